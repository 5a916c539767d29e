"""The one exception hierarchy of robot_app.

Every error that a user can cause (bad input, bad config, an unreachable target) is a
`RobotAppError`; the CLI turns it into a one-line message and exit code 2 (bad input)
or 1 (a run that failed).
"""

from __future__ import annotations


class RobotAppError(Exception):
    """Root of all robot_app errors. `exit_code` is what the CLI returns for it."""

    exit_code: int = 1


class InputError(RobotAppError):
    """A file or argument given by the user is missing, unreadable or malformed."""

    exit_code = 2


class ConfigError(InputError):
    """A config value is unknown, of the wrong type or out of range."""


class CalibrationError(InputError):
    """A camera or stereo-rig file is inconsistent (sizes, non-rotation R, ...)."""


class ModelError(InputError):
    """A cloth model cannot be made or loaded (no cloth in the photo, wrong format)."""


class IKError(RobotAppError):
    """Inverse kinematics failed where a solution was required."""


class TrajectoryError(RobotAppError):
    """Ruckig rejected a trajectory request; carries ruckig's result code."""


class GraspError(RobotAppError):
    """A grasp or release could not be carried out."""


class SimulationError(RobotAppError):
    """The simulator could not build or step a scene."""


__all__ = [
    "CalibrationError",
    "ConfigError",
    "GraspError",
    "IKError",
    "InputError",
    "ModelError",
    "RobotAppError",
    "SimulationError",
    "TrajectoryError",
]
