"""The TCP's height above the cloth while the servo tracks it down and lifts it off the belt.

`HeightProfile` is the height over time: a quintic smoothstep between two heights (zero
velocity and acceleration at both ends), restarted from wherever it is when DESCEND holds,
resumes or LIFT begins. `tcp_height` turns a height above the predicted grasp point into
the TCP's z: the cloth lies on the belt, so its surface is taken between the belt and a
wrinkle above it (a recognised depth outside is the depth error of a close view: up to
17 mm measured at the working distance for a navy napkin, which left the fingers 4 cm
above it), and the TCP never goes lower than `min_table_clearance` above the belt.
"""

from __future__ import annotations

CLOTH_SURFACE_MAX = 0.01  # [m] a cloth's surface on the belt is at most this above it (wrinkles)


def tcp_height(point_z: float, height: float, table_z: float, min_table_clearance: float) -> float:
    """The TCP's z [m] `height` [m] above a predicted grasp point at `point_z` [m] on the belt
    whose top is at `table_z` [m], never lower than `min_table_clearance` [m] above it."""
    surface = min(max(point_z, table_z), table_z + CLOTH_SURFACE_MAX)
    return max(surface + height, table_z + min_table_clearance)


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


__all__ = ["CLOTH_SURFACE_MAX", "HeightProfile", "tcp_height"]
