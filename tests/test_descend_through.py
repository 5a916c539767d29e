"""DESCEND through the pregrasp point without a stop (`trajectory.plan_through`,
`ArmMotion.move_through`, `loop.descend_via_speed`): faster than the two stops, within
the limits, and the last leg straight down onto the grasp point, never past it."""

from __future__ import annotations

import numpy as np
import pytest

from robot_app.control.kinematics import Kinematics
from robot_app.control.limits import JointLimits, TrajectorySettings, check_limits
from robot_app.control.trajectory import plan_point_to_point, plan_through
from robot_app.geometry import make_transform
from robot_app.sim.config import DEFAULT_URDF, RobotSettings

DT = 1.0 / 240.0
KINEMATICS = Kinematics.from_urdf(DEFAULT_URDF, "base_link", "tcp")
LIMITS = JointLimits.from_urdf(DEFAULT_URDF, TrajectorySettings())
HOME = np.array(RobotSettings().home_joints)
DOWN = KINEMATICS.frame_pose(HOME, "tcp")[:3, :3]


def _ik(position, seed) -> np.ndarray:
    result = KINEMATICS.solve_ik(
        make_transform(DOWN, position), seed, frame="tcp", time_budget=0.05,
        position_tolerance=1e-6, orientation_tolerance=1e-6, preferred_posture=HOME,
    )  # fmt: skip
    assert result.success
    return np.array(result.q)


def _tcp(q) -> np.ndarray:
    return KINEMATICS.frame_pose(q, "tcp")[:3, 3]


def _descent(x: float, y: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Joints at the hover (0.48 m), the pregrasp point (0.11 m) and the grasp (0.03 m)."""
    hover = _ik([x, y, 0.48], HOME)
    pregrasp = _ik([x, y, 0.11], hover)
    return hover, pregrasp, _ik([x, y, 0.03], pregrasp)


def _sampled(trajectory):  # type: ignore[no-untyped-def]
    steps = round(trajectory.duration / DT)
    states = [trajectory.sample(k * DT) for k in range(steps + 1)]
    return (
        np.arange(steps + 1) * DT,
        np.array([s.q for s in states]),
        np.array([s.v for s in states]),
        np.array([s.a for s in states]),
    )


@pytest.mark.parametrize("xy", [(0.56, 0.13), (0.45, -0.20), (0.72, 0.25), (0.30, -0.30)])
def test_the_descent_passes_the_pregrasp_point_moving_and_comes_straight_down_sooner(xy) -> None:
    x, y = xy
    hover, pregrasp, grasp = _descent(x, y)
    two_stops = sum(
        plan_point_to_point(a, b, LIMITS, dt=DT).duration for a, b in ((hover, pregrasp), (pregrasp, grasp))
    )
    speed = 0.25 * np.linalg.norm(grasp - pregrasp) / 0.08  # 0.25 m/s at the TCP
    joined = plan_through(hover, pregrasp, grasp, LIMITS, speed, dt=DT)
    times, Q, V, A = _sampled(joined)
    assert check_limits(times, Q, V, A, LIMITS, tol=1e-6).ok
    np.testing.assert_allclose(Q[-1], grasp, atol=1e-9)
    np.testing.assert_allclose(V[-1], 0.0, atol=1e-9)
    assert joined.duration < two_stops - 0.1
    # no stop at the pregrasp point: the hand passes it heading down at about 0.25 m/s
    at_via = joined.fast.sample(joined.fast.duration)
    np.testing.assert_allclose(at_via.q, pregrasp, atol=1e-9)
    heading = KINEMATICS.frame_jacobian(pregrasp, "tcp")[:3] @ at_via.v
    assert heading[2] == pytest.approx(-0.25, abs=0.03)
    assert np.hypot(*heading[:2]) < 0.2 * abs(heading[2])  # the joint line's tangent: nearly down
    # the last 8 cm: within 4 mm of the vertical over the grasp point, never below it
    tcp = np.array([_tcp(q) for q in Q])
    low = tcp[:, 2] < 0.11 - 1e-6
    assert np.max(np.hypot(tcp[low, 0] - x, tcp[low, 1] - y)) < 0.004
    assert np.min(tcp[:, 2]) > 0.03 - 1e-4


def test_a_pass_too_fast_to_stop_in_the_distance_is_slowed_and_at_no_speed_the_hand_stops() -> None:
    hover, pregrasp, grasp = _descent(0.56, 0.13)
    # 3 rad/s along the last leg cannot stop within its length: a slower pass or the two stops,
    # never a move past the grasp point and back
    joined = plan_through(hover, pregrasp, grasp, LIMITS, 3.0, dt=DT)
    _, Q, _, _ = _sampled(joined)
    leg = grasp - pregrasp
    along = (Q - pregrasp) @ leg / np.linalg.norm(leg)
    assert np.max(along[round(joined.fast.duration / DT) :]) <= np.linalg.norm(leg) + 1e-6
    assert min(_tcp(q)[2] for q in Q) > 0.03 - 1e-4
    stopped = plan_through(hover, pregrasp, grasp, LIMITS, 0.0, dt=DT)
    np.testing.assert_allclose(stopped.fast.sample(stopped.fast.duration).v, 0.0, atol=1e-9)


def test_a_pass_that_cannot_be_planned_within_the_limits_falls_back_to_the_two_stops(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # e.g. a first leg arriving at speed that would overshoot a position limit (ruckig_input's
    # code -102): the descent still goes, stopping at the pregrasp point
    from robot_app.control import trajectory
    from robot_app.control.ruckig_input import TrajectoryPlanningError

    planned = trajectory.plan_point_to_point

    def refusing(q_start, q_goal, limits, *, v_goal=None, **kwargs):  # type: ignore[no-untyped-def]
        if v_goal is not None:
            raise TrajectoryPlanningError("overshoot", -102)
        return planned(q_start, q_goal, limits, **kwargs)

    monkeypatch.setattr(trajectory, "plan_point_to_point", refusing)
    hover, pregrasp, grasp = _descent(0.56, 0.13)
    joined = plan_through(hover, pregrasp, grasp, LIMITS, 1.0, dt=DT)
    np.testing.assert_allclose(joined.fast.sample(joined.fast.duration).v, 0.0, atol=1e-9)
    np.testing.assert_allclose(joined.sample(joined.duration).q, grasp, atol=1e-9)
