"""Contract tests of the jerk-limited trajectories: limits are never exceeded, targets
are reached, moving targets are followed, and planner errors come back typed."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import ruckig
from hypothesis import given, settings
from hypothesis import strategies as st

from robot_app.config import load_config
from robot_app.control.limits import (
    JointLimits,
    LimitReport,
    TrajectorySettings,
    check_limits,
)
from robot_app.control.online_trajectory import OnlineTrajectory
from robot_app.control.ruckig_input import TrajectoryPlanningError, call_ruckig
from robot_app.control.trajectory import plan_point_to_point
from robot_app.errors import ConfigError, InputError, TrajectoryError

URDF = Path(__file__).resolve().parents[1] / "urdf" / "pa10.urdf"

# Mitsubishi PA10-7C published position [deg] and velocity [deg/s] limits, S1..W2.
PUBLISHED_POSITION_DEG = np.array([177.0, 94.0, 174.0, 137.0, 255.0, 165.0, 255.0])
PUBLISHED_VELOCITY_DEG = np.array([57.0, 57.0, 114.0, 114.0, 360.0, 360.0, 360.0])
PA10_JOINTS = ("S1", "S2", "S3", "E1", "E2", "W1", "W2")  # the published names, to check the URDF's


def pa10_limits(settings_: TrajectorySettings | None = None) -> JointLimits:
    bound = np.deg2rad(PUBLISHED_POSITION_DEG)
    return JointLimits.from_velocity_limits(
        -bound, bound, np.deg2rad(PUBLISHED_VELOCITY_DEG), settings_, PA10_JOINTS
    )


LIMITS = pa10_limits()
DT = 0.01

unit_vectors = st.lists(st.floats(0.0, 1.0), min_size=7, max_size=7).map(np.array)
signed_vectors = st.lists(st.floats(-1.0, 1.0), min_size=7, max_size=7).map(np.array)


def inside(fraction: np.ndarray, shrink: float = 0.0) -> np.ndarray:
    """Maps [0, 1]^7 into the joint range, `shrink` of it kept clear at each end."""
    span = LIMITS.upper - LIMITS.lower
    return LIMITS.lower + span * (shrink + (1.0 - 2.0 * shrink) * fraction)


# --- limits -----------------------------------------------------------------------------


def test_urdf_limits_are_the_published_pa10_limits() -> None:
    hardware = JointLimits.from_urdf(URDF, settings=TrajectorySettings(safety_scale=1.0, position_margin=0.0))
    assert hardware.names == PA10_JOINTS
    np.testing.assert_allclose(hardware.upper, np.deg2rad(PUBLISHED_POSITION_DEG), rtol=1e-6)
    np.testing.assert_allclose(hardware.lower, -np.deg2rad(PUBLISHED_POSITION_DEG), rtol=1e-6)
    np.testing.assert_allclose(hardware.velocity, np.deg2rad(PUBLISHED_VELOCITY_DEG), rtol=1e-6)
    np.testing.assert_allclose(hardware.acceleration, 2.5 * hardware.velocity)
    np.testing.assert_allclose(hardware.jerk, 25.0 * hardware.velocity)


def test_settings_scale_kinematic_limits_and_trim_positions() -> None:
    raw = TrajectorySettings(safety_scale=1.0, position_margin=0.0)
    safe = TrajectorySettings(safety_scale=0.5, position_margin=0.1)
    full, scaled = pa10_limits(raw), pa10_limits(safe)
    np.testing.assert_allclose(scaled.velocity, 0.5 * full.velocity)
    np.testing.assert_allclose(scaled.acceleration, 0.5 * full.acceleration)
    np.testing.assert_allclose(scaled.jerk, 0.5 * full.jerk)
    np.testing.assert_allclose(scaled.upper, full.upper - 0.1)
    np.testing.assert_allclose(scaled.lower, full.lower + 0.1)


def test_bad_limits_and_settings_are_config_errors(tmp_path: Path) -> None:
    with pytest.raises(ConfigError) as crossed:
        JointLimits([1.0], [0.0], [1.0], [1.0], [1.0])
    assert (crossed.value.key, crossed.value.value) == ("lower", [1.0])
    with pytest.raises(ConfigError) as negative:
        JointLimits([0.0], [1.0], [-1.0], [1.0], [1.0])
    assert (negative.value.key, negative.value.value) == ("velocity", [-1.0])
    # sizes that disagree are our code's mistake: the arrays come from one URDF chain
    with pytest.raises(ValueError, match="one value per joint"):
        JointLimits([0.0, 0.0], [1.0], [1.0], [1.0], [1.0])
    with pytest.raises(ConfigError) as infinite:
        JointLimits([0.0], [np.inf], [1.0], [1.0], [1.0])
    assert (infinite.value.key, infinite.value.value) == ("upper", [np.inf])
    with pytest.raises(ConfigError) as scale:
        LIMITS.scaled(1.5)
    assert (scale.value.key, scale.value.value) == ("safety_scale", 1.5)
    with pytest.raises(ConfigError) as margin:
        LIMITS.scaled(1.0, position_margin=2.0)
    assert (margin.value.key, margin.value.value) == ("position_margin", 2.0)
    with pytest.raises(ConfigError) as zero_scale:
        load_config(TrajectorySettings, None, ["safety_scale=0"])
    assert (zero_scale.value.key, zero_scale.value.value) == ("safety_scale", 0)
    with pytest.raises(ConfigError) as ratio:
        load_config(TrajectorySettings, None, ["acceleration_per_velocity=-1"])
    assert (ratio.value.key, ratio.value.value) == ("acceleration_per_velocity", -1)


def test_urdf_problems_are_input_errors(tmp_path: Path) -> None:
    with pytest.raises(InputError) as missing:
        JointLimits.from_urdf(tmp_path / "missing.urdf")
    assert missing.value.path == (tmp_path / "missing.urdf").resolve()
    broken = tmp_path / "broken.urdf"
    broken.write_text("<robot><joint name='S1'")
    with pytest.raises(InputError) as unreadable:
        JointLimits.from_urdf(broken)
    assert unreadable.value.path == broken.resolve()
    no_chain = tmp_path / "no_chain.urdf"
    no_chain.write_text("<robot name='r'><link name='base_link'/></robot>")
    with pytest.raises(InputError) as no_link:
        JointLimits.from_urdf(no_chain)
    assert no_link.value.key == "flange"


def test_check_limits_counts_each_kind_of_violation() -> None:
    limits = JointLimits([-1.0], [1.0], [1.0], [2.0], [10.0])
    times = np.array([0.0, 0.1, 0.2, 0.3])
    Q = np.array([[0.0], [1.5], [0.0], [0.0]])  # one sample beyond the upper limit
    V = np.array([[0.0], [1.2], [0.0], [-1.0]])  # one too fast; -1.0 is exactly the limit
    A = np.array([[0.0], [1.0], [-2.5], [-1.5]])  # one too large; jerks 10, -35, 10
    report = check_limits(times, Q, V, A, limits)
    assert isinstance(report, LimitReport)
    assert (report.position, report.velocity, report.acceleration, report.jerk) == (1, 1, 1, 1)
    assert report.violations == 4 and not report.ok
    assert report.worst_jerk == pytest.approx(3.5)
    assert report.worst_position_excess == pytest.approx(0.25)
    with pytest.raises(ValueError, match="shape"):
        check_limits(times, Q[:2], V, A, limits)
    with pytest.raises(ValueError, match="increasing"):
        check_limits(times[::-1], Q, V, A, limits)


# --- offline ----------------------------------------------------------------------------


@settings(max_examples=40, deadline=None, derandomize=True, database=None)
@given(start=unit_vectors, goal=unit_vectors, v_frac=signed_vectors, a_frac=signed_vectors)
def test_point_to_point_respects_every_limit_and_reaches_the_goal(
    start: np.ndarray, goal: np.ndarray, v_frac: np.ndarray, a_frac: np.ndarray
) -> None:
    # Start in the middle half of the range, at up to half speed and acceleration, so that
    # braking (< 0.1 rad) can never carry a joint out of its range.
    q_start, q_goal = inside(start, 0.25), inside(goal)
    v_start, a_start = 0.5 * v_frac * LIMITS.velocity, 0.5 * a_frac * LIMITS.acceleration
    trajectory = plan_point_to_point(q_start, q_goal, LIMITS, v_start=v_start, a_start=a_start, dt=DT)
    sampled = trajectory.samples(DT / 4)
    report = check_limits(*sampled, LIMITS)
    assert report.ok, report
    assert trajectory.duration / DT == pytest.approx(round(trajectory.duration / DT), abs=1e-9)
    np.testing.assert_allclose(sampled.Q[0], q_start, atol=1e-12)
    np.testing.assert_allclose(sampled.V[0], v_start, atol=1e-12)
    np.testing.assert_allclose(sampled.Q[-1], q_goal, atol=1e-9)
    np.testing.assert_allclose(sampled.V[-1], 0.0, atol=1e-9)
    np.testing.assert_allclose(sampled.A[-1], 0.0, atol=1e-9)
    # The sampled velocities are the derivative of the sampled positions.
    midpoint_v = np.diff(sampled.Q, axis=0) / np.diff(sampled.times)[:, None]
    np.testing.assert_allclose(midpoint_v, 0.5 * (sampled.V[1:] + sampled.V[:-1]), atol=1e-3)


def test_trajectory_sampling_clamps_to_its_duration() -> None:
    q_goal = np.full(7, 0.3)
    trajectory = plan_point_to_point(np.zeros(7), q_goal, LIMITS, dt=DT)
    assert trajectory.duration > 0.0 and trajectory.calculation_time_s > 0.0
    after = trajectory.sample(trajectory.duration + 5.0)
    np.testing.assert_allclose(after.q, q_goal, atol=1e-12)
    assert after.time == trajectory.duration
    np.testing.assert_allclose(trajectory.sample(-1.0).q, 0.0)
    with pytest.raises(ValueError):
        trajectory.sample(float("nan"))
    with pytest.raises(ValueError):
        trajectory.samples(0.0)


# --- online -----------------------------------------------------------------------------


@settings(max_examples=25, deadline=None, derandomize=True, database=None)
@given(
    targets=st.lists(st.tuples(unit_vectors, st.integers(1, 60)), min_size=1, max_size=5),
    q0=unit_vectors,
)
def test_online_replanning_respects_every_limit_and_reaches_the_last_target(
    targets: list[tuple[np.ndarray, int]], q0: np.ndarray
) -> None:
    online = OnlineTrajectory(LIMITS, DT, inside(q0))
    start = online.state
    times, Q, V, A = [start.time], [start.q], [start.v], [start.a]
    for fraction, cycles in targets:  # each target is switched to mid-motion
        online.set_target(inside(fraction, 0.1))
        for _ in range(cycles):
            sample = online.step()
            times.append(sample.time), Q.append(sample.q), V.append(sample.v), A.append(sample.a)
    steps = 0
    while not online.finished:
        sample = online.step()
        times.append(sample.time), Q.append(sample.q), V.append(sample.v), A.append(sample.a)
        steps += 1
        assert steps < 2000, "the online trajectory never finished"
    report = check_limits(np.array(times), np.array(Q), np.array(V), np.array(A), LIMITS)
    assert report.ok, report
    np.testing.assert_allclose(Q[-1], online.target, atol=1e-9)
    np.testing.assert_allclose(V[-1], 0.0, atol=1e-9)
    assert online.calculation_times.size >= 1
    assert np.all(online.calculation_times > 0.0)


def test_online_follows_a_moving_target() -> None:
    online = OnlineTrajectory(LIMITS, DT, np.zeros(7))
    phase = np.arange(7.0)
    amplitude, omega = 0.3, 1.0  # [rad], [rad/s]
    errors, times, Q, V, A = [], [], [], [], []
    for k in range(1, 801):
        t = k * DT
        q_target = amplitude * np.sin(omega * t + phase)
        v_target = amplitude * omega * np.cos(omega * t + phase)
        a_target = -amplitude * omega**2 * np.sin(omega * t + phase)
        online.set_target(q_target, v_target, a_target)
        sample = online.step()
        errors.append(np.abs(sample.q - q_target).max())
        times.append(sample.time), Q.append(sample.q), V.append(sample.v), A.append(sample.a)
    assert errors[0] > 0.2  # it starts far from the target ...
    assert max(errors[-300:]) < 3e-3  # ... and follows it within 3 mrad after 5 s
    assert check_limits(np.array(times), np.array(Q), np.array(V), np.array(A), LIMITS).ok
    assert online.calculation_times.size >= 790  # a replan on (nearly) every cycle
    assert online.last_calculation_time_s == online.calculation_times[-1]


def test_online_catches_up_with_a_constant_velocity_target() -> None:
    # Cycle 51 of this run leaves S1 one ulp beyond its velocity limit; unclipped, the
    # next replan fails inside ruckig (regression test for the clipping in step()).
    online = OnlineTrajectory(LIMITS, DT, np.zeros(7))
    velocity = np.full(7, 0.1)
    for k in range(1, 601):
        q_target = -0.5 + velocity * k * DT
        online.set_target(q_target, velocity)
        sample = online.step()
    np.testing.assert_allclose(sample.q, q_target, atol=1e-3)
    np.testing.assert_allclose(sample.v, velocity, atol=1e-3)


def test_online_reset_moves_the_commanded_state() -> None:
    online = OnlineTrajectory(LIMITS, DT, np.zeros(7))
    online.set_target(np.full(7, 0.2))
    online.step()
    assert not online.finished
    q = np.full(7, -0.1)
    online.reset(q)
    assert online.finished and online.state.time == 0.0
    np.testing.assert_allclose(online.state.q, q)
    sample = online.step()
    np.testing.assert_allclose(sample.q, q, atol=1e-12)


# --- errors -----------------------------------------------------------------------------


def test_targets_outside_the_position_limits_are_invalid_input() -> None:
    beyond = np.zeros(7)
    beyond[1] = LIMITS.upper[1] + 0.01
    with pytest.raises(TrajectoryPlanningError, match="S2") as info:
        plan_point_to_point(np.zeros(7), beyond, LIMITS, dt=DT)
    assert info.value.code == int(ruckig.Result.ErrorInvalidInput)
    assert isinstance(info.value, TrajectoryError) and "ErrorInvalidInput" in str(info.value)
    online = OnlineTrajectory(LIMITS, DT, np.zeros(7))
    with pytest.raises(TrajectoryPlanningError) as info:
        online.set_target(beyond)
    assert info.value.code == -100
    with pytest.raises(TrajectoryPlanningError) as info:
        OnlineTrajectory(LIMITS, DT, beyond)
    assert info.value.code == -100


@pytest.mark.parametrize(
    "kwargs",
    [
        {"v_start": np.full(7, 10.0)},
        {"a_start": np.full(7, 100.0)},
        {"v_start": np.full(7, np.nan)},
    ],
)
def test_start_states_beyond_the_limits_are_invalid_input(kwargs: dict[str, np.ndarray]) -> None:
    with pytest.raises(TrajectoryPlanningError) as info:
        plan_point_to_point(np.zeros(7), np.full(7, 0.1), LIMITS, dt=DT, **kwargs)
    assert info.value.code == -100


def test_a_target_that_must_overshoot_its_velocity_limit_is_invalid_input() -> None:
    online = OnlineTrajectory(LIMITS, DT, np.zeros(7))
    v_target = 0.99 * LIMITS.velocity
    a_target = 0.5 * LIMITS.acceleration  # still speeding up at 99 % of the limit
    with pytest.raises(TrajectoryPlanningError, match="drift") as info:
        online.set_target(np.full(7, 0.2), v_target, a_target)
    assert info.value.code == -100


def test_a_motion_that_would_overshoot_the_range_raises_positional_limits() -> None:
    q_start = np.zeros(7)
    q_start[0] = LIMITS.upper[0] - 0.05  # 50 mrad from the limit at full speed toward it
    v_start = np.zeros(7)
    v_start[0] = LIMITS.velocity[0]
    with pytest.raises(TrajectoryPlanningError, match="S1") as info:
        plan_point_to_point(q_start, q_start, LIMITS, v_start=v_start, dt=DT)
    assert info.value.code == int(ruckig.Result.ErrorPositionalLimits)
    online = OnlineTrajectory(LIMITS, DT, np.zeros(7))
    online.reset(q_start, v_start)
    before = online.state
    with pytest.raises(TrajectoryPlanningError) as info:
        online.step()
    assert info.value.code == -102
    np.testing.assert_array_equal(online.state.q, before.q)  # the state did not advance
    with pytest.raises(TrajectoryPlanningError):  # nor does it on a second try
        online.step()
    np.testing.assert_array_equal(online.state.q, before.q)


def test_ruckig_exceptions_become_typed_errors() -> None:
    request = ruckig.InputParameter(1)
    request.max_velocity, request.max_acceleration, request.max_jerk = [-1.0], [1.0], [1.0]
    with pytest.raises(TrajectoryPlanningError, match="maximum velocity limit") as info:
        call_ruckig(ruckig.Ruckig(1, DT).calculate, request, ruckig.Trajectory(1))
    assert info.value.code == -100


def test_ruckig_calculation_failures_keep_their_code() -> None:
    # A state one ulp beyond the velocity limit that ruckig itself once commanded; its
    # synchronisation then throws (the online loop clips such rounding excess first,
    # see test_online_catches_up_with_a_constant_velocity_target).
    h = float.fromhex
    request = ruckig.InputParameter(2)
    request.current_position = [h("-0x1.ca6bd3c393da6p-3")] * 2
    request.current_velocity = [h("-0x1.ca6bd3c393da7p-1")] * 2
    request.current_acceleration = [h("-0x1.7p-50")] * 2
    request.target_position = [h("-0x1.cbc6a7ef9db23p-2")] * 2
    request.target_velocity = [0.1] * 2
    request.max_velocity = [h("0x1.ca6bd3c393da6p-1")] * 2
    request.max_acceleration = [h("0x1.1e83645a3c688p+1")] * 2
    request.max_jerk = [h("0x1.66243d70cb82ap+4")] * 2
    with pytest.raises(TrajectoryPlanningError, match="synchronisation failed") as info:
        call_ruckig(ruckig.Ruckig(2, DT).update, request, ruckig.OutputParameter(2))
    assert info.value.code == int(ruckig.Result.ErrorSynchronizationCalculation)


def test_bad_shapes_and_periods_are_input_errors() -> None:
    with pytest.raises(ValueError, match="7 values"):
        plan_point_to_point(np.zeros(6), np.zeros(7), LIMITS, dt=DT)
    with pytest.raises(ValueError, match="dt"):
        plan_point_to_point(np.zeros(7), np.zeros(7), LIMITS, dt=0.0)
    with pytest.raises(ValueError, match="dt"):
        OnlineTrajectory(LIMITS, -1.0, np.zeros(7))
