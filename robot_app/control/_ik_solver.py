"""The inner IK search of `Kinematics.solve_ik` (private).

One solve = attempts from a start configuration, then from seeded random ones. An
attempt iterates a Levenberg-Marquardt step on the SE(3) error e = log6(T^-1 T_target):

    dq = z + Je^T (Je Je^T + lambda I)^-1 (e - Je z),   Je = Jlog6(T_target^-1 T) J_local,
    lambda = DAMPING_GAIN * |e|^2 + BASE_DAMPING        (Sugihara 2011, damping ~ error),
    z = gain * (q_preferred - q)                        (null-space pull, damped projection),

Joints on a limit that the step pushes outward are frozen and the step recomputed
without them; then q is clamped into the limits (continuous joints wrapped). An attempt
ends on success, when the error stops falling (STALL_PATIENCE iterations without a 2 %
improvement), after MAX_ITERATIONS_PER_ATTEMPT, or at the deadline. With a posture
pull, a successful attempt is then polished: pulled steps along the self-motion, each
re-converged within tolerance. A step's linear algebra is one numba kernel (a 6x6
Cholesky) because numpy's per-call overhead dominated at this size. Sugihara 2011:
"Solvability-unconcerned inverse kinematics by the Levenberg-Marquardt method", T-RO.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

import numba
import numpy as np
import numpy.typing as npt
import pinocchio as pin

from robot_app.arrays import FloatArray

_TWO_PI = 2.0 * math.pi


@numba.njit(cache=True)
def _dls_step(
    Je: FloatArray, r: FloatArray, z: FloatArray, free: npt.NDArray[np.bool_], damping: float, dq: FloatArray
) -> None:  # pragma: no cover - compiled
    """dq = z + Je_f^T (Je_f Je_f^T + damping I)^-1 r over the free joints (6x6 Cholesky)."""
    n = dq.shape[0]
    L = np.zeros((6, 6))
    for i in range(6):
        for k in range(i + 1):
            s = 0.0
            for j in range(n):
                if free[j]:
                    s += Je[i, j] * Je[k, j]
            if i == k:
                s += damping
            for m in range(k):
                s -= L[i, m] * L[k, m]
            if i == k:
                L[i, i] = math.sqrt(max(s, 1e-300))
            else:
                L[i, k] = s / L[k, k]
    y = np.empty(6)
    for i in range(6):
        s = r[i]
        for m in range(i):
            s -= L[i, m] * y[m]
        y[i] = s / L[i, i]
    for i in range(5, -1, -1):
        s = y[i]
        for m in range(i + 1, 6):
            s -= L[m, i] * y[m]
        y[i] = s / L[i, i]
    for j in range(n):
        v = 0.0
        if free[j]:
            v = z[j]
            for i in range(6):
                v += Je[i, j] * y[i]
        dq[j] = v


@numba.njit(cache=True)
def _lm_step(
    Jlog: FloatArray,
    J: FloatArray,
    err: FloatArray,
    q: FloatArray,
    lower: FloatArray,
    upper: FloatArray,
    wrap: npt.NDArray[np.bool_],
    posture: FloatArray,
    gain: float,
    damping: float,
) -> None:  # pragma: no cover - compiled
    """One damped least-squares step on q, in place, then limits (see module docstring).

    Joints sitting on a limit that the step would push outward are frozen and the step
    is recomputed without them (at most n passes), so the other joints take up the
    motion instead of the step being clipped into a wrong direction.
    """
    n = q.shape[0]
    Je = np.zeros((6, n))
    for i in range(6):
        for k in range(6):
            a = Jlog[i, k]
            if a != 0.0:
                for j in range(n):
                    Je[i, j] += a * J[k, j]
    z = np.zeros(n)
    if gain > 0.0:
        for j in range(n):
            d = posture[j] - q[j]
            if wrap[j]:
                d = (d + math.pi) % _TWO_PI - math.pi
            z[j] = gain * d
    free = np.ones(n, dtype=np.bool_)
    r = np.empty(6)
    dq = np.empty(n)
    for _ in range(n):
        for i in range(6):
            acc = err[i]
            for j in range(n):
                if free[j]:
                    acc -= Je[i, j] * z[j]
            r[i] = acc
        _dls_step(Je, r, z, free, damping, dq)
        changed = False
        for j in range(n):
            pushing_out = (q[j] <= lower[j] and dq[j] < 0.0) or (q[j] >= upper[j] and dq[j] > 0.0)
            if free[j] and not wrap[j] and pushing_out:
                free[j] = False
                changed = True
        if not changed:
            break
    for j in range(n):
        v = q[j] + dq[j]
        if wrap[j]:
            v = (v + math.pi) % _TWO_PI - math.pi
        elif v < lower[j]:
            v = lower[j]
        elif v > upper[j]:
            v = upper[j]
        q[j] = v


def warm_up(dof: int = 7) -> None:
    """Compiles (or loads from numba's cache) the step kernel for `dof` joints.

    Called when a `Kinematics` is built so that the first `solve_ik` is not charged the
    compile time against its budget.
    """
    q = np.zeros(dof)
    _lm_step(
        np.eye(6),
        np.zeros((6, dof)),
        np.zeros(6),
        q,
        q - 1.0,
        q + 1.0,
        np.zeros(dof, np.bool_),
        q.copy(),
        0.1,
        1.0,
    )


class IKSearch:
    """State of one IK solve over a Pinocchio model whose joints are all 1-DoF.

    Args:
        model: reduced Pinocchio model of the chain.
        data: its data (overwritten).
        frame_id: frame to place.
        to_pin: maps a joint vector (one value per joint) to Pinocchio's q.
        lower: lower joint limits [rad or m].
        upper: upper joint limits [rad or m].
        wrap: joints wrapped into [-pi, pi) instead of clamped.
        target: target placement of the frame in the model's universe frame.
        position_tolerance: success threshold [m].
        orientation_tolerance: success threshold [rad].
    """

    MAX_ITERATIONS_PER_ATTEMPT = 80
    MAX_POLISH_ITERATIONS = 40
    POLISH_CORRECTIONS = 3
    STALL_PATIENCE = 6
    DAMPING_GAIN = 0.05
    BASE_DAMPING = 1e-9

    def __init__(
        self,
        model: pin.Model,
        data: pin.Data,
        frame_id: int,
        to_pin: Callable[[FloatArray], FloatArray],
        lower: FloatArray,
        upper: FloatArray,
        wrap: npt.NDArray[np.bool_],
        target: pin.SE3,
        position_tolerance: float,
        orientation_tolerance: float,
    ) -> None:
        self.model, self.data, self.frame_id, self.to_pin = model, data, frame_id, to_pin
        # Writable C-contiguous copies: the kernel is compiled for exactly these array types.
        self.lower, self.upper = np.array(lower, dtype=float), np.array(upper, dtype=float)
        self.wrap = np.array(wrap, dtype=np.bool_)
        self.target = target
        self.target_translation = np.array(target.translation)
        self.position_tolerance = position_tolerance
        self.orientation_tolerance = orientation_tolerance
        self.best_q = (self.lower + self.upper) / 2.0
        self.best_position_error = math.inf
        self.best_orientation_error = math.inf
        self.best_cost = math.inf
        self.success = False
        self.iterations = 0
        self.restarts = 0

    def run(
        self,
        q: FloatArray,
        deadline: float,
        max_restarts: int | None,
        seed: int | None,
        posture: FloatArray,
        gain: float,
    ) -> None:
        """Attempts from q, then from random configurations, until success or limits.

        Args:
            q: first start configuration, within the limits.
            deadline: `time.perf_counter()` value at which to stop [s].
            max_restarts: random restarts allowed (None: until the deadline).
            seed: seed of the restart sampler.
            posture: preferred posture of the null-space pull.
            gain: null-space gain [1/iteration].
        """
        rng: np.random.Generator | None = None
        posture = np.array(posture, dtype=float)
        while True:
            if self._attempt(q, deadline, posture, gain) or time.perf_counter() >= deadline:
                return
            if max_restarts is not None and self.restarts >= max_restarts:
                return
            rng = rng or np.random.default_rng(seed)
            q = rng.uniform(self.lower, self.upper)
            self.restarts += 1

    def _evaluate(self, q: FloatArray) -> tuple[pin.SE3, pin.SE3, FloatArray]:
        """FK and joint Jacobians at q; returns the frame placement, T^-1 T_target, log6 of it."""
        pin.computeJointJacobians(self.model, self.data, self.to_pin(q))  # also runs FK
        placement = pin.updateFramePlacement(self.model, self.data, self.frame_id)
        iMd = placement.actInv(self.target)
        return placement, iMd, pin.log6(iMd).vector

    def _step(self, q: FloatArray, iMd: pin.SE3, err: FloatArray, posture: FloatArray, gain: float) -> None:
        J = pin.getFrameJacobian(self.model, self.data, self.frame_id, pin.LOCAL)
        Jlog = pin.Jlog6(iMd.inverse())  # d log6(T^-1 T_target) = -Jlog6(iMd^-1) J dq
        damping = self.DAMPING_GAIN * float(err @ err) + self.BASE_DAMPING
        _lm_step(Jlog, J, err, q, self.lower, self.upper, self.wrap, posture, gain, damping)

    def _attempt(self, q: FloatArray, deadline: float, posture: FloatArray, gain: float) -> bool:
        q = np.array(q, dtype=float)
        attempt_best, stalled = math.inf, 0
        for _ in range(self.MAX_ITERATIONS_PER_ATTEMPT):
            self.iterations += 1
            placement, iMd, err = self._evaluate(q)
            cost = float(err @ err)
            if cost < self.best_cost:
                self._record(q, placement, err)
                if self.success:
                    if gain > 0.0:
                        self._polish(iMd, err, deadline, posture, gain)
                    return True
            if cost < 0.98 * attempt_best:
                attempt_best, stalled = cost, 0
            else:
                stalled += 1
                if stalled >= self.STALL_PATIENCE:
                    return False
            if time.perf_counter() >= deadline:
                return False
            self._step(q, iMd, err, posture, gain)
        return False

    def _polish(
        self, iMd: pin.SE3, err: FloatArray, deadline: float, posture: FloatArray, gain: float
    ) -> None:
        """After success, keeps moving along the self-motion toward the posture.

        Each pulled step is followed by up to POLISH_CORRECTIONS plain Newton steps that
        bring the residual back within tolerance (else polishing stops at the last
        solution); stops when the motion is below 1e-6 [rad or m], after
        MAX_POLISH_ITERATIONS or at the deadline.
        """
        q = self.best_q.copy()
        for _ in range(self.MAX_POLISH_ITERATIONS):
            if time.perf_counter() >= deadline:
                return
            q_next = q.copy()
            self._step(q_next, iMd, err, posture, gain)
            for correction in range(self.POLISH_CORRECTIONS + 1):
                self.iterations += 1
                placement, iMd, err = self._evaluate(q_next)
                if self._within_tolerance(placement, err):
                    break
                if correction == self.POLISH_CORRECTIONS:
                    return  # the pull left the tolerance for good: keep the last solution
                self._step(q_next, iMd, err, posture, 0.0)
            self._record(q_next, placement, err)
            if float(np.abs(q_next - q).max()) < 1e-6:
                return
            q = q_next

    def _within_tolerance(self, placement: pin.SE3, err: FloatArray) -> bool:
        delta = self.target_translation - placement.translation
        return (
            math.sqrt(float(delta @ delta)) <= self.position_tolerance
            and math.sqrt(float(err[3:] @ err[3:])) <= self.orientation_tolerance
        )

    def _record(self, q: FloatArray, placement: pin.SE3, err: FloatArray) -> None:
        delta = self.target_translation - placement.translation
        self.best_cost = float(err @ err)
        self.best_q = q.copy()
        self.best_position_error = math.sqrt(float(delta @ delta))
        self.best_orientation_error = math.sqrt(float(err[3:] @ err[3:]))
        self.success = (
            self.best_position_error <= self.position_tolerance
            and self.best_orientation_error <= self.orientation_tolerance
        )


__all__ = ["IKSearch", "warm_up"]
