"""Joint limits of the arm: positions and velocities from the URDF, the rest from config.

A URDF gives each revolute joint `<limit lower upper velocity effort>` but says nothing
about acceleration or jerk, which a jerk-limited planner needs. `TrajectorySettings`
derives them from the velocity limits (acceleration = factor x velocity, jerk = factor x
acceleration, both per second) and applies a safety scale below 1 to every kinematic
limit and a margin to each end of the position range, so the commanded motion keeps
clear of the hardware limits.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, NamedTuple

import numpy as np
import numpy.typing as npt
from pydantic import Field

from robot_app.arrays import FloatArray
from robot_app.config import StrictModel
from robot_app.errors import ConfigError
from robot_app.robot_description import PA10_BASE_LINK, PA10_FLANGE, read_joint_chain


class TrajectorySettings(StrictModel):
    """How joint limits for trajectory generation are derived from the URDF's limits.

    Attributes:
        acceleration_per_velocity: acceleration limit = this x velocity limit [1/s];
            2.5 reaches full speed in 0.4 s (plus jerk ramps).
        jerk_per_acceleration: jerk limit = this x acceleration limit [1/s]; 10 ramps
            the acceleration up in 0.1 s.
        safety_scale: factor (0, 1] applied to velocity, acceleration and jerk limits.
        position_margin: taken off each end of every joint's position range [rad].
    """

    acceleration_per_velocity: Annotated[float, Field(gt=0.0, le=100.0)] = 2.5
    jerk_per_acceleration: Annotated[float, Field(gt=0.0, le=1000.0)] = 10.0
    safety_scale: Annotated[float, Field(gt=0.0, le=1.0)] = 0.9
    position_margin: Annotated[float, Field(ge=0.0, le=0.5)] = 0.035


@dataclass(frozen=True)
class JointLimits:
    """Symmetric kinematic limits per joint; arrays are read-only, shape (n,).

    Attributes:
        lower: lowest position [rad].
        upper: highest position [rad].
        velocity: largest |velocity| [rad/s].
        acceleration: largest |acceleration| [rad/s^2].
        jerk: largest |jerk| [rad/s^3].
        names: joint names, same order as the arrays.
    """

    lower: FloatArray
    upper: FloatArray
    velocity: FloatArray
    acceleration: FloatArray
    jerk: FloatArray
    names: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        arrays = {}
        for field in ("lower", "upper", "velocity", "acceleration", "jerk"):
            value = np.array(getattr(self, field), dtype=float).reshape(-1)
            if not np.all(np.isfinite(value)):
                raise ConfigError(
                    f"joint limits: {field} must be finite, got {value.tolist()}",
                    key=field,
                    value=value.tolist(),
                )
            value.setflags(write=False)
            object.__setattr__(self, field, value)
            arrays[field] = value
        n = arrays["lower"].size
        if n == 0 or any(a.size != n for a in arrays.values()):
            sizes = {k: v.size for k, v in arrays.items()}
            raise ValueError(f"joint limits need one value per joint in every array, got sizes {sizes}")
        if self.names and len(self.names) != n:
            raise ValueError(f"joint limits: {len(self.names)} names for {n} joints")
        object.__setattr__(self, "names", tuple(self.names))
        if np.any(arrays["lower"] >= arrays["upper"]):
            raise ConfigError(
                f"joint limits: lower must be below upper, got lower={arrays['lower'].tolist()}, "
                f"upper={arrays['upper'].tolist()}",
                key="lower",
                value=arrays["lower"].tolist(),
                expected=f"below upper {arrays['upper'].tolist()}",
            )
        for field in ("velocity", "acceleration", "jerk"):
            if np.any(arrays[field] <= 0.0):
                raise ConfigError(
                    f"joint limits: {field} must be > 0, got {arrays[field].tolist()}",
                    key=field,
                    value=arrays[field].tolist(),
                )

    @property
    def dof(self) -> int:
        """Number of joints."""
        return int(self.lower.size)

    @classmethod
    def from_velocity_limits(
        cls,
        lower: npt.ArrayLike,
        upper: npt.ArrayLike,
        velocity: npt.ArrayLike,
        settings: TrajectorySettings | None = None,
        names: Sequence[str] = (),
    ) -> JointLimits:
        """Limits from hardware position [rad] and velocity [rad/s] limits and `settings`.

        Acceleration and jerk are derived from the velocity limits, then the safety scale
        and position margin of `settings` are applied.
        """
        settings = settings or TrajectorySettings()
        velocity = np.asarray(velocity, dtype=float)
        acceleration = velocity * settings.acceleration_per_velocity
        hardware = cls(
            lower=np.asarray(lower, dtype=float),
            upper=np.asarray(upper, dtype=float),
            velocity=velocity,
            acceleration=acceleration,
            jerk=acceleration * settings.jerk_per_acceleration,
            names=tuple(names),
        )
        return hardware.scaled(settings.safety_scale, position_margin=settings.position_margin)

    @classmethod
    def from_urdf(
        cls,
        path: str | Path,
        settings: TrajectorySettings | None = None,
        base_link: str = PA10_BASE_LINK,
        tip_link: str = PA10_FLANGE,
    ) -> JointLimits:
        """Limits of the joints from `base_link` to `tip_link` of a URDF (read through
        Pinocchio by `robot_app.urdf.read_joint_chain`, the one source of joint names and
        hardware limits).

        Args:
            path: URDF file.
            settings: derivation of acceleration/jerk and safety scaling; defaults if None.
            base_link, tip_link: the chain's ends (default: the PA10's base and flange).

        Raises:
            InputError: the file is missing or not a URDF, or the chain is empty.
        """
        chain = read_joint_chain(path, base_link, tip_link)
        return cls.from_velocity_limits(chain.lower, chain.upper, chain.velocity, settings, chain.names)

    def scaled(self, factor: float, position_margin: float = 0.0) -> JointLimits:
        """Limits with velocity, acceleration and jerk times `factor` (0, 1] and the
        position range narrowed by `position_margin` [rad] at each end."""
        if not (0.0 < factor <= 1.0):
            raise ConfigError(
                f"limit scale factor must be in (0, 1], got {factor}", key="safety_scale", value=factor
            )
        if not (position_margin >= 0.0 and np.all(self.upper - self.lower > 2.0 * position_margin)):
            raise ConfigError(
                f"position margin must be >= 0 and leave a range, got {position_margin} [rad] "
                f"for ranges {(self.upper - self.lower).tolist()} [rad]",
                key="position_margin",
                value=position_margin,
                expected="a margin >= 0 [rad] below half of every joint's range",
            )
        return JointLimits(
            lower=self.lower + position_margin,
            upper=self.upper - position_margin,
            velocity=self.velocity * factor,
            acceleration=self.acceleration * factor,
            jerk=self.jerk * factor,
            names=self.names,
        )

    def contains(self, q: npt.ArrayLike) -> bool:
        """True if every joint position of `q` [rad] is within [lower, upper]."""
        q = np.asarray(q, dtype=float)
        return bool(np.all(np.isfinite(q)) and np.all(q >= self.lower) and np.all(q <= self.upper))


class LimitReport(NamedTuple):
    """Violations of a `JointLimits` found on sampled states.

    Counts are of (sample, joint) pairs; `worst_*` are the largest |value| / limit ratios
    (for positions, the largest excursion beyond the range over the range's width).

    Attributes:
        samples: number of samples checked.
        position: count outside [lower, upper].
        velocity: count with |v| above the limit.
        acceleration: count with |a| above the limit.
        jerk: count with |finite-difference jerk| above the limit (K-1 intervals).
        worst_velocity: max |v| / limit [-].
        worst_acceleration: max |a| / limit [-].
        worst_jerk: max |da/dt| / limit [-].
        worst_position_excess: max distance beyond the range / range width [-].
    """

    samples: int
    position: int
    velocity: int
    acceleration: int
    jerk: int
    worst_velocity: float
    worst_acceleration: float
    worst_jerk: float
    worst_position_excess: float

    @property
    def violations(self) -> int:
        """Total violations of all four kinds."""
        return self.position + self.velocity + self.acceleration + self.jerk

    @property
    def ok(self) -> bool:
        """True if no sample violates any limit."""
        return self.violations == 0


def check_limits(
    times: npt.ArrayLike,
    Q: npt.ArrayLike,
    V: npt.ArrayLike,
    A: npt.ArrayLike,
    limits: JointLimits,
    tol: float = 1e-9,
) -> LimitReport:
    """Counts limit violations of sampled states (K samples of n joints).

    Jerk is estimated as (A[k+1] - A[k]) / (t[k+1] - t[k]). A ruckig trajectory has
    piecewise-constant jerk, so its acceleration is piecewise linear and this difference
    is the mean jerk over the interval: it cannot exceed the limit unless the jerk did,
    whatever the sampling period. `tol` is therefore only for floating-point rounding:
    ruckig puts its profiles on the limits to ~1e-13 relative, and the difference quotient
    adds eps x |a| / dt, below 1e-12 of the jerk limit for dt >= 1e-4 s with the
    acceleration/jerk ratios of `TrajectorySettings`; the default 1e-9 is far above both
    and far below any real violation.

    Args:
        times: sample times (K,) [s], strictly increasing.
        Q: positions (K, n) [rad].
        V: velocities (K, n) [rad/s].
        A: accelerations (K, n) [rad/s^2].
        limits: the limits to check against.
        tol: relative tolerance [-]: a value violates a limit L if it exceeds L by more
            than tol x L (positions: tol x range width).

    Raises:
        ValueError: the arrays' shapes disagree or times do not increase.
    """
    t = np.asarray(times, dtype=float).reshape(-1)
    Q, V, A = (np.asarray(x, dtype=float) for x in (Q, V, A))
    shape = (t.size, limits.dof)
    if Q.shape != shape or V.shape != shape or A.shape != shape:
        raise ValueError(
            f"check_limits needs Q, V, A of shape {shape} for {t.size} times, "
            f"got {Q.shape}, {V.shape}, {A.shape}"
        )
    if not (tol >= 0.0):
        raise ValueError(f"tolerance must be >= 0, got {tol}")
    intervals = np.diff(t)
    if np.any(intervals <= 0.0):
        raise ValueError("check_limits needs strictly increasing sample times")
    width = limits.upper - limits.lower
    excess = np.maximum(limits.lower - Q, Q - limits.upper) / width
    jerk = np.diff(A, axis=0) / intervals[:, None]
    ratios = [np.abs(x) / bound for x, bound in ((V, limits.velocity), (A, limits.acceleration))]
    jerk_ratio = np.abs(jerk) / limits.jerk
    return LimitReport(
        samples=int(t.size),
        position=int(np.count_nonzero(excess > tol)),
        velocity=int(np.count_nonzero(ratios[0] > 1.0 + tol)),
        acceleration=int(np.count_nonzero(ratios[1] > 1.0 + tol)),
        jerk=int(np.count_nonzero(jerk_ratio > 1.0 + tol)),
        worst_velocity=_max(ratios[0]),
        worst_acceleration=_max(ratios[1]),
        worst_jerk=_max(jerk_ratio),
        worst_position_excess=max(_max(excess), 0.0),
    )


def _max(values: FloatArray) -> float:
    return float(values.max()) if values.size else 0.0


__all__ = ["JointLimits", "LimitReport", "TrajectorySettings", "check_limits"]
