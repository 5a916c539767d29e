"""The conveyor: the green sheet under the recognition range is a belt that carries cloths.

pybullet has no moving-surface contact (a conveyor belt's "surface velocity"), and a
kinematic box moved under a soft body drags it only through the contact solver's friction,
which slips and jitters. The belt therefore moves the cloth the way a belt that does not
slip does: before every physics step, each cloth node that lies on the belt area (within
`CONTACT_HEIGHT` of its surface) and is not held by the gripper moves by the belt's
displacement over the step. The cloth stays a mass-spring soft body: a node lifted off the
belt (by the gripper, or hanging from it) is no longer carried, and the springs between it
and the carried nodes pull as they would on a real belt; a node past the belt's end stays
where it is: the belt ends at the sheet's edge, and a cloth carried there is pushed onto
the still table beyond it and bunches up. Ground truth stays the Kabsch fit of the nodes.

The belt's speed over time is a `BeltMotion`: constant, stop-and-go (runs, decelerates to
a stop, stands, accelerates again) or a ramp from standstill to speed.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray

if TYPE_CHECKING:
    from robot_app.sim.cloth_body import ClothBody
    from robot_app.sim.config import SceneSettings, WorldConfig

CONTACT_HEIGHT = 0.012  # [m] above the belt: resting nodes (~0.3 mm) and a folded flap (6 mm) ride on it
PROFILES = ("constant", "stop_and_go", "ramp")


@dataclass(frozen=True)
class BeltMotion:
    """How fast the belt runs, over the time since it was switched on.

    Attributes:
        speed: top speed [m/s] (>= 0).
        direction_deg: direction of travel in Σ_W, from +x toward +y [deg].
        profile: "constant", "stop_and_go" or "ramp".
        run_time: stop_and_go: time from starting to standing again, per cycle [s].
        stop_time: stop_and_go: time standing per cycle [s].
        acceleration: stop_and_go: acceleration while starting and stopping [m/s^2].
        ramp_time: ramp: time from standstill to `speed` [s].
    """

    speed: float
    direction_deg: float = 0.0
    profile: str = "constant"
    run_time: float = 2.0
    stop_time: float = 1.0
    acceleration: float = 0.5
    ramp_time: float = 4.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.speed) and self.speed >= 0.0):
            raise ValueError(f"belt speed must be finite and >= 0 [m/s], got {self.speed}")
        if self.profile not in PROFILES:
            raise ValueError(f"belt profile must be one of {PROFILES}, got {self.profile!r}")
        if min(self.run_time, self.acceleration, self.ramp_time) <= 0.0 or self.stop_time < 0.0:
            raise ValueError("belt run_time, acceleration and ramp_time must be > 0, stop_time >= 0")

    @classmethod
    def from_scene(cls, scene: SceneSettings) -> BeltMotion:
        """The belt of a scene's `conveyor_*` settings."""
        return cls(
            scene.conveyor_speed,
            scene.conveyor_direction_deg,
            scene.conveyor_profile,
            scene.conveyor_run_time,
            scene.conveyor_stop_time,
            scene.conveyor_acceleration,
            scene.conveyor_ramp_time,
        )

    @property
    def direction(self) -> FloatArray:
        """(3,) unit vector of travel in Σ_W (horizontal)."""
        angle = math.radians(self.direction_deg)
        return np.array([math.cos(angle), math.sin(angle), 0.0])

    def speed_at(self, t: float) -> float:
        """Belt speed [m/s] `t` [s] after it was switched on (0 before)."""
        if t < 0.0 or self.speed == 0.0:
            return 0.0
        if self.profile == "ramp":
            return self.speed * min(1.0, t / self.ramp_time)
        if self.profile == "stop_and_go":
            tau = t % (self.run_time + self.stop_time)
            if tau >= self.run_time:
                return 0.0
            return min(self.speed, self.acceleration * tau, self.acceleration * (self.run_time - tau))
        return self.speed

    def velocity_at(self, t: float) -> FloatArray:
        """(3,) belt velocity [m/s] in Σ_W at `t` [s] after switching on."""
        return self.speed_at(t) * self.direction

    def travel(self, t: float, step: float = 1e-3) -> float:
        """Distance [m] the belt moves in the first `t` [s] (trapezoidal sum over `step`)."""
        if t <= 0.0:
            return 0.0
        times = np.linspace(0.0, t, max(2, math.ceil(t / step) + 1))
        speeds = np.array([self.speed_at(float(s)) for s in times])
        return float(np.sum((speeds[1:] + speeds[:-1]) * np.diff(times)) / 2.0)


@dataclass(frozen=True)
class BeltArea:
    """The belt's top face: an axis-aligned rectangle at height `surface_z` [m] in Σ_W."""

    x_range: tuple[float, float]
    y_range: tuple[float, float]
    surface_z: float

    @classmethod
    def under_sheet(cls, world: WorldConfig) -> BeltArea:
        """The green sheet as the belt: the recognition range and its margin around it."""
        rx, ry = world.range.centre_xy
        margin = world.range.sheet_margin
        hx, hy = world.range.size_xy[0] / 2 + margin, world.range.size_xy[1] / 2 + margin
        return cls((rx - hx, rx + hx), (ry - hy, ry + hy), world.table.top_z)

    def carries(self, points: npt.ArrayLike) -> npt.NDArray[np.bool_]:
        """True for points on the belt: inside the rectangle, within CONTACT_HEIGHT above it."""
        P = np.asarray(points, dtype=float).reshape(-1, 3)
        return (
            (P[:, 0] >= self.x_range[0])
            & (P[:, 0] <= self.x_range[1])
            & (P[:, 1] >= self.y_range[0])
            & (P[:, 1] <= self.y_range[1])
            & (P[:, 2] <= self.surface_z + CONTACT_HEIGHT)
        )

    def contains_xy(self, xy: npt.ArrayLike) -> bool:
        """True if the point (x, y) [m] lies over the belt."""
        x, y = (float(v) for v in np.asarray(xy, dtype=float).reshape(-1)[:2])
        return self.x_range[0] <= x <= self.x_range[1] and self.y_range[0] <= y <= self.y_range[1]


class Conveyor:
    """A running belt in a `World` (the world calls `carry` before every physics step).

    Args:
        motion: the belt's speed profile and direction.
        area: the belt's top face.
    """

    def __init__(self, motion: BeltMotion, area: BeltArea) -> None:
        self.motion = motion
        self.area = area
        self.start_time: float | None = None

    def start(self, time: float) -> None:
        """Switches the belt on at cell time `time` [s]."""
        self.start_time = float(time)

    @property
    def running(self) -> bool:
        return self.start_time is not None

    def velocity_at(self, time: float) -> FloatArray:
        """(3,) belt velocity [m/s] at cell time `time` [s] (zero before it is switched on)."""
        if self.start_time is None:
            return np.zeros(3)
        return self.motion.velocity_at(time - self.start_time)

    def carry(self, cloths: list[ClothBody], time: float, dt: float) -> int:
        """Moves the free nodes on the belt by its displacement over [time, time + dt].

        Returns the number of nodes moved.
        """
        if self.start_time is None or self.motion.speed == 0.0:
            return 0
        displacement = self.velocity_at(time + dt / 2.0) * dt  # midpoint rule
        if not np.any(displacement):
            return 0
        return sum(cloth.move_free_nodes(displacement, self.area.carries) for cloth in cloths)


class ConveyorEncoder:
    """The belt's encoder as the loop reads it (`control.cell.BeltEncoder`): the belt's
    true velocity now plus white noise of `std` per horizontal axis, and its area.

    Args:
        conveyor: the running belt.
        clock: the cell's time now [s].
        std: the encoder's velocity noise per axis [m/s].
        seed: the noise's random seed.
    """

    def __init__(self, conveyor: Conveyor, clock: Callable[[], float], std: float, seed: int) -> None:
        if not (math.isfinite(std) and std >= 0.0):
            raise ValueError(f"the encoder's noise must be finite and >= 0 [m/s], got {std}")
        self.conveyor = conveyor
        self.clock = clock
        self.std = float(std)
        self._rng = np.random.default_rng(seed)

    def velocity(self) -> FloatArray:
        """(vx, vy) [m/s] of the belt now, with the encoder's noise."""
        true = self.conveyor.velocity_at(self.clock())[:2]
        return np.asarray(true + self._rng.normal(0.0, self.std, 2), dtype=float)

    def carries(self, xy: FloatArray) -> bool:
        """True if (x, y) [m] lies over the belt."""
        return self.conveyor.area.contains_xy(xy)


__all__ = ["CONTACT_HEIGHT", "PROFILES", "BeltArea", "BeltMotion", "Conveyor", "ConveyorEncoder"]
