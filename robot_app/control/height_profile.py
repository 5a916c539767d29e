"""The TCP's height above the cloth while the servo tracks it down and lifts it off the belt.

`HeightProfile` is the height over time: a quintic smoothstep between two heights (zero
velocity and acceleration at both ends), restarted from wherever it is when DESCEND holds,
resumes or LIFT begins, at a mean speed the joints can follow (`vertical_speed`).
`tcp_height` turns a height above the predicted grasp point into
the TCP's z: the cloth lies on the belt, so its surface is taken between the belt and a
wrinkle above it (`cloth_surface`; a recognised depth outside is the depth error of a
close view: up to 17 mm measured at the working distance for a navy napkin, which left
the fingers 4 cm above it; the servo's camera-to-cloth distance takes the surface the
same way), and the TCP never goes lower than `min_table_clearance` above the belt.
"""

from __future__ import annotations

import numpy as np

from robot_app.arrays import FloatArray
from robot_app.control.limits import JointLimits

CLOTH_SURFACE_MAX = 0.01  # [m] a cloth's surface on the belt is at most this above it (wrinkles)
MIN_VERTICAL_SPEED = 0.03  # [m/s] a vertical profile is never slower on average


def cloth_surface(point_z: float, table_z: float) -> float:
    """The cloth's surface z [m] for a predicted `point_z` [m] on the belt whose top is at
    `table_z` [m]: between the belt and CLOTH_SURFACE_MAX above it."""
    return min(max(point_z, table_z), table_z + CLOTH_SURFACE_MAX)


def tcp_height(point_z: float, height: float, table_z: float, min_table_clearance: float) -> float:
    """The TCP's z [m] `height` [m] above a predicted grasp point at `point_z` [m] on the belt
    whose top is at `table_z` [m], never lower than `min_table_clearance` [m] above it."""
    return max(cloth_surface(point_z, table_z) + height, table_z + min_table_clearance)


def vertical_speed(
    jacobian: FloatArray,
    limits: JointLimits,
    horizontal_velocity: FloatArray,
    rise: float,
    top_speed: float,
    share: float,
) -> float:
    """Mean speed [m/s] of a `HeightProfile` over `rise` [m] that the joints can follow.

    `top_speed`, or less where the joints would need more than `share` of their velocity,
    acceleration or jerk limits at the quintic's peaks (15/8 v, 5.77 v^2/h and 60 v^3/h^2
    for a mean speed v over a height h), the velocity on top of the TCP's
    `horizontal_velocity` [m/s] (following a moving cloth; far out, the shoulder does).
    A profile the joints cannot follow is tracked late: with the velocity bound alone, a
    0.13 m DESCEND needed twice the jerk limit, the hand lagged 0.1 m behind the profile,
    caught up at 0.34 m/s near the table, and a doubt there could not stop it before the
    fingertips touched the table (bench_pick_place episodes 32, 61, 64).

    Args:
        jacobian: (6, n) the TCP's Jacobian (world-aligned) at the posture [m/rad, rad/rad].
        limits: the joints' limits.
        horizontal_velocity: (3,) the TCP's velocity besides the profile [m/s].
        rise: the profile's height change [m] (either sign).
        top_speed: the fastest mean speed wanted [m/s].
        share: of each joint limit the profile may use at its peak (0-1].
    """
    J = np.asarray(jacobian, dtype=float)
    pinv = J.T @ np.linalg.inv(J @ J.T + 1e-6 * np.eye(6))
    horizontal = np.abs(pinv[:, :3] @ np.asarray(horizontal_velocity, dtype=float))
    per_speed = np.abs(pinv[:, 2]) + 1e-9  # [rad/m] of each joint per metre up
    by_velocity = (np.maximum(share * limits.velocity - horizontal, 0.0) / per_speed).min() / 1.875
    h = max(abs(float(rise)), 1e-3)
    by_acceleration = np.sqrt(share * limits.acceleration * h / (5.774 * per_speed)).min()
    by_jerk = np.cbrt(share * limits.jerk * h * h / (60.0 * per_speed)).min()
    speed = min(float(by_velocity), float(by_acceleration), float(by_jerk))
    return float(min(top_speed, max(MIN_VERTICAL_SPEED, speed)))


class HeightProfile:
    """A height [m] going from `first` at `start` [s] to `last` over `duration` [s] along a
    quintic smoothstep (zero velocity and acceleration at both ends)."""

    def __init__(self, first: float, last: float, start: float, duration: float) -> None:
        self.first, self.last, self.start = first, last, start
        self.duration = max(duration, 1e-6)

    @property
    def end(self) -> float:
        """When the profile reaches `last` [s]."""
        return self.start + self.duration

    def to(self, last: float, now: float, speed: float) -> HeightProfile:
        """A new profile from this one's height at `now` [s] to `last` [m] at mean `speed` [m/s]."""
        first = self.at(now)
        return HeightProfile(first, last, now, abs(last - first) / speed)

    def at(self, t: float) -> float:
        """The height [m] at `t` [s]."""
        u = min(1.0, max(0.0, (t - self.start) / self.duration))
        return self.first + (self.last - self.first) * u**3 * (10.0 - 15.0 * u + 6.0 * u * u)

    def rate(self, t: float) -> float:
        """Its rate [m/s] at `t` [s]."""
        u = min(1.0, max(0.0, (t - self.start) / self.duration))
        return (self.last - self.first) * 30.0 * u * u * (1.0 - u) ** 2 / self.duration

    def acceleration(self, t: float) -> float:
        """Its acceleration [m/s^2] at `t` [s]."""
        u = min(1.0, max(0.0, (t - self.start) / self.duration))
        return (self.last - self.first) * 60.0 * u * (1.0 - u) * (1.0 - 2.0 * u) / self.duration**2


__all__ = [
    "CLOTH_SURFACE_MAX",
    "MIN_VERTICAL_SPEED",
    "HeightProfile",
    "cloth_surface",
    "tcp_height",
    "vertical_speed",
]
