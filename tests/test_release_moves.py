"""The release into the box: the lowering that slows down without a stop
(`trajectory.plan_slowing_down`, `JobMotion.move_slowing_down`) and the hand camera's
watch for the cloth coming to rest after letting go (`release_watch`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from robot_app.control.arm_motion import ArmMotion
from robot_app.control.job_motion import JobMotion
from robot_app.control.kinematics import Kinematics
from robot_app.control.limits import JointLimits, TrajectorySettings, check_limits
from robot_app.control.logged_cell import LoggedCell
from robot_app.control.loop_settings import LoopSettings
from robot_app.control.release_watch import image_change, wait_until_settled
from robot_app.control.trajectory import plan_point_to_point, plan_slowing_down
from robot_app.sim.config import DEFAULT_URDF, RobotSettings

DT = 1.0 / 240.0
SLOW = 0.3  # loop.release_speed


# --- the joined lowering, in joint space -------------------------------------------------


def _limits() -> JointLimits:
    return JointLimits.from_urdf(DEFAULT_URDF, TrajectorySettings())


def _samples(trajectory, dt: float = DT):  # type: ignore[no-untyped-def]
    steps = round(trajectory.duration / dt)
    states = [trajectory.sample(k * dt) for k in range(steps + 1)]
    times = np.arange(steps + 1) * dt
    return (
        times,
        np.array([s.q for s in states]),
        np.array([s.v for s in states]),
        np.array([s.a for s in states]),
    )


def test_the_joined_move_is_the_slow_one_wherever_it_must_be_slow_and_faster_overall() -> None:
    limits = _limits()
    q_start = np.array(RobotSettings().home_joints)
    q_goal = q_start + np.array([0.3, 0.4, 0.0, -0.5, 0.0, 0.3, 0.2])
    # slow once joint S2 has come 60 % of its way
    threshold = q_start[1] + 0.6 * (q_goal[1] - q_start[1])

    def slow_from(q: np.ndarray) -> bool:
        return bool(q[1] >= threshold)

    slow = plan_point_to_point(q_start, q_goal, limits.scaled(SLOW), dt=DT)
    joined = plan_slowing_down(q_start, q_goal, limits, limits.scaled(SLOW), slow_from, dt=DT)
    assert joined.fast is not None
    assert joined.duration < slow.duration - 0.1
    times, Q, V, A = _samples(joined)
    assert check_limits(times, Q, V, A, limits, tol=1e-6).ok
    np.testing.assert_allclose(Q[-1], q_goal, atol=1e-9)
    np.testing.assert_allclose(V[-1], 0.0, atol=1e-9)
    # no jump where the fast part hands over: positions and velocities continue smoothly
    assert np.max(np.abs(np.diff(V, axis=0))) <= np.max(limits.acceleration) * DT * 1.01
    # wherever the move must be slow, it is within the slow limits, and it is the slow
    # move's own from the hand-over on
    in_zone = np.array([slow_from(q) for q in Q])
    assert in_zone.any()
    assert np.all(np.abs(V[in_zone]) <= limits.scaled(SLOW).velocity + 1e-9)
    assert np.all(np.abs(A[in_zone]) <= limits.scaled(SLOW).acceleration + 1e-9)
    first = int(np.argmax(in_zone))
    assert not in_zone[:first].any()
    slow_times = joined.handover + (times[first:] - times[first])
    for t, q, v in zip(slow_times, Q[first:], V[first:], strict=True):
        state = slow.sample(t)
        np.testing.assert_allclose(q, state.q, atol=1e-9)
        np.testing.assert_allclose(v, state.v, atol=1e-9)


def test_a_move_that_starts_where_it_must_be_slow_is_the_slow_move() -> None:
    limits = _limits()
    q_start = np.array(RobotSettings().home_joints)
    q_goal = q_start + 0.2
    joined = plan_slowing_down(q_start, q_goal, limits, limits.scaled(SLOW), lambda q: True, dt=DT)
    slow = plan_point_to_point(q_start, q_goal, limits.scaled(SLOW), dt=DT)
    assert joined.fast is None
    assert joined.duration == pytest.approx(slow.duration)


# --- the lowering over the box, through the arm's kinematics ----------------------------


class _StillCell:
    """A cell whose arm goes exactly where commanded (no simulator)."""

    def __init__(self, q: np.ndarray) -> None:
        self.dt, self.time, self.q = DT, 0.0, q.copy()

    def step(self) -> None:
        self.time += self.dt

    def joint_positions(self) -> np.ndarray:
        return self.q.copy()

    def command_joints(self, q: np.ndarray, dq: np.ndarray) -> None:
        self.q = np.array(q, dtype=float)

    def collisions(self) -> int:
        return 0


def _lowering(slowing: bool, below: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """TCP positions (K, 3) and commanded joints (K, 7), velocities, of a lowering from 0.40 m
    over the colours box to 0.07 m, as the RELEASE does it."""
    kinematics = Kinematics.from_urdf(DEFAULT_URDF, "base_link", "tcp")
    limits = _limits()
    home = np.array(RobotSettings().home_joints)
    cell = LoggedCell(_StillCell(home))  # type: ignore[arg-type]
    motion = JobMotion(cell, kinematics, limits, home)
    over, low = np.array([0.30, -0.56, 0.40]), np.array([0.30, -0.56, 0.07])
    motion.move_tcp(over)
    first = cell.samples
    q_low = motion.solve_tcp(low)
    if slowing:
        motion.move_slowing_down(q_low, SLOW, below)
    else:
        motion.move_to_joints(q_low, speed=SLOW)
    Q, V = np.array(cell._q[first:]), np.array(cell._v[first:])
    tcp = np.array([kinematics.frame_pose(q, "tcp")[:3, 3] for q in Q])
    return tcp, Q, V


def test_the_lowering_into_the_box_is_slow_below_the_given_height_and_shorter() -> None:
    below = 0.24  # e.g. a cloth hanging 0.12 m, its lowest point 0.1 m above the floor
    tcp_old, _, _ = _lowering(False, below)
    tcp_new, _, v_new = _lowering(True, below)
    limits = _limits().scaled(SLOW)
    assert len(tcp_new) < len(tcp_old) - 0.1 / DT  # at least 0.1 s shorter
    low_new = tcp_new[:, 2] <= below
    assert np.all(np.abs(v_new[low_new]) <= limits.velocity + 1e-9)
    # the TCP is no faster below that height than the old, all-slow lowering was there
    speed_new = np.linalg.norm(np.diff(tcp_new, axis=0), axis=1) / DT
    speed_old = np.linalg.norm(np.diff(tcp_old, axis=0), axis=1) / DT
    low_old = tcp_old[:, 2] <= below
    assert speed_new[low_new[1:] & low_new[:-1]].max() <= speed_old[low_old[1:] & low_old[:-1]].max() + 1e-6
    # and its path is the old one's: no farther off the vertical over the box's middle (the
    # joint-space path bows 22 mm either way) than 1 mm more
    off_new = np.hypot(tcp_new[:, 0] - 0.30, tcp_new[:, 1] + 0.56)
    off_old = np.hypot(tcp_old[:, 0] - 0.30, tcp_old[:, 1] + 0.56)
    assert off_new.max() <= off_old.max() + 0.001, (off_new.max(), off_old.max())
    np.testing.assert_allclose(tcp_new[-1], tcp_old[-1], atol=1e-6)


# --- the watch after letting go ----------------------------------------------------------


@dataclass
class _Frame:
    right_bgr: np.ndarray
    time: float
    available_time: float


class _WatchedCell:
    """Frames of a cloth (a bright square) that moves until `rest_at` [s], with noise."""

    def __init__(self, rest_at: float, latency: float = 0.05, noise: float = 2.5) -> None:
        self.dt, self.time = DT, 0.0
        self.rest_at, self.latency, self.noise = rest_at, latency, noise
        self.rng = np.random.default_rng(0)
        self.captures: list[float] = []

    def capture(self) -> _Frame:
        self.captures.append(self.time)
        image = np.full((240, 320, 3), 90.0)
        x = 40 + int(300 * min(self.time, self.rest_at))  # 300 px/s while it moves
        image[80:160, x % 240 : x % 240 + 60] = 220.0
        image += self.rng.normal(0.0, self.noise, image.shape)
        return _Frame(np.clip(image, 0, 255).astype(np.uint8), self.time, self.time + self.latency)


class _Hand:
    def __init__(self, cell: _WatchedCell) -> None:
        self.cell = cell

    def hold(self, duration: float) -> None:
        for _ in range(round(duration / self.cell.dt)):
            self.cell.time += self.cell.dt


WATCH = {"rate_hz": 15.0, "longest": 1.0, "threshold": 25.0, "share": 0.002, "frames": 2}


def test_the_fingers_open_once_the_cloth_is_seen_at_rest() -> None:
    cell = _WatchedCell(rest_at=0.4)
    watch = wait_until_settled(_Hand(cell), cell, **WATCH)  # type: ignore[arg-type]
    assert watch.settled
    # two still pairs need three frames after it stopped, each waited for until it arrived
    assert 0.4 + 2 / 15 + 0.05 - 0.01 <= watch.waited <= 0.4 + 3 / 15 + 0.05 + 0.01
    assert watch.waited < 1.0
    assert np.all(np.diff(cell.captures) > 0)  # never the same frame twice


def test_a_cloth_still_moving_keeps_the_fingers_closed_for_the_longest_wait_only() -> None:
    cell = _WatchedCell(rest_at=5.0)
    watch = wait_until_settled(_Hand(cell), cell, **WATCH)  # type: ignore[arg-type]
    assert not watch.settled
    assert watch.waited == pytest.approx(1.0, abs=DT)
    assert watch.last_change > WATCH["share"]


def test_a_frame_counts_only_once_it_has_arrived() -> None:
    cell = _WatchedCell(rest_at=0.0, latency=0.3)
    watch = wait_until_settled(_Hand(cell), cell, **WATCH)  # type: ignore[arg-type]
    assert watch.settled
    assert watch.waited >= 0.3 + 2 / 15 - 0.01  # the third frame's arrival, not its exposure


def test_camera_noise_alone_is_no_change_and_a_moved_cloth_is() -> None:
    rng = np.random.default_rng(1)
    still = np.full((240, 320, 3), 120.0)
    a = np.clip(still + rng.normal(0, 2.5, still.shape), 0, 255).astype(np.uint8)
    b = np.clip(still + rng.normal(0, 2.5, still.shape), 0, 255).astype(np.uint8)
    assert image_change(a, b, 25.0) == 0.0
    moved = b.copy()
    moved[100:140, 100:140] = 250
    assert image_change(a, moved, 25.0) == pytest.approx(40 * 40 / (240 * 320), rel=0.2)
    with pytest.raises(ValueError, match="sizes"):
        image_change(a, b[:100], 25.0)


def test_the_release_takes_the_top_of_what_lies_in_the_box_for_its_floor() -> None:
    # held-out 876 (session 35): the hand went down to 0.06 m into the heap of two cloths
    # placed before (0.11 m high) and, rising, carried them out of the box
    from types import SimpleNamespace

    from robot_app.control.loop_settings import LoopSettings
    from robot_app.control.pick_place import release_into_box

    def lowest(heap: float) -> tuple[float, float]:
        moves: list[tuple[float, float]] = []
        motion = SimpleNamespace(
            solve_tcp=lambda p: np.asarray(p, dtype=float),
            move_slowing_down=lambda q, speed, below: moves.append((float(q[2]), below)),
            hold=lambda seconds: None,
        )
        cell = SimpleNamespace(release=lambda: None, set_gripper=lambda opening: None)
        release_into_box(motion, cell, np.array([0.3, -0.56, 0.0]), 0.0, LoopSettings(), 0.2, heap)  # type: ignore[arg-type]
        return moves[0]

    empty_low, empty_slow = lowest(0.0)
    heaped_low, heaped_slow = lowest(0.11)
    assert empty_low == pytest.approx(LoopSettings().min_release_height)
    assert heaped_low == pytest.approx(empty_low + 0.11) and heaped_slow == pytest.approx(empty_slow + 0.11)
    assert lowest(-0.01) == (empty_low, empty_slow)  # nothing measured below the floor counts


# --- the transfer that arrives moving down into the lowering (`ArmMotion.arrive_lowering`) --


def _arm() -> tuple[ArmMotion, Kinematics]:
    kinematics = Kinematics.from_urdf(DEFAULT_URDF, "base_link", "tcp")
    home = np.array(RobotSettings().home_joints)
    rotation = kinematics.frame_pose(home, "tcp")[:3, :3]
    arm = ArmMotion(_StillCell(home), kinematics, _limits(), LoopSettings(), rotation, home)  # type: ignore[arg-type]
    return arm, kinematics


def _carry(join: bool, drop: float = 0.02) -> tuple[ArmMotion, bool, int, np.ndarray]:
    """Lifted over the table at (0.55, 0.0), 0.40 m, carried over the colours box and lowered
    to 0.07 m (slow below 0.30 m), joined or with the stop over the box; the arm, whether it
    joined, the sample where the transfer ended, and every TCP position (K, 3)."""
    arm, kinematics = _arm()
    arm.move_to_joints(arm.solve_tcp([0.55, 0.0, 0.40]))
    start = arm.samples
    q_over, q_low = arm.solve_tcp([0.30, -0.56, 0.40]), arm.solve_tcp([0.30, -0.56, 0.07])
    joined = join and arm.arrive_lowering(q_over, q_low, SLOW, 0.30, (drop,), 0.05, 0.003) == drop
    if not joined:
        arm.move_to_joints(q_over)
    transfer_end = arm.samples
    arm.move_slowing_down(q_low, SLOW, 0.30)
    Q = np.array(arm._Q[start:])
    tcp = np.array([kinematics.frame_pose(q, "tcp")[:3, 3] for q in Q])
    return arm, joined, transfer_end - start, tcp


def test_the_transfer_arrives_moving_into_the_lowering_and_saves_the_stop() -> None:
    arm_stop, _, _, tcp_stop = _carry(join=False)
    arm, joined, transfer, tcp = _carry(join=True)
    assert joined
    assert len(tcp) < len(tcp_stop) - 0.15 / DT  # at least 0.15 s shorter
    np.testing.assert_allclose(tcp[-1], tcp_stop[-1], atol=1e-6)
    assert arm.limit_report().ok and arm_stop.limit_report().ok
    V = np.array(arm._V)
    assert np.max(np.abs(np.diff(V, axis=0))) <= np.max(arm.limits.acceleration) * DT * 1.01  # no jump
    # the transfer ends moving down, 20 mm below the transfer height, over the box's middle
    end = tcp[transfer - 1]
    assert end[2] == pytest.approx(0.38, abs=0.003)
    assert np.hypot(end[0] - 0.30, end[1] + 0.56) < 0.05
    assert np.linalg.norm(arm._V[arm.samples - len(tcp) + transfer - 1]) > 0.05
    # a hanging cloth crosses the box's wall as high as after a stop: more than 3 mm below
    # the transfer height only within 5 cm of the box's middle
    far = np.hypot(tcp[:transfer, 0] - 0.30, tcp[:transfer, 1] + 0.56) > 0.05
    assert tcp[:transfer][far, 2].min() >= 0.40 - 0.003
    # below the slow height the joined move is the lowering's own: within the slow limits
    slow = tcp[1:, 2] <= 0.30
    assert np.all(np.abs(V[-len(tcp) + 1 :][slow]) <= arm.limits.scaled(SLOW).velocity + 1e-9)


def test_a_move_after_the_arrival_that_is_not_the_lowering_starts_from_the_moving_state() -> None:
    arm, _ = _arm()
    arm.move_to_joints(arm.solve_tcp([0.55, 0.0, 0.40]))
    q_over, q_low = arm.solve_tcp([0.30, -0.56, 0.40]), arm.solve_tcp([0.30, -0.56, 0.07])
    assert arm.arrive_lowering(q_over, q_low, SLOW, 0.30, (0.02,), 0.05, 0.003)
    assert np.linalg.norm(arm.command.v) > 0.0
    arm.move_to_joints(q_over)  # e.g. the hand came empty: brought to rest over the box
    assert arm.limit_report().ok
    V = np.array(arm._V)
    assert np.max(np.abs(np.diff(V, axis=0))) <= np.max(arm.limits.acceleration) * DT * 1.01
    np.testing.assert_allclose(arm.command.q, q_over, atol=1e-9)
    # and the lowering after it is planned afresh from rest (the arrival's is dropped)
    arm.move_slowing_down(q_low, SLOW, 0.30)
    np.testing.assert_allclose(arm.command.q, q_low, atol=1e-9)
    assert arm.limit_report().ok


def test_no_arrival_where_it_would_not_hand_over_in_the_fast_part() -> None:
    arm, _ = _arm()
    arm.move_to_joints(arm.solve_tcp([0.55, 0.0, 0.40]))
    before = arm.samples
    q_over, q_low = arm.solve_tcp([0.30, -0.56, 0.40]), arm.solve_tcp([0.30, -0.56, 0.07])
    assert arm.arrive_lowering(q_over, q_low, SLOW, 0.30, (0.0,), 0.05, 0.003) is None  # no drop asked
    assert arm.arrive_lowering(q_over, q_low, SLOW, 0.30, (0.2,), 0.05, 0.003) is None  # past the slow height
    assert arm.arrive_lowering(q_over, q_low, SLOW, 0.45, (0.02,), 0.05, 0.003) is None  # all of it slow
    assert arm.samples == before  # nothing moved


def test_a_hold_after_the_arrival_brings_the_arm_to_rest_first() -> None:
    arm, _ = _arm()
    arm.move_to_joints(arm.solve_tcp([0.55, 0.0, 0.40]))
    q_over, q_low = arm.solve_tcp([0.30, -0.56, 0.40]), arm.solve_tcp([0.30, -0.56, 0.07])
    assert arm.arrive_lowering(q_over, q_low, SLOW, 0.30, (0.02,), 0.05, 0.003)
    arm.hold(0.1)
    assert arm.limit_report().ok
    V = np.array(arm._V)
    assert np.max(np.abs(np.diff(V, axis=0))) <= np.max(arm.limits.acceleration) * DT * 1.01
    np.testing.assert_allclose(V[-1], 0.0, atol=1e-12)
