"""What the pick-and-place loop needs from a robot cell: an arm, a stereo camera, a gripper.

The loop (`pick_place.py`) talks to the world only through `Cell`, so that the same
loop can drive the pybullet cell (`robot_app.sim.SimCell`) or a real PA10. Everything
is in Σ_W (world, robot base at the origin) and SI units.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray


class StereoCapture(Protocol):
    """One capture of the hand stereo pair and where the right camera was at that time.

    Attributes:
        time: the exposure [s] (cell time): what the images show happened then.
        available_time: when the images reached the computer [s] (>= time: the camera's
            latency; a frame the camera lost and resent arrives a frame period later).
        dropped: the frame triggered at `time` was lost and these images came late.
        transform_right_camera_to_world: 4x4 pose of Σ_CR at the exposure [m].
    """

    @property
    def left_bgr(self) -> npt.NDArray[np.uint8]: ...

    @property
    def right_bgr(self) -> npt.NDArray[np.uint8]: ...

    @property
    def time(self) -> float: ...

    @property
    def available_time(self) -> float: ...

    @property
    def dropped(self) -> bool: ...

    @property
    def transform_right_camera_to_world(self) -> FloatArray: ...


class Cell(Protocol):
    """A robot cell the loop can drive.

    Attributes:
        dt: control period [s] (one `step`).
        time: current time [s] (simulated or real).
    """

    dt: float

    @property
    def time(self) -> float: ...

    def step(self) -> None:
        """Applies the last command for one control period `dt`."""

    def joint_positions(self) -> FloatArray:
        """Measured arm joint positions [rad]."""

    def command_joints(self, q: FloatArray, dq: FloatArray) -> None:
        """Position (and velocity feed-forward) command for the arm [rad, rad/s]."""

    def capture(self) -> StereoCapture:
        """Triggers the hand stereo pair now (exposure at `time`; the images carry their
        `available_time`, which the loop must not act before)."""

    def set_gripper(self, opening: float) -> None:
        """Commands the finger gap [m] (0 = closed)."""

    def grasp(self) -> int:
        """Closes on whatever is between the fingers; returns a hold measure (0 = nothing)."""

    def release(self) -> None:
        """Lets go of what the gripper holds."""

    def holding(self) -> bool:
        """True if the gripper is carrying the cloth off the table."""

    def collisions(self) -> int:
        """Number of contacts of the arm with the table or the box right now."""


class BeltEncoder(Protocol):
    """A conveyor's encoder and where its belt lies (Σ_W), if the cell has a belt: a cloth
    lying on it moves at the belt's velocity (`control.belt_odometry.BeltOdometry`).

    Attributes:
        std: the encoder's velocity noise, per horizontal axis [m/s].
    """

    std: float

    def velocity(self) -> FloatArray:
        """The belt's horizontal velocity (vx, vy) now [m/s], as the encoder reads it."""

    def carries(self, xy: FloatArray) -> bool:
        """True if the point (x, y) [m] lies over the belt."""


__all__ = ["BeltEncoder", "Cell", "StereoCapture"]
