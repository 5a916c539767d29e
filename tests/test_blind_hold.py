"""The blind hand's aim (`control/blind_hold.py`): a still cloth's velocity noise is not
integrated, a belt's motion is."""

from __future__ import annotations

import numpy as np
import pytest

from robot_app.control.blind_hold import MOTION_CONFIDENCE, blind_estimate, chi2_quantile_2dof, moving
from robot_app.control.pose_filter import PoseEstimate, PoseFilter, PoseFilterSettings

PERIOD = 0.1  # [s] between fused recognitions
TRACKED = 3.0  # [s] of views before the cameras go blind
BLIND = 0.9  # [s] of blind descent (bench_pick_place episode 64)
RUNS = 200


def _filtered(speed: float, seed: int) -> PoseEstimate:
    """The filter after TRACKED s of noisy recognitions (the filter's own measurement
    stds) of a cloth moving along x at `speed` [m/s]."""
    settings = PoseFilterSettings()
    rng = np.random.default_rng(seed)
    xy, z, yaw = settings.measurement_std_xy, settings.measurement_std_z, settings.measurement_std_yaw
    std = np.array([xy, xy, z, yaw])
    f = PoseFilter(settings)
    f.reset(np.array([0.5, 0.1, 0.0, 0.3]) + std * rng.standard_normal(4), 0.0)
    for k in range(1, round(TRACKED / PERIOD) + 1):
        t = k * PERIOD
        f.update(np.array([0.5 + speed * t, 0.1, 0.0, 0.3]) + std * rng.standard_normal(4), 0.9, t)
    estimate = f.estimate
    assert estimate is not None
    return estimate


def _aim(f_estimate: PoseEstimate, t: float) -> PoseEstimate:
    # the prediction as the filter makes it: constant velocity from the last estimate
    dt = t - f_estimate.time
    predicted = PoseEstimate(
        f_estimate.x + dt * float(f_estimate.velocity[0]),
        f_estimate.y + dt * float(f_estimate.velocity[1]),
        f_estimate.z + dt * float(f_estimate.velocity[2]),
        f_estimate.yaw + dt * f_estimate.yaw_rate,
        f_estimate.velocity,
        f_estimate.yaw_rate,
        f_estimate.covariance,
        t,
    )
    return blind_estimate(f_estimate, t, predicted)


def test_the_chi_square_quantile_is_the_tabulated_one() -> None:
    assert chi2_quantile_2dof(0.95) == pytest.approx(5.991, abs=1e-3)
    assert chi2_quantile_2dof(0.99) == pytest.approx(9.210, abs=1e-3)
    with pytest.raises(ValueError):
        chi2_quantile_2dof(1.0)


def test_a_still_cloth_is_held_where_it_was_filtered_and_misses_less_than_the_prediction() -> None:
    held_errors, predicted_errors, judged_moving = [], [], 0
    for seed in range(RUNS):
        last = _filtered(0.0, seed)
        judged_moving += moving(last)
        t = last.time + BLIND
        aim = _aim(last, t)
        held_errors.append(float(np.hypot(aim.x - 0.5, aim.y - 0.1)))
        drift = last.velocity[:2] * BLIND
        predicted_errors.append(float(np.hypot(last.x + drift[0] - 0.5, last.y + drift[1] - 0.1)))
    # false alarms at most the test's level (plus three binomial standard deviations)
    level = 1.0 - MOTION_CONFIDENCE
    assert judged_moving / RUNS <= level + 3.0 * np.sqrt(level * (1.0 - level) / RUNS)
    assert np.median(held_errors) < 0.6 * np.median(predicted_errors)
    assert np.percentile(held_errors, 95) < np.percentile(predicted_errors, 95)


@pytest.mark.parametrize("speed", [0.05, 0.1])
def test_a_cloth_on_the_belt_is_carried_on_at_its_velocity(speed: float) -> None:
    errors, judged_still = [], 0
    for seed in range(RUNS):
        last = _filtered(speed, seed)
        judged_still += not moving(last)
        t = last.time + BLIND
        aim = _aim(last, t)
        truth_x = 0.5 + speed * t
        errors.append(float(np.hypot(aim.x - truth_x, aim.y - 0.1)))
    assert judged_still == 0
    # held, the aim would be speed * BLIND (45 mm or more) behind the cloth
    assert max(errors) < 0.5 * speed * BLIND
