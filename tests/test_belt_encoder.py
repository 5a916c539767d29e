"""The belt encoder fused into the cloth filter (belt_odometry.BeltOdometry): a belt that stops
while the cameras are too close to see it is predicted standing; vision keeps the position."""

from __future__ import annotations

import numpy as np
import pytest

from robot_app.control.belt_odometry import BeltOdometry
from robot_app.control.pose_filter import PoseFilter, UpdateReason

RATE = 15.0  # vision frames per second
LATENCY = 0.11  # [s] from exposure to the result
DT = 1.0 / 240.0  # control period [s]
DIRECTION = np.array([np.cos(np.radians(120.0)), np.sin(np.radians(120.0))])


def belt_speed(t: float) -> float:
    """50 mm/s, braking at 0.5 m/s^2 from 2.2 s: standing from 2.3 s (the stop test's belt)."""
    return float(np.clip(0.05 - 0.5 * (t - 2.2), 0.0, 0.05))


def belt_travel(t: float) -> float:
    """Distance [m] the belt moved by `t` [s]."""
    braking = float(np.clip(t - 2.2, 0.0, 0.1))
    return 0.05 * min(t, 2.2) + 0.05 * braking - 0.25 * braking**2


class FakeEncoder:
    def __init__(self, std: float, seed: int, belt_x_max: float = np.inf) -> None:
        self.std, self.time, self.belt_x_max = std, 0.0, belt_x_max
        self.rng = np.random.default_rng(seed)

    def velocity(self) -> np.ndarray:
        return belt_speed(self.time) * DIRECTION + self.rng.normal(0.0, self.std, 2)

    def carries(self, xy: np.ndarray) -> bool:
        return float(xy[0]) <= self.belt_x_max


def run(
    encoder: FakeEncoder | None, *, last_frame: float, until: float, push: tuple[float, float] | None = None
) -> tuple[PoseFilter, BeltOdometry | None, float]:
    """Vision at RATE (3.5 mm noise) up to exposures at `last_frame`, the encoder every
    control period, results LATENCY late; returns the filter, the odometry and the truth's
    offset added by `push` (time, dx [m])."""
    rng = np.random.default_rng(5)
    pose_filter = PoseFilter()
    odometry = BeltOdometry(encoder, 100.0) if encoder is not None else None
    exposures = list(np.arange(0.0, last_frame + 1e-9, 1.0 / RATE))
    pending: list[tuple[float, np.ndarray]] = []

    def truth(t: float) -> np.ndarray:
        shift = push[1] if push is not None and t >= push[0] else 0.0
        xy = belt_travel(t) * DIRECTION + [shift, 0.0]
        return np.array([*xy, 0.7, 0.3])

    t = 0.0
    while t <= until:
        if encoder is not None:
            encoder.time = t
        if exposures and exposures[0] <= t:
            exposed = exposures.pop(0)
            pending.append((exposed, truth(exposed) + np.array([*rng.normal(0, 0.0035, 2), 0.0, 0.0])))
        if odometry is not None:
            odometry.sample(t, pose_filter)
        while pending and pending[0][0] + LATENCY <= t:
            exposed, z = pending.pop(0)
            if odometry is not None:
                odometry.fuse_until(pose_filter, exposed)
            pose_filter.update(z, 0.9, exposed)
        t += DT
    return pose_filter, odometry, float(push[1]) if push else 0.0


def predicted_xy(pose_filter: PoseFilter, odometry: BeltOdometry | None, t: float) -> np.ndarray:
    estimate = odometry.estimate_at(pose_filter, t) if odometry else pose_filter.estimate_at(t)
    return np.array([estimate.x, estimate.y])


@pytest.mark.parametrize("seed", range(5))
def test_a_belt_stopping_after_the_last_frame_is_predicted_standing(seed: int) -> None:
    """The last frame is exposed at 2.1 s; the belt stops at 2.3 s; the fingers close at 2.97 s."""
    encoder = FakeEncoder(0.002, seed)
    pose_filter, odometry, _ = run(encoder, last_frame=2.1, until=2.97)
    truth = belt_travel(2.97) * DIRECTION
    assert np.linalg.norm(predicted_xy(pose_filter, odometry, 2.97) - truth) < 0.004
    estimate = odometry.estimate_at(pose_filter, 2.97)  # type: ignore[union-attr]
    assert np.linalg.norm(estimate.velocity[:2]) < 0.005  # standing, not at the old 50 mm/s
    # vision alone carries the cloth on at 50 mm/s through the stop (the known gap)
    alone, _, _ = run(None, last_frame=2.1, until=2.97)
    assert np.linalg.norm(predicted_xy(alone, None, 2.97) - truth) > 0.02


def test_predictions_do_not_change_the_filter_and_samples_wait_for_later_exposures() -> None:
    encoder = FakeEncoder(0.002, 1)
    pose_filter, odometry, _ = run(encoder, last_frame=2.1, until=2.5)
    assert odometry is not None and odometry.samples  # taken after the last exposure, not fused
    time, state = pose_filter.estimate.time, pose_filter.estimate.position  # type: ignore[union-attr]
    assert time <= 2.1 + 1e-9
    odometry.estimate_at(pose_filter, 2.6)
    assert pose_filter.estimate.time == time  # type: ignore[union-attr]
    np.testing.assert_array_equal(pose_filter.estimate.position, state)  # type: ignore[union-attr]
    odometry.fuse_until(pose_filter, 2.4)  # a late frame exposed at 2.4 s would come next
    assert 2.39 < pose_filter.estimate.time <= 2.4  # type: ignore[union-attr]
    assert all(t > 2.4 for t, _ in odometry.samples)


def test_a_cloth_pushed_across_the_running_belt_is_followed_by_vision() -> None:
    """Pushed 30 mm across the belt at 1.5 s: the encoder does not see it; vision relocates
    the position, and the velocity stays the belt's."""
    encoder = FakeEncoder(0.002, 2)
    pose_filter, odometry, shift = run(encoder, last_frame=3.0, until=3.2, push=(1.5, 0.03))
    truth = belt_travel(3.2) * DIRECTION + [shift, 0.0]
    assert np.linalg.norm(predicted_xy(pose_filter, odometry, 3.2) - truth) < 0.004


def test_off_the_belt_the_encoder_is_not_used() -> None:
    """A cloth past the belt's edge (x beyond it) is not carried: no sample is taken."""
    encoder = FakeEncoder(0.002, 3, belt_x_max=-1.0)
    pose_filter, odometry, _ = run(encoder, last_frame=2.1, until=2.97)
    assert odometry is not None and not odometry.samples
    alone, _, _ = run(None, last_frame=2.1, until=2.97)
    np.testing.assert_allclose(
        predicted_xy(pose_filter, odometry, 2.97), predicted_xy(alone, None, 2.97), atol=1e-12
    )


def test_fusing_velocities_needs_a_filter_and_a_noise() -> None:
    with pytest.raises(RuntimeError):
        PoseFilter().fuse_velocities([(0.1, np.zeros(2))], 0.002)
    pose_filter = PoseFilter()
    assert pose_filter.update([0.0, 0.0, 0.7, 0.0], 0.9, 0.0).reason is UpdateReason.INITIALISED
    with pytest.raises(ValueError):
        pose_filter.fuse_velocities([(0.1, np.zeros(2))], 0.0)
    with pytest.raises(ValueError):
        BeltOdometry(FakeEncoder(0.002, 0), 0.0)
