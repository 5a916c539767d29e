"""The simulated PA10 with its stereo-camera and gripper tool (urdf/pa10.urdf) in pybullet."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import pybullet as pb

from robot_app.arrays import FloatArray
from robot_app.errors import IKError, InputError, SimulationError
from robot_app.geometry import (
    make_transform,
    matrix_from_quaternion_xyzw,
    quaternion_xyzw_from_matrix,
    rotation_about_z,
    rotation_angle_between,
)
from robot_app.robot_description import PA10_BASE_LINK, PA10_FLANGE, read_joint_chain
from robot_app.sim.config import RobotSettings

ARM_DOF = 7
FINGER_JOINTS = ("finger_left_joint", "finger_right_joint")
GRIPPER_LINKS = ("gripper_palm", "finger_left", "finger_right")
MAX_OPENING = 0.08  # both fingers fully open [m] (0.04 m each side)


@dataclass(frozen=True)
class Contact:
    """A robot link touching (or within `distance` of) another body.

    Attributes:
        link: robot link name.
        body: pybullet id of the other body.
        distance: signed contact distance [m] (negative = penetration).
    """

    link: str
    body: int
    distance: float


class SimRobot:
    """The PA10 in one pybullet client: joint state, position control, gripper, frames.

    Args:
        client: pybullet client id.
        config: URDF path, base placement, motor gain.
    """

    def __init__(self, client: int, config: RobotSettings) -> None:
        if not config.urdf.is_file():
            raise InputError(f"robot URDF not found: {config.urdf}")
        self._client = client
        self._config = config
        base_quat = quaternion_xyzw_from_matrix(rotation_about_z(config.base_yaw))
        self.body_id = pb.loadURDF(
            str(config.urdf),
            basePosition=list(config.base_xyz),
            baseOrientation=base_quat.tolist(),
            useFixedBase=True,
            flags=pb.URDF_USE_INERTIA_FROM_FILE,
            physicsClientId=client,
        )
        self._links: dict[str, int] = {pb.getBodyInfo(self.body_id, physicsClientId=client)[0].decode(): -1}
        chain = read_joint_chain(config.urdf, PA10_BASE_LINK, PA10_FLANGE)
        joints: dict[str, int] = {}
        for index in range(pb.getNumJoints(self.body_id, physicsClientId=client)):
            info = pb.getJointInfo(self.body_id, index, physicsClientId=client)
            joints[info[1].decode()] = index
            self._links[info[12].decode()] = index
        missing = [name for name in (*chain.names, *FINGER_JOINTS) if name not in joints]
        if missing or chain.dof != ARM_DOF:
            raise SimulationError(
                f"{config.urdf} must have {ARM_DOF} arm joints and the fingers {FINGER_JOINTS}; "
                f"arm joints {chain.names}, missing {missing}",
                path=config.urdf,
            )
        self.joint_names = chain.names
        self.joint_indices = tuple(joints[name] for name in chain.names)
        self.finger_indices = tuple(joints[name] for name in FINGER_JOINTS)
        self.lower_limits = chain.lower
        self.upper_limits = chain.upper
        self.velocity_limits = chain.velocity
        self._effort = chain.effort
        self.reset_joints(np.asarray(config.home_joints, dtype=float))
        self.set_gripper(MAX_OPENING)

    @property
    def link_names(self) -> tuple[str, ...]:
        return tuple(self._links)

    @property
    def gripper_links(self) -> tuple[int, ...]:
        """pybullet link indices of the gripper's palm and fingers."""
        return tuple(self.link_index(name) for name in GRIPPER_LINKS)

    def link_index(self, name: str) -> int:
        """pybullet link index of a URDF link (-1 for the base)."""
        if name not in self._links:
            raise ValueError(f"unknown robot link {name!r}; links are {sorted(self._links)}")
        return self._links[name]

    def q(self) -> FloatArray:
        """(7,) joint positions [rad]."""
        states = pb.getJointStates(self.body_id, self.joint_indices, physicsClientId=self._client)
        return np.array([s[0] for s in states])

    def dq(self) -> FloatArray:
        """(7,) joint velocities [rad/s]."""
        states = pb.getJointStates(self.body_id, self.joint_indices, physicsClientId=self._client)
        return np.array([s[1] for s in states])

    def reset_joints(self, q: npt.ArrayLike) -> None:
        """Teleports the arm to `q` [rad] at rest and holds it there."""
        q = self._check_q(q)
        for index, value in zip(self.joint_indices, q, strict=True):
            pb.resetJointState(self.body_id, index, float(value), 0.0, physicsClientId=self._client)
        self.command_joints(q)

    def command_joints(self, q_target: npt.ArrayLike, dq_target: npt.ArrayLike | None = None) -> None:
        """Sets the position-control targets [rad] (and velocities [rad/s]) used at every step."""
        q = self._check_q(q_target)
        dq = np.zeros(7) if dq_target is None else np.asarray(dq_target, dtype=float).reshape(-1)
        if dq.shape != (7,) or not np.all(np.isfinite(dq)):
            raise ValueError(f"dq_target must be 7 finite velocities [rad/s], got {dq.tolist()}")
        pb.setJointMotorControlArray(
            self.body_id,
            self.joint_indices,
            pb.POSITION_CONTROL,
            targetPositions=q.tolist(),
            targetVelocities=dq.tolist(),
            forces=self._effort.tolist(),
            positionGains=[self._config.position_gain] * 7,
            physicsClientId=self._client,
        )

    def set_gripper(self, opening: float) -> None:
        """Commands the gap the fingers open beyond closed [m], 0 (closed) .. 0.08."""
        if not 0.0 <= opening <= MAX_OPENING:
            raise ValueError(f"gripper opening must be within 0 .. {MAX_OPENING} m, got {opening}")
        pb.setJointMotorControlArray(
            self.body_id,
            self.finger_indices,
            pb.POSITION_CONTROL,
            targetPositions=[opening / 2, opening / 2],
            forces=[40.0, 40.0],
            physicsClientId=self._client,
        )

    def gripper_opening(self) -> float:
        """Current gap beyond closed [m] (sum of both finger joints)."""
        states = pb.getJointStates(self.body_id, self.finger_indices, physicsClientId=self._client)
        return float(sum(s[0] for s in states))

    def frame_pose(self, name: str) -> FloatArray:
        """4x4 world pose of a URDF link frame, from pybullet's forward kinematics."""
        index = self.link_index(name)
        if index < 0:
            pos, quat = pb.getBasePositionAndOrientation(self.body_id, physicsClientId=self._client)
        else:
            state = pb.getLinkState(
                self.body_id, index, computeForwardKinematics=True, physicsClientId=self._client
            )
            pos, quat = state[4], state[5]
        return make_transform(matrix_from_quaternion_xyzw(quat), pos)

    def frame_velocity(self, name: str) -> tuple[FloatArray, FloatArray]:
        """Linear [m/s] and angular [rad/s] velocity (3,) of a URDF link frame, in Σ_W."""
        index = self.link_index(name)
        if index < 0:
            linear, angular = pb.getBaseVelocity(self.body_id, physicsClientId=self._client)
        else:
            state = pb.getLinkState(
                self.body_id,
                index,
                computeLinkVelocity=1,
                computeForwardKinematics=True,
                physicsClientId=self._client,
            )
            linear, angular = state[6], state[7]
        return np.asarray(linear, dtype=float), np.asarray(angular, dtype=float)

    def arm_collisions(self, bodies: tuple[int, ...] | list[int], margin: float = 0.0) -> list[Contact]:
        """Contacts (closer than `margin` [m]) between moving robot links and the given bodies.

        The base link stands on the table and is not reported.
        """
        names = {index: name for name, index in self._links.items()}
        contacts = []
        for body in bodies:
            for point in pb.getClosestPoints(self.body_id, body, margin, physicsClientId=self._client):
                if point[3] >= 0:
                    contacts.append(Contact(names[point[3]], body, float(point[8])))
        return contacts

    def solve_frame_ik(
        self, frame: str, target: npt.ArrayLike, q_rest: npt.ArrayLike, tolerance: float = 1e-4
    ) -> FloatArray:
        """Joint angles placing `frame` at the 4x4 `target`, near `q_rest` (pybullet IK).

        Leaves the arm where it was. Raises IKError with the residual if it fails.
        """
        T = np.asarray(target, dtype=float)
        index = self.link_index(frame)
        q_saved = self.q()
        rest = self._check_q(q_rest)
        # pybullet's null-space IK wants one entry per movable joint: arm then fingers
        fingers = [self.gripper_opening() / 2] * 2
        lower = [*self.lower_limits, 0.0, 0.0]
        upper = [*self.upper_limits, MAX_OPENING / 2, MAX_OPENING / 2]
        ranges = [u - lo for u, lo in zip(upper, lower, strict=True)]
        q = rest
        position_error, angle_error = np.inf, np.inf
        try:
            self.reset_joints(rest)
            for _ in range(20):
                solution = pb.calculateInverseKinematics(
                    self.body_id,
                    index,
                    T[:3, 3].tolist(),
                    quaternion_xyzw_from_matrix(T[:3, :3]).tolist(),
                    lowerLimits=lower,
                    upperLimits=upper,
                    jointRanges=ranges,
                    restPoses=[*rest, *fingers],
                    maxNumIterations=200,
                    residualThreshold=1e-9,
                    physicsClientId=self._client,
                )
                q = np.clip(np.array(solution[:7]), self.lower_limits, self.upper_limits)
                q = self._newton(index, T, q, fingers)
                reached = self.frame_pose(frame)
                position_error = float(np.linalg.norm(reached[:3, 3] - T[:3, 3]))
                angle_error = rotation_angle_between(reached[:3, :3], T[:3, :3])
                if position_error < tolerance and angle_error < 10 * tolerance:
                    return q
        finally:
            self.reset_joints(q_saved)
        raise IKError(
            f"pybullet IK for '{frame}' did not converge: position error {position_error * 1000:.2f} mm, "
            f"orientation error {np.degrees(angle_error):.3f} deg"
        )

    def _newton(self, index: int, target: FloatArray, q: FloatArray, fingers: list[float]) -> FloatArray:
        """Damped Gauss-Newton on pybullet's Jacobian; leaves the arm at the result."""
        for _ in range(30):
            self.reset_joints(q)
            state = pb.getLinkState(
                self.body_id, index, computeForwardKinematics=True, physicsClientId=self._client
            )
            R = matrix_from_quaternion_xyzw(state[5])
            error_position = target[:3, 3] - np.asarray(state[4])
            error_rotation = R @ _log_so3(R.T @ target[:3, :3])
            error = np.concatenate([error_position, error_rotation])
            if np.linalg.norm(error) < 1e-9:
                break
            linear, angular = pb.calculateJacobian(
                self.body_id, index, [0.0, 0.0, 0.0], [*q, *fingers], [0.0] * 9, [0.0] * 9,
                physicsClientId=self._client,
            )  # fmt: skip
            J = np.vstack([np.asarray(linear)[:, :7], np.asarray(angular)[:, :7]])
            step = J.T @ np.linalg.solve(J @ J.T + 1e-8 * np.eye(6), error)
            q = np.clip(q + step, self.lower_limits, self.upper_limits)
        return q

    def _check_q(self, q: npt.ArrayLike) -> FloatArray:
        values = np.asarray(q, dtype=float).reshape(-1)
        if values.shape != (7,) or not np.all(np.isfinite(values)):
            raise ValueError(f"expected 7 finite joint angles [rad] for {self.joint_names}, got {values}")
        return values


def _log_so3(R: FloatArray) -> FloatArray:
    angle = rotation_angle_between(np.eye(3), R)
    axis = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    if angle < 1e-9:
        return 0.5 * axis
    return angle / (2 * np.sin(angle)) * axis


__all__ = ["ARM_DOF", "FINGER_JOINTS", "GRIPPER_LINKS", "MAX_OPENING", "Contact", "SimRobot"]
