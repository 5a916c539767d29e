"""Kinematics: FK against pybullet, Jacobians against finite differences, IK contracts."""

from __future__ import annotations

import re

import numpy as np
import pinocchio as pin
import pybullet as p
import pytest

from robot_app.control.kinematics import IKResult, Kinematics
from robot_app.control.robot_models import load_arm
from robot_app.errors import IKError, InputError
from robot_app.robot_description import urdf_path

URDF = urdf_path("pa10.urdf")


@pytest.fixture(scope="module")
def pa10() -> Kinematics:
    return Kinematics.from_urdf(URDF, "base_link", "flange")


@pytest.fixture(scope="module")
def pr2() -> Kinematics:
    return load_arm("pr2")


def _angle(R: np.ndarray) -> float:
    return float(np.linalg.norm(pin.log3(R)))


def test_chain_properties(pa10: Kinematics) -> None:
    assert pa10.joint_names == ("S1", "S2", "S3", "E1", "E2", "W1", "W2")
    assert pa10.nq == 7
    np.testing.assert_allclose(np.rad2deg(pa10.upper), (177, 94, 174, 137, 255, 165, 255))
    np.testing.assert_allclose(pa10.lower, -pa10.upper)
    np.testing.assert_allclose(np.rad2deg(pa10.velocity_limits), (57, 57, 114, 114, 360, 360, 360))
    np.testing.assert_allclose(pa10.neutral, np.zeros(7))
    with pytest.raises(ValueError):
        pa10.lower[0] = 0.0  # read-only


def test_fk_equals_pybullet_at_100_random_configurations() -> None:
    """Pinocchio FK of every link equals pybullet's getLinkState (<= 1e-6 m, 1e-6 rad)."""
    kin = Kinematics.from_urdf(URDF, "base_link", "tcp")
    client = p.connect(p.DIRECT)
    try:
        robot = p.loadURDF(str(URDF), useFixedBase=True, physicsClientId=client)
        joints = {}
        links = {}
        for i in range(p.getNumJoints(robot, physicsClientId=client)):
            info = p.getJointInfo(robot, i, physicsClientId=client)
            joints[info[1].decode()] = i
            links[info[12].decode()] = i
        rng = np.random.default_rng(7)
        worst_position = worst_angle = 0.0
        for _ in range(100):
            q = kin.random_configuration(rng)
            for name, value in zip(kin.joint_names, q, strict=True):
                p.resetJointState(robot, joints[name], value, physicsClientId=client)
            for link, index in links.items():
                if link.startswith("finger"):
                    continue  # locked at 0 in our chain model; pybullet's are at 0 too
                state = p.getLinkState(robot, index, computeForwardKinematics=True, physicsClientId=client)
                R_bullet = np.array(p.getMatrixFromQuaternion(state[5])).reshape(3, 3)
                T = kin.frame_pose(q, link)
                worst_position = max(worst_position, float(np.linalg.norm(T[:3, 3] - state[4])))
                worst_angle = max(worst_angle, _angle(T[:3, :3].T @ R_bullet))
        assert worst_position <= 1e-6
        assert worst_angle <= 1e-6
    finally:
        p.disconnect(client)


def _finite_difference_jacobian(kin: Kinematics, q: np.ndarray, frame: str, reference: str) -> np.ndarray:
    h = 1e-6
    T0 = kin.frame_pose(q, frame)
    J = np.zeros((6, kin.nq))
    for j in range(kin.nq):
        dq = np.zeros(kin.nq)
        dq[j] = h
        Tp, Tm = kin.frame_pose(q + dq, frame), kin.frame_pose(q - dq, frame)
        linear = (Tp[:3, 3] - Tm[:3, 3]) / (2 * h)  # velocity of the frame origin, base axes
        angular = pin.log3(Tp[:3, :3] @ Tm[:3, :3].T) / (2 * h)  # base axes
        if reference == "local_world_aligned":
            J[:, j] = np.concatenate([linear, angular])
        elif reference == "local":
            J[:, j] = np.concatenate([T0[:3, :3].T @ linear, T0[:3, :3].T @ angular])
        else:  # world: velocity of the point at the base origin moving with the frame
            J[:, j] = np.concatenate([linear - np.cross(angular, T0[:3, 3]), angular])
    return J


@pytest.mark.parametrize("reference", ["local_world_aligned", "local", "world"])
@pytest.mark.parametrize("arm", ["pa10", "pr2"])
def test_jacobian_equals_finite_differences(
    pa10: Kinematics, pr2: Kinematics, arm: str, reference: str
) -> None:
    kin = pa10 if arm == "pa10" else pr2  # the PR2 adds a non-identity base and continuous joints
    frames = ("flange", "link_e2") if arm == "pa10" else ("r_wrist_roll_link", "r_elbow_flex_link")
    rng = np.random.default_rng(3)
    for _ in range(5):
        q = kin.random_configuration(rng)
        for frame in frames:
            J = kin.frame_jacobian(q, frame, reference)
            assert J.shape == (6, kin.nq)
            np.testing.assert_allclose(J, _finite_difference_jacobian(kin, q, frame, reference), atol=1e-6)


def test_ik_reaches_random_targets_within_tolerance_and_limits(pa10: Kinematics) -> None:
    rng = np.random.default_rng(11)
    for i in range(60):
        target = pa10.tip_pose(pa10.random_configuration(rng))
        result = pa10.solve_ik(target, seed=i, time_budget=0.2)
        assert isinstance(result, IKResult)
        assert result.success
        reached = pa10.tip_pose(result.q)  # residuals checked independently of the solver
        assert np.linalg.norm(reached[:3, 3] - target[:3, 3]) <= 1e-5
        assert _angle(reached[:3, :3].T @ target[:3, :3]) <= 1e-5
        assert result.position_error == pytest.approx(
            np.linalg.norm(reached[:3, 3] - target[:3, 3]), abs=1e-12
        )
        assert pa10.within_limits(result.q)


def test_ik_output_never_violates_the_limits(pa10: Kinematics, pr2: Kinematics) -> None:
    """Including unreachable targets and starts outside the limits."""
    rng = np.random.default_rng(5)
    for kin in (pa10, pr2):
        for i in range(20):
            target = kin.tip_pose(kin.random_configuration(rng))
            target[:3, 3] *= rng.uniform(0.5, 2.0)  # some reachable, some not
            q_init = kin.random_configuration(rng) * 1.5
            result = kin.solve_ik(target, q_init, seed=i, time_budget=0.01, max_restarts=2)
            assert np.all(result.q >= kin.lower) and np.all(result.q <= kin.upper)


def test_pr2_continuous_joints_are_wrapped_not_clamped(pr2: Kinematics) -> None:
    assert pr2.continuous.tolist() == [False, False, False, False, True, False, True]
    q = pr2.neutral.copy()
    q[4] = 3.0
    target = pr2.tip_pose(q)
    result = pr2.solve_ik(target, q_init=q - np.array([0, 0, 0, 0, 0.5, 0, 0]), time_budget=0.2)
    assert result.success
    q_far = q.copy()
    q_far[4] += 2 * np.pi  # the same pose: an angle 2 pi away is wrapped back into [-pi, pi)
    np.testing.assert_allclose(pr2.clip(q_far)[4], 3.0 - 0.0, atol=1e-12)


def test_unreachable_target_fails_with_its_residual_quickly(pa10: Kinematics) -> None:
    target = np.eye(4)
    target[:3, 3] = (2.0, 0.0, 0.5)  # the PA10 reaches about 1.0 m from its shoulder
    result = pa10.solve_ik(target, time_budget=10.0, max_restarts=3)
    assert not result.success
    assert result.restarts == 3
    assert result.position_error > 0.9
    assert pa10.tip_pose(result.q)[0, 3] > 0.9  # the best effort stretches toward it
    with pytest.raises(IKError, match="position error"):
        result.raise_if_failed()
    bounded = pa10.solve_ik(target, time_budget=0.02)  # unlimited restarts: the budget ends it
    assert not bounded.success and bounded.time_s < 1.0


def test_ik_is_reproducible_for_a_seed(pa10: Kinematics) -> None:
    target = np.eye(4)
    target[:3, 3] = (1.5, 0.2, 0.3)
    a = pa10.solve_ik(target, time_budget=10.0, max_restarts=4, seed=9)
    b = pa10.solve_ik(target, time_budget=10.0, max_restarts=4, seed=9)
    np.testing.assert_array_equal(a.q, b.q)


def test_ik_for_another_frame_of_the_chain(pa10: Kinematics) -> None:
    """The camera-looking-down pose of the paper: tcp 0.5 m in front, tool axis down."""
    target = np.eye(4)
    target[:3, :3] = np.diag([1.0, -1.0, -1.0])
    target[:3, 3] = (0.5, 0.1, 0.3)
    result = pa10.solve_ik(target, frame="tcp", time_budget=0.2).raise_if_failed()
    np.testing.assert_allclose(pa10.frame_pose(result.q, "tcp"), target, atol=2e-5)


def test_null_space_bias_slides_along_the_self_motion_to_the_posture(pa10: Kinematics) -> None:
    """Start on a solution that differs from the posture only by self-motion (1-D for 7 DoF)."""
    posture = np.array([0.3, 0.5, -0.2, 1.2, 0.4, 1.0, -0.3])
    target = pa10.tip_pose(posture)
    q_far = posture.copy()
    for _ in range(20):  # walk 0.5 rad along the self-motion, re-projecting onto the target
        null = np.linalg.svd(pa10.frame_jacobian(q_far))[2][-1]
        q_far = pa10.solve_ik(target, q_far + 0.025 * null, time_budget=0.2).raise_if_failed().q
    assert np.linalg.norm(q_far - posture) > 0.4
    without = pa10.solve_ik(target, q_far)
    with_bias = pa10.solve_ik(target, q_far, preferred_posture=posture, time_budget=0.05)
    assert without.success and with_bias.success
    np.testing.assert_allclose(without.q, q_far)  # already a solution: no pull, no motion
    assert np.linalg.norm(with_bias.q - posture) < 0.1 * np.linalg.norm(q_far - posture)


def test_locked_joints_take_the_given_positions() -> None:
    kin = Kinematics.from_urdf(URDF, "base_link", "flange", locked_positions={"finger_left_joint": 0.03})
    finger = kin.frame_pose(kin.neutral, "finger_left")
    flange = kin.frame_pose(kin.neutral, "flange")
    np.testing.assert_allclose((np.linalg.inv(flange) @ finger)[:3, 3], (-0.03, 0.0, 0.09), atol=1e-12)


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda k: k.solve_ik(np.eye(3)), "4x4"),
        (lambda k: k.solve_ik(np.diag([2.0, 1.0, 1.0, 1.0])), "not rigid"),
        (lambda k: k.solve_ik(np.full((4, 4), np.nan)), "finite"),
        (lambda k: k.solve_ik(np.eye(4), np.zeros(6)), "7 finite joint values"),
        (lambda k: k.solve_ik(np.eye(4), frame="nowhere"), "unknown frame"),
        (lambda k: k.solve_ik(np.eye(4), time_budget=0.0), "time_budget"),
        (lambda k: k.solve_ik(np.eye(4), null_space_gain=1.5), "null_space_gain"),
        (lambda k: k.solve_ik(np.eye(4), max_restarts=-1), "max_restarts"),
        (lambda k: k.solve_ik(np.eye(4), position_tolerance=0.0), "tolerance"),
        (lambda k: k.frame_pose(np.zeros(8), "tcp"), "7 finite joint values"),
        (lambda k: k.frame_jacobian(np.zeros(7), "tcp", "body"), "reference must be"),
    ],
)
def test_bad_arguments_raise_value_error(pa10: Kinematics, call, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        call(pa10)


def test_bad_chain_raises_input_error(tmp_path) -> None:
    with pytest.raises(InputError) as missing:
        Kinematics.from_urdf(tmp_path / "missing.urdf", "base_link", "tcp")
    assert missing.value.path == tmp_path / "missing.urdf"
    with pytest.raises(InputError) as no_frame:
        Kinematics.from_urdf(URDF, "base_link", "hand")
    assert no_frame.value.key == "hand"
    with pytest.raises(InputError) as off_path:
        Kinematics.from_urdf(URDF, "finger_left", "tcp")
    assert off_path.value.key == "finger_left"
    broken = tmp_path / "broken.urdf"
    broken.write_text("<robot name='x'><link name='a'></robot>")
    with pytest.raises(InputError) as unparsable:
        Kinematics.from_urdf(broken, "a", "a")
    assert unparsable.value.path == broken


def test_demo_command_drives_pybullet_to_the_ik_solution(capsys: pytest.CaptureFixture[str]) -> None:
    """Closed loop: our IK solution, commanded to pybullet, puts pybullet's tcp on the target."""
    from robot_app.cli import main

    assert main(["demo", "--x", "0.5", "--y", "-0.1", "--z", "0.3", "--yaw-deg", "30", "--seconds", "2"]) == 0
    out = capsys.readouterr().out
    match = re.search(r"error ([0-9.]+) mm, ([0-9.]+) deg", out)
    assert match, out
    assert float(match.group(1)) < 0.5 and float(match.group(2)) < 0.05
    assert "IK: success" in out and "IK FAILED" in out  # reachable, then the unreachable target
    assert main(["demo", "--seconds", "0"]) == 2  # bad input


def test_chain_covering_the_whole_tree_needs_no_reduction(tmp_path) -> None:
    """With the fingers welded, every joint is in the chain: the model is used as is."""
    welded = tmp_path / "pa10_welded.urdf"
    welded.write_text(URDF.read_text().replace('type="prismatic"', 'type="fixed"'))
    kin = Kinematics.from_urdf(welded, "base_link", "tcp")
    reference = Kinematics.from_urdf(URDF, "base_link", "tcp")
    q = np.linspace(-0.5, 0.5, 7)
    np.testing.assert_allclose(kin.tip_pose(q), reference.tip_pose(q), atol=1e-12)
    assert kin.solve_ik(kin.tip_pose(q), time_budget=0.2).success
