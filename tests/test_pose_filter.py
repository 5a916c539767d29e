"""Behaviour of the cloth pose filter against simulated ground truth."""

from __future__ import annotations

import math

import numpy as np
import pytest
from filterpy.stats import NEES

from robot_app.config import load_config
from robot_app.control.pose_filter import (
    PoseFilter,
    PoseFilterSettings,
    PoseXYZYaw,
    UpdateReason,
)
from robot_app.errors import ConfigError
from robot_app.geometry import make_transform, rotation_about_z, rotation_from_rpy, wrap_angle, yaw_of

SETTINGS = PoseFilterSettings()
STD_XY, STD_Z, STD_YAW = SETTINGS.measurement_std_xy, SETTINGS.measurement_std_z, SETTINGS.measurement_std_yaw
NOISE_STD = np.array([STD_XY, STD_XY, STD_Z, STD_YAW])


def noisy(rng: np.random.Generator, truth: np.ndarray) -> np.ndarray:
    measured = truth + rng.normal(0.0, NOISE_STD)
    measured[3] = wrap_angle(measured[3])
    return measured


def error_of(estimate_state: np.ndarray, truth: np.ndarray) -> np.ndarray:
    error = estimate_state - truth
    error[3] = wrap_angle(error[3])
    return error


def state_of(filter_: PoseFilter) -> np.ndarray:
    e = filter_.estimate
    assert e is not None
    return np.array([e.x, e.y, e.z, e.yaw, *e.velocity, e.yaw_rate])


def test_converges_to_a_constant_pose_under_noise() -> None:
    rng = np.random.default_rng(1)
    truth = np.array([0.12, -0.05, 0.02, 2.0])
    pose_filter = PoseFilter()
    errors = []
    for k in range(60):
        update = pose_filter.update(noisy(rng, truth), fitness=0.8, t=0.1 * k)
        assert update.accepted
        errors.append(np.abs(error_of(state_of(pose_filter)[:4], truth)))
    assert pose_filter.accepted_count == 60 and pose_filter.rejected_count == 0
    estimate = pose_filter.estimate
    assert estimate is not None
    sigma = np.sqrt(np.diag(estimate.covariance)[:4])
    assert np.all(errors[-1] < 3.0 * sigma)  # within its own 3 sigma ...
    assert np.all(sigma < 0.7 * NOISE_STD)  # ... which is tighter than one measurement's
    rms = np.sqrt(np.mean(np.square(errors[-40:]), axis=0))
    assert np.all(rms < 0.8 * NOISE_STD)  # and the errors really are smaller
    np.testing.assert_allclose(estimate.velocity, 0.0, atol=3 * np.sqrt(estimate.covariance[4, 4]))


def test_tracks_a_constant_velocity_motion_through_the_yaw_wrap() -> None:
    rng = np.random.default_rng(2)
    start = np.array([-0.1, 0.05, 0.0, 2.5])
    rates = np.array([0.04, -0.02, 0.0, 0.4])  # [m/s, m/s, m/s, rad/s]; yaw passes pi at 1.6 s
    pose_filter = PoseFilter()
    for k in range(81):
        t = 0.05 * k
        truth = start + rates * t
        truth[3] = wrap_angle(truth[3])
        assert pose_filter.update(noisy(rng, truth), fitness=0.9, t=t).accepted
        estimate = pose_filter.estimate
        assert estimate is not None and -math.pi <= estimate.yaw < math.pi  # the state stays wrapped
    state = state_of(pose_filter)
    error = error_of(state[:4], truth)
    assert np.all(np.abs(error[:3]) < 3e-3) and abs(error[3]) < math.radians(1.5)
    np.testing.assert_allclose(state[4:7], rates[:3], atol=6e-3)
    assert state[7] == pytest.approx(rates[3], abs=0.05)


def test_yaw_residual_is_taken_on_the_circle() -> None:
    pose_filter = PoseFilter()
    pose_filter.reset(PoseXYZYaw(0.0, 0.0, 0.0, math.radians(179.0)), t=0.0)
    predicted = pose_filter.estimate_at(0.1)
    innovation_var = predicted.covariance[3, 3] + SETTINGS.measurement_std_yaw**2
    update = pose_filter.update(PoseXYZYaw(0.0, 0.0, 0.0, math.radians(-179.0)), fitness=0.9, t=0.1)
    assert update.accepted and update.reason is UpdateReason.ACCEPTED
    # The innovation is +2 deg, not -358 deg; the position innovation is zero.
    assert update.nis == pytest.approx(math.radians(2.0) ** 2 / innovation_var, rel=1e-9)
    assert update.estimate is not None
    assert 0.0 < wrap_angle(update.estimate.yaw - math.radians(179.0)) < math.radians(2.0)
    assert update.estimate.yaw_rate > 0.0


@pytest.mark.parametrize("turn_deg", [180.0, 90.0, -90.0])
def test_a_symmetric_cloth_turned_by_its_symmetry_is_the_same_pose(turn_deg: float) -> None:
    """A plain rectangle recognised half turned (or a square quarter turned) is no yaw jump
    for a filter that knows the cloth's symmetry; it is one for a filter that does not."""
    symmetry = (math.pi,) if abs(turn_deg) == 180.0 else (math.pi / 2, math.pi, -math.pi / 2)
    knowing, unaware = PoseFilter(symmetry_angles=symmetry), PoseFilter()
    start = PoseXYZYaw(0.4, 0.1, 0.0, math.radians(30.0))
    for pose_filter in (knowing, unaware):
        pose_filter.reset(start, t=0.0)
    turned = PoseXYZYaw(0.4, 0.1, 0.0, math.radians(30.5 + turn_deg))
    update = knowing.update(turned, fitness=0.9, t=0.1)
    assert update.accepted and update.estimate is not None
    assert 0.0 < wrap_angle(update.estimate.yaw - math.radians(30.0)) < math.radians(0.5)  # kept its branch
    assert unaware.update(turned, fitness=0.9, t=0.1).reason is UpdateReason.YAW_JUMP
    # a real 60 deg jump stays a jump for the knowing filter too
    jumped = PoseXYZYaw(0.4, 0.1, 0.0, math.radians(90.0 + (turn_deg if abs(turn_deg) == 180.0 else 0.0)))
    assert knowing.update(jumped, fitness=0.9, t=0.2).reason is UpdateReason.YAW_JUMP


def test_outliers_and_low_fitness_are_rejected_and_counted() -> None:
    rng = np.random.default_rng(3)
    truth = np.array([0.0, 0.1, 0.01, -0.5])
    pose_filter, twin = PoseFilter(), PoseFilter()  # the twin never sees the outliers
    for k in range(30):
        measurement = noisy(rng, truth)
        pose_filter.update(measurement, fitness=0.8, t=0.1 * k)
        twin.update(measurement, fitness=0.8, t=0.1 * k)
    outliers = [
        (truth + np.array([0.2, 0.0, 0.0, 0.0]), 0.8, UpdateReason.POSITION_JUMP),
        (truth + np.array([0.0, 0.0, 0.0, math.radians(60.0)]), 0.8, UpdateReason.YAW_JUMP),
        (truth + np.array([0.025, 0.0, 0.0, 0.0]), 0.8, UpdateReason.MAHALANOBIS),  # 7 sigma, < 5 cm
        (truth + np.array([0.2, 0.0, 0.0, 0.0]), SETTINGS.min_fitness - 0.01, UpdateReason.LOW_FITNESS),
    ]
    for n, (measurement, fitness, reason) in enumerate(outliers, start=1):
        update = pose_filter.update(measurement, fitness, t=2.9 + 0.1 * n)
        assert not update.accepted and update.reason is reason
        assert pose_filter.rejected_count == n and pose_filter.consecutive_rejections == n
    # a poor recognition where the cloth should be is not fused, and does not count toward lost
    update = pose_filter.update(truth, SETTINGS.min_fitness - 0.01, t=3.4)
    assert not update.accepted and update.reason is UpdateReason.LOW_FITNESS_CONSISTENT
    assert pose_filter.rejected_count == 5 and pose_filter.consecutive_rejections == 4
    assert pose_filter.accepted_count == 30 and not pose_filter.lost
    # A rejected measurement only moves the filter's time: it equals the twin's prediction.
    twin.predict(3.4)
    np.testing.assert_allclose(state_of(pose_filter), state_of(twin), atol=1e-15)
    assert pose_filter.update(noisy(rng, truth), 0.8, t=3.5).accepted
    assert pose_filter.consecutive_rejections == 0 and pose_filter.rejected_count == 5


def test_a_lost_filter_reinitialises_on_the_next_good_recognition() -> None:
    pose_filter = PoseFilter(PoseFilterSettings(max_consecutive_rejections=3))
    pose_filter.reset(PoseXYZYaw(0.0, 0.0, 0.0, 0.0), t=0.0)
    moved = PoseXYZYaw(0.3, -0.1, 0.0, 1.0)  # e.g. the cloth was carried away
    for k in range(1, 4):
        update = pose_filter.update(moved, fitness=0.9, t=0.1 * k)
        assert not update.accepted and update.reason is UpdateReason.POSITION_JUMP
    assert pose_filter.lost
    update = pose_filter.update(moved, fitness=0.9, t=0.4)
    assert update.accepted and update.reason is UpdateReason.REINITIALISED
    assert update.estimate is not None and update.estimate.time == pytest.approx(0.4)
    np.testing.assert_allclose(update.estimate.position, moved[:3])
    assert not pose_filter.lost and pose_filter.rejected_count == 3


def test_a_changing_period_rebuilds_f_and_q() -> None:
    start = PoseXYZYaw(0.1, 0.2, 0.0, 0.3)
    stepwise, direct = PoseFilter(), PoseFilter()
    for pose_filter in (stepwise, direct):
        pose_filter.reset(start, t=1.0)
        pose_filter.update(PoseXYZYaw(0.102, 0.199, 0.0, 0.31), fitness=0.9, t=1.1)  # some velocity
    stepwise.predict(1.15)
    assert stepwise.period == pytest.approx(0.05)
    F = stepwise.transition_matrix
    np.testing.assert_allclose(np.diag(F[:4, 4:]), 0.05)
    q = SETTINGS.position_process_psd
    expected_q = np.array([[0.05**3 / 3, 0.05**2 / 2], [0.05**2 / 2, 0.05]]) * q
    np.testing.assert_allclose(stepwise.process_noise[np.ix_([0, 4], [0, 4])], expected_q, rtol=1e-12)
    assert stepwise.process_noise[3, 3] == pytest.approx(SETTINGS.yaw_process_psd * 0.05**3 / 3)
    final = stepwise.predict(1.45)
    assert stepwise.period == pytest.approx(0.3) and stepwise.transition_matrix[0, 4] == pytest.approx(0.3)
    # Exact discretisation: 0.05 s then 0.3 s equals one prediction of 0.35 s.
    peek = direct.estimate_at(1.45)
    assert direct.estimate is not None
    assert direct.estimate.time == pytest.approx(1.1)  # peeking changes nothing
    once = direct.predict(1.45)
    for a, b in ((final, once), (peek, once)):
        np.testing.assert_allclose([a.x, a.y, a.z, a.yaw], [b.x, b.y, b.z, b.yaw], atol=1e-12)
        np.testing.assert_allclose(a.covariance, b.covariance, rtol=1e-9, atol=1e-15)


def test_estimates_are_statistically_consistent() -> None:
    # Truth drawn from the filter's own model: the mean NEES must be the state dimension.
    rng = np.random.default_rng(4)
    dt, steps, runs = 0.1, 60, 30
    nees = []
    for _ in range(runs):
        no_gates = PoseFilterSettings(gate_chi2=1e9, max_position_jump=10.0, max_yaw_jump=math.pi)
        pose_filter = PoseFilter(no_gates)
        truth = np.array([0.0, 0.0, 0.0, rng.uniform(-math.pi, math.pi), 0.0, 0.0, 0.0, 0.0])
        pose_filter.update(noisy(rng, truth[:4]), 0.9, t=0.0)
        truth[4:] = rng.normal(0.0, [SETTINGS.initial_velocity_std] * 3 + [SETTINGS.initial_yaw_rate_std])
        pose_filter.predict(dt)
        F, chol_Q = pose_filter.transition_matrix, np.linalg.cholesky(pose_filter.process_noise)
        for k in range(1, steps):
            truth = F @ truth + chol_Q @ rng.standard_normal(8)
            pose_filter.update(noisy(rng, truth[:4]), 0.9, t=k * dt)
            if k > 10:
                estimate = pose_filter.estimate
                assert estimate is not None
                error = error_of(state_of(pose_filter), truth)
                nees.append(NEES(error[None], np.zeros((1, 8)), [estimate.covariance])[0])
    assert 7.2 < np.mean(nees) < 8.8, np.mean(nees)


def test_transform_round_trip_with_the_cloth_z_into_the_table() -> None:
    pose = make_transform(rotation_about_z(2.8) @ np.diag([1.0, -1.0, -1.0]), [0.1, -0.2, 0.01])
    pose_filter = PoseFilter()
    estimate = pose_filter.reset(pose, t=0.0)
    assert estimate.yaw == pytest.approx(2.8)
    np.testing.assert_allclose(estimate.as_transform(), pose, atol=1e-12)
    np.testing.assert_allclose(estimate.as_transform(z_down=False)[:3, :3], rotation_about_z(2.8), atol=1e-12)
    tilted = make_transform(rotation_about_z(-1.0) @ rotation_from_rpy(math.pi + 0.1, 0.05, 0.0), [0, 0, 0])
    assert yaw_of(pose_filter.reset(tilted, t=1.0).as_transform()[:3, :3]) == pytest.approx(
        yaw_of(tilted[:3, :3]), abs=1e-12
    )


def test_bad_settings_are_config_errors() -> None:
    for override, key, value in (
        ("measurement_std_xy=-0.01", "measurement_std_xy", -0.01),
        ("position_process_psd=0", "position_process_psd", 0),
        ("max_consecutive_rejections=0", "max_consecutive_rejections", 0),
        ("gate=3", "gate", 3),
    ):
        with pytest.raises(ConfigError) as bad:
            load_config(PoseFilterSettings, None, [override])
        assert (bad.value.key, bad.value.value) == (key, value)
    assert bad.value.problems[0].problem == "unknown key"


def test_bad_inputs_are_input_errors() -> None:
    pose_filter = PoseFilter()
    with pytest.raises(RuntimeError, match="not initialised"):
        pose_filter.predict(1.0)
    with pytest.raises(ValueError, match=r"\(x, y, z, yaw\) or a 4x4"):
        pose_filter.update(np.zeros(3), 0.9, t=0.0)
    with pytest.raises(ValueError, match="rotation"):
        pose_filter.update(np.full((4, 4), 2.0), 0.9, t=0.0)
    with pytest.raises(ValueError, match="finite"):
        pose_filter.update(np.zeros(4), float("nan"), t=0.0)
    pose_filter.update(np.zeros(4), 0.9, t=1.0)
    with pytest.raises(ValueError, match="went back"):
        pose_filter.update(np.zeros(4), 0.9, t=0.5)
    with pytest.raises(ValueError, match="went back"):
        pose_filter.predict(0.9)


def test_two_looks_start_the_filter_moving_with_the_difference_covariance() -> None:
    pose_filter = PoseFilter()
    first, second = PoseXYZYaw(0.50, 0.10, 0.0, math.pi - 0.01), PoseXYZYaw(0.505, 0.11, 0.0, -math.pi + 0.01)
    estimate = pose_filter.reset_from_two(first, 1.0, second, 1.1)
    np.testing.assert_allclose(estimate.position, second[:3])
    np.testing.assert_allclose(estimate.velocity, [0.05, 0.1, 0.0], atol=1e-12)
    assert estimate.yaw_rate == pytest.approx(0.2)  # across the +-pi seam: +0.02 rad in 0.1 s
    variance_xy = SETTINGS.measurement_std_xy**2
    assert estimate.covariance[4, 4] == pytest.approx(2 * variance_xy / 0.1**2)
    assert estimate.covariance[0, 4] == pytest.approx(variance_xy / 0.1)
    np.testing.assert_allclose(np.linalg.eigvalsh(estimate.covariance).min() > 0, True)
    later = pose_filter.estimate_at(1.5)
    np.testing.assert_allclose(later.position, [0.525, 0.15, 0.0], atol=1e-12)
    with pytest.raises(ValueError):
        pose_filter.reset_from_two(first, 1.0, second, 1.0)


def test_every_update_reports_its_distance_from_the_prediction() -> None:
    """`distance` is the measured minus predicted x-y position, whatever the gates decided:
    an untrusted view of a pushed cloth is fused with little weight, but is still far."""
    pose_filter = PoseFilter()
    truth = np.array([0.1, 0.2, 0.01, 0.3])
    assert math.isnan(pose_filter.update(truth, 0.8, t=0.0).distance)  # nothing predicted yet
    for k in range(1, 20):
        update = pose_filter.update(truth, 0.8, t=0.1 * k)
        assert update.distance == pytest.approx(0.0, abs=1e-6)
    pushed = truth + np.array([0.024, -0.007, 0.0, 0.0])
    fused_far = pose_filter.update(pushed, 0.8, t=2.0, trusted=False)  # within the widened gate
    assert fused_far.accepted and fused_far.distance == pytest.approx(0.025, abs=1e-6)
    estimate = fused_far.estimate
    assert estimate is not None and np.hypot(estimate.x - pushed[0], estimate.y - pushed[1]) > 0.012
    jumped = pose_filter.update(truth + np.array([0.2, 0.0, 0.0, 0.0]), 0.8, t=2.1)
    assert not jumped.accepted and jumped.reason is UpdateReason.POSITION_JUMP
    assert jumped.distance > 0.17
    low = pose_filter.update(truth, SETTINGS.min_fitness - 0.01, t=2.2)
    assert low.reason is UpdateReason.LOW_FITNESS_CONSISTENT and low.distance < 0.01
