"""Kinematics of one serial chain of any URDF robot: FK, frame Jacobians and IK.

`Kinematics` wraps a Pinocchio model reduced to the joints between a base link and a
tip frame (every other joint is locked with `buildReducedModel`). Its joint vector has
one coordinate per chain joint, in chain order: an angle [rad] for revolute joints (a
continuous joint is wrapped into [-pi, pi)) or a displacement [m] for prismatic ones.
Poses are 4x4 transforms expressed in the base link's frame ("world" of this model).

The IK is a Levenberg-Marquardt / damped-least-squares iteration on the SE(3) error
log6(T_tip^-1 T_target) with the exact Jacobian of that error (Jlog6), an optional
null-space pull toward a preferred posture, joint limits enforced every step (joints
pushed against a limit are frozen, the rest clamped), and seeded random restarts when
an attempt stalls, all within a wall-clock budget (see `_ik_solver`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from robot_app.arrays import FloatArray
from robot_app.control._ik_solver import IKSearch, warm_up
from robot_app.errors import IKError, InputError

_EYE3 = np.eye(3)
_REFERENCES = {
    "local": pin.LOCAL,
    "local_world_aligned": pin.LOCAL_WORLD_ALIGNED,
    "world": pin.WORLD,
}


def _readonly(array: npt.ArrayLike) -> FloatArray:
    out = np.array(array, dtype=float)
    out.setflags(write=False)
    return out


@dataclass(frozen=True)
class IKResult:
    """Outcome of one `Kinematics.solve_ik` call.

    Attributes:
        q: best joint vector found, within the joint limits [rad or m], read-only.
        success: both residuals are within the requested tolerances.
        position_error: distance between the reached and the target frame origin [m].
        orientation_error: angle of the rotation from reached to target orientation [rad].
        iterations: IK iterations over all attempts.
        restarts: random restarts used (0 if the first attempt converged).
        time_s: wall-clock time of the solve [s].
    """

    q: FloatArray
    success: bool
    position_error: float
    orientation_error: float
    iterations: int
    restarts: int
    time_s: float

    def raise_if_failed(self) -> IKResult:
        """Returns self if successful, else raises IKError with the residuals."""
        if not self.success:
            raise IKError(
                f"IK did not converge: position error {self.position_error:.3g} m, orientation error "
                f"{self.orientation_error:.3g} rad after {self.iterations} iterations and "
                f"{self.restarts} restarts ({self.time_s * 1e3:.2f} ms)"
            )
        return self


class Kinematics:
    """FK, Jacobians and IK of the chain base_link -> tip_frame of a Pinocchio model.

    Args:
        model: full Pinocchio model (e.g. from `pin.buildModelFromUrdf`).
        base_link: frame whose pose is the reference of every pose returned.
        tip_frame: end frame of the chain; `solve_ik` targets it by default.
        locked_positions: joint name -> position [rad or m] for joints outside the
            chain; others are locked at their neutral value, clipped into their limits.

    Raises:
        InputError: unknown frames or joints, a base not on the path to the tip, or a
            chain joint that is not 1-DoF revolute/prismatic.

    One instance owns one Pinocchio data buffer: it is not thread-safe; use one per
    thread or process. Arrays it hands out are read-only or fresh copies.
    """

    def __init__(
        self,
        model: pin.Model,
        base_link: str,
        tip_frame: str,
        locked_positions: Mapping[str, float] | None = None,
    ) -> None:
        for name in (base_link, tip_frame):
            if not model.existFrame(name):
                known = ", ".join(sorted({f.name for f in model.frames})[:12])
                raise InputError(
                    f"frame '{name}' is not in model '{model.name}'; frames include: {known}", key=name
                )
        chain = self._chain_joint_ids(model, base_link, tip_frame)
        q_ref = self._locked_configuration(model, locked_positions or {})
        locked = [j for j in range(1, model.njoints) if j not in chain]
        self._model = pin.buildReducedModel(model, locked, q_ref) if locked else model.copy()
        self._data = self._model.createData()
        self.base_link = base_link
        self.tip_frame = tip_frame
        self._tip_id = self._model.getFrameId(tip_frame)
        self._setup_joints()
        pin.framesForwardKinematics(self._model, self._data, self._to_pin(self._mid))
        base_placement = self._data.oMf[self._model.getFrameId(base_link)].copy()
        self._base_inv = base_placement.inverse()
        self._base_is_universe = bool(np.allclose(base_placement.homogeneous, np.eye(4), atol=1e-15))
        warm_up(self.nq)

    @classmethod
    def from_urdf(
        cls,
        urdf_path: str | Path,
        base_link: str,
        tip_frame: str,
        package_dirs: Sequence[str | Path] | None = None,
        locked_positions: Mapping[str, float] | None = None,
    ) -> Kinematics:
        """Loads the kinematic tree of a URDF (no meshes are read).

        Args:
            urdf_path: URDF file.
            base_link: reference frame of all poses.
            tip_frame: end frame of the chain.
            package_dirs: folders that resolve `package://` URIs; only checked to
                exist, since kinematics reads no meshes.
            locked_positions: positions of joints outside the chain [rad or m].
        """
        path = Path(urdf_path)
        if not path.is_file():
            raise InputError(f"URDF file not found: {path}", path=path)
        for folder in package_dirs or ():
            if not Path(folder).is_dir():
                raise InputError(f"package dir not found: {folder}", path=folder)
        try:
            model = pin.buildModelFromUrdf(str(path))
        except (RuntimeError, ValueError) as err:
            raise InputError(f"cannot parse URDF {path}: {err}", path=path) from err
        return cls(model, base_link, tip_frame, locked_positions)

    # ----------------------------------------------------------------- model set-up
    @staticmethod
    def _chain_joint_ids(model: pin.Model, base_link: str, tip_frame: str) -> set[int]:
        def ancestors(joint_id: int) -> list[int]:
            out = []
            while joint_id > 0:
                out.append(joint_id)
                joint_id = model.parents[joint_id]
            return out

        tip_path = ancestors(model.frames[model.getFrameId(tip_frame)].parentJoint)
        base_path = ancestors(model.frames[model.getFrameId(base_link)].parentJoint)
        if base_path and base_path[0] not in tip_path:
            raise InputError(
                f"'{base_link}' is not on the path from the root to '{tip_frame}'", key=base_link
            )
        chain = set(tip_path) - set(base_path)
        if not chain:
            raise InputError(f"no joint between '{base_link}' and '{tip_frame}'")
        return chain

    @staticmethod
    def _locked_configuration(model: pin.Model, locked_positions: Mapping[str, float]) -> FloatArray:
        q = pin.neutral(model)
        for j in range(1, model.njoints):
            joint = model.joints[j]
            if joint.nq == 1:
                lo, hi = model.lowerPositionLimit[joint.idx_q], model.upperPositionLimit[joint.idx_q]
                q[joint.idx_q] = min(max(q[joint.idx_q], lo), hi)
        for name, value in locked_positions.items():
            if not model.existJointName(name):
                raise InputError(f"locked joint '{name}' is not in model '{model.name}'", key=name)
            joint = model.joints[model.getJointId(name)]
            if joint.nq == 1:
                q[joint.idx_q] = value
            elif joint.nq == 2 and joint.nv == 1:
                q[joint.idx_q : joint.idx_q + 2] = (math.cos(value), math.sin(value))
            else:
                raise InputError(f"joint '{name}' has {joint.nv} DoF; only 1-DoF joints can be set by value")
        return q

    def _setup_joints(self) -> None:
        model = self._model
        names, lower, upper, wrap, simple_q, simple_v, cont_q, cont_v = [], [], [], [], [], [], [], []
        for j in range(1, model.njoints):
            joint, name = model.joints[j], model.names[j]
            if joint.nv != 1 or joint.nq not in (1, 2):
                raise InputError(
                    f"joint '{name}' ({joint.shortname()}) is not a 1-DoF revolute or prismatic joint"
                )
            names.append(name)
            lo = model.lowerPositionLimit[joint.idx_q]
            hi = model.upperPositionLimit[joint.idx_q]
            revolute = joint.shortname().removeprefix("JointModel").startswith("R")
            if joint.nq == 2 or not (np.isfinite(lo) and np.isfinite(hi) and hi - lo < 1e6):
                if not revolute and joint.nq == 1:
                    raise InputError(f"prismatic joint '{name}' has no finite limits")
                lo, hi = -math.pi, math.pi
                wrap.append(True)
            else:
                wrap.append(False)
            if joint.nq == 2:
                cont_q.append(joint.idx_q)
                cont_v.append(joint.idx_v)
            else:
                simple_q.append(joint.idx_q)
                simple_v.append(joint.idx_v)
            lower.append(lo)
            upper.append(hi)
        self.joint_names: tuple[str, ...] = tuple(names)
        self.nq = len(names)
        self._lower = _readonly(lower)
        self._upper = _readonly(upper)
        self._mid = _readonly((self._lower + self._upper) / 2.0)
        self._velocity = _readonly(model.velocityLimit)
        self._wrap = np.array(wrap, dtype=bool)
        self._any_wrap = bool(self._wrap.any())
        self._clip_lower = np.where(self._wrap, -np.inf, self._lower)
        self._clip_upper = np.where(self._wrap, np.inf, self._upper)
        self._identity_q = not cont_q and simple_q == list(range(self.nq)) and simple_v == simple_q
        self._simple_q, self._simple_v = np.array(simple_q, int), np.array(simple_v, int)
        self._cont_q, self._cont_v = np.array(cont_q, int), np.array(cont_v, int)

    # ----------------------------------------------------------------- properties
    @property
    def lower(self) -> FloatArray:
        """Lower joint limits [rad or m] (-pi for continuous joints), read-only."""
        return self._lower

    @property
    def upper(self) -> FloatArray:
        """Upper joint limits [rad or m] (+pi for continuous joints), read-only."""
        return self._upper

    @property
    def velocity_limits(self) -> FloatArray:
        """Joint velocity limits from the URDF [rad/s or m/s], read-only."""
        return self._velocity

    @property
    def neutral(self) -> FloatArray:
        """Mid-range configuration (lower + upper) / 2, read-only."""
        return self._mid

    @property
    def continuous(self) -> npt.NDArray[np.bool_]:
        """True for joints that wrap (continuous or unlimited revolute), read-only copy."""
        out = self._wrap.copy()
        out.setflags(write=False)
        return out

    @property
    def frame_names(self) -> tuple[str, ...]:
        """Names of every frame of the reduced model."""
        return tuple(frame.name for frame in self._model.frames)

    # ----------------------------------------------------------------- conversions
    def _to_pin(self, q: FloatArray) -> FloatArray:
        if self._identity_q:
            return q
        q_pin = np.empty(self._model.nq)
        q_pin[self._simple_q] = q[self._simple_v]
        angles = q[self._cont_v]
        q_pin[self._cont_q] = np.cos(angles)
        q_pin[self._cont_q + 1] = np.sin(angles)
        return q_pin

    def _check_q(self, q: npt.ArrayLike, what: str = "q") -> FloatArray:
        arr = np.asarray(q, dtype=float)
        if arr.shape != (self.nq,) or not np.all(np.isfinite(arr)):
            raise ValueError(
                f"{what} must be {self.nq} finite joint values ({', '.join(self.joint_names)}), "
                f"got shape {arr.shape}"
            )
        return np.ascontiguousarray(arr)

    def _frame_id(self, frame: str | None) -> int:
        if frame is None:
            return self._tip_id
        if not self._model.existFrame(frame):
            raise ValueError(f"unknown frame '{frame}'; valid frames: {', '.join(self.frame_names)}")
        return self._model.getFrameId(frame)

    def clip(self, q: npt.ArrayLike) -> FloatArray:
        """Returns q clamped into the joint limits, continuous joints wrapped into [-pi, pi)."""
        out = np.clip(self._check_q(q), self._clip_lower, self._clip_upper)
        if self._any_wrap:
            out[self._wrap] = (out[self._wrap] + math.pi) % (2.0 * math.pi) - math.pi
        return out

    def within_limits(self, q: npt.ArrayLike, tol: float = 0.0) -> bool:
        """True if q respects every joint limit within tol [rad or m]."""
        arr = self._check_q(q)
        inside = (arr >= self._lower - tol) & (arr <= self._upper + tol)
        return bool(np.all(inside | self._wrap))

    def random_configuration(self, rng: np.random.Generator) -> FloatArray:
        """Uniform sample within the joint limits."""
        return rng.uniform(self._lower, self._upper)

    # ----------------------------------------------------------------- FK / Jacobians
    def frame_pose(self, q: npt.ArrayLike, frame: str) -> FloatArray:
        """Pose of `frame` in the base frame, 4x4, for joint vector q."""
        fid = self._frame_id(frame)
        pin.forwardKinematics(self._model, self._data, self._to_pin(self._check_q(q)))
        placement = pin.updateFramePlacement(self._model, self._data, fid)
        if not self._base_is_universe:
            placement = self._base_inv * placement
        return np.array(placement.homogeneous)

    def tip_pose(self, q: npt.ArrayLike) -> FloatArray:
        """Pose of the tip frame in the base frame, 4x4."""
        return self.frame_pose(q, self.tip_frame)

    def frame_jacobian(
        self, q: npt.ArrayLike, frame: str | None = None, reference: str = "local_world_aligned"
    ) -> FloatArray:
        """Jacobian (6, nq) of a frame's twist (linear [m/s]; angular [rad/s]) w.r.t. q.

        Args:
            q: joint vector.
            frame: frame name (default: the tip frame).
            reference: 'local' (frame axes), 'local_world_aligned' (frame origin, base
                axes) or 'world' (base origin and axes).
        """
        if reference not in _REFERENCES:
            raise ValueError(f"reference must be one of {sorted(_REFERENCES)}, got '{reference}'")
        fid = self._frame_id(frame)
        J = pin.computeFrameJacobian(
            self._model, self._data, self._to_pin(self._check_q(q)), fid, _REFERENCES[reference]
        )
        if reference != "local" and not self._base_is_universe:
            if reference == "world":
                J = self._base_inv.toActionMatrix() @ J
            else:
                R = self._base_inv.rotation
                J = np.vstack([R @ J[:3], R @ J[3:]])
        return np.array(J)

    # ----------------------------------------------------------------- IK
    def solve_ik(
        self,
        target: npt.ArrayLike,
        q_init: npt.ArrayLike | None = None,
        *,
        frame: str | None = None,
        time_budget: float = 0.005,
        position_tolerance: float = 1e-5,
        orientation_tolerance: float = 1e-5,
        max_restarts: int | None = None,
        seed: int | None = 0,
        preferred_posture: npt.ArrayLike | None = None,
        null_space_gain: float = 0.1,
    ) -> IKResult:
        """Joint vector that puts `frame` at the 4x4 `target` pose (in the base frame).

        Unreachable targets return success=False with the best residual once the time
        budget or the restarts are used up; they never raise.

        Args:
            target: desired pose of the frame in the base frame, 4x4 rigid transform.
            q_init: start configuration (default: mid-range); clamped into the limits.
            frame: frame to place (default: the tip frame).
            time_budget: wall-clock limit of the whole solve [s].
            position_tolerance: success threshold on the position error [m].
            orientation_tolerance: success threshold on the rotation angle error [rad].
            max_restarts: random restarts allowed (None: as many as the budget allows).
            seed: seed of the restart sampler (None: fresh entropy).
            preferred_posture: posture the null-space term pulls toward; None: no pull.
                With a posture, a converged solution keeps sliding along the self-motion
                toward it while the residual stays within tolerance.
            null_space_gain: gain of that pull per iteration [1/iteration], in [0, 1).

        Raises:
            InputError: malformed target, q_init, posture, frame or settings.
        """
        start = time.perf_counter()
        target_se3 = self._check_target(target)
        fid = self._frame_id(frame)
        if not (0.0 < time_budget < math.inf):
            raise ValueError(f"time_budget must be a positive number of seconds, got {time_budget}")
        if position_tolerance <= 0.0 or orientation_tolerance <= 0.0:
            raise ValueError("position_tolerance and orientation_tolerance must be > 0")
        if not (0.0 <= null_space_gain < 1.0):
            raise ValueError(f"null_space_gain must be in [0, 1), got {null_space_gain}")
        if max_restarts is not None and max_restarts < 0:
            raise ValueError(f"max_restarts must be >= 0 or None, got {max_restarts}")
        q = self.clip(self._mid if q_init is None else self._check_q(q_init, "q_init"))
        if preferred_posture is None:
            posture, null_space_gain = self._mid, 0.0
        else:
            posture = self._check_q(preferred_posture, "preferred_posture")
        if not self._base_is_universe:
            target_se3 = self._base_inv.inverse() * target_se3
        search = IKSearch(
            self._model,
            self._data,
            fid,
            self._to_pin,
            self._lower,
            self._upper,
            self._wrap,
            target_se3,
            position_tolerance,
            orientation_tolerance,
        )
        search.run(q, start + time_budget, max_restarts, seed, posture, null_space_gain)
        return IKResult(
            q=_readonly(search.best_q),
            success=search.success,
            position_error=search.best_position_error,
            orientation_error=search.best_orientation_error,
            iterations=search.iterations,
            restarts=search.restarts,
            time_s=time.perf_counter() - start,
        )

    @staticmethod
    def _check_target(target: npt.ArrayLike) -> pin.SE3:
        T = np.asarray(target, dtype=float)
        if T.shape != (4, 4) or not np.isfinite(T).all():
            raise ValueError(f"IK target must be a finite 4x4 transform, got shape {T.shape}")
        R = T[:3, :3]
        # Cheaper than geometry.is_rotation (same test, tol 1e-6): this runs on every solve.
        (a, b, c), (d, e, f), (g, h, i) = R.tolist()
        det = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)
        orthonormal = float(np.abs(R.T @ R - _EYE3).max()) <= 1e-6 and abs(det - 1.0) <= 1e-6
        if not orthonormal or T[3].tolist() != [0.0, 0.0, 0.0, 1.0]:
            raise ValueError("IK target is not rigid: its 3x3 block must be a rotation, last row 0 0 0 1")
        return pin.SE3(R.copy(), T[:3, 3].copy())


__all__ = ["IKResult", "Kinematics"]
