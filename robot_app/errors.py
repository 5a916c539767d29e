"""The one exception hierarchy of robot_app.

Every error that a user can cause (bad input, bad config, an unreachable target) is a
`RobotAppError`; the CLI turns it into a one-line message and exit code 2 (bad input)
or 1 (a run that failed). Programming mistakes (calling a method out of order, an array
of the wrong shape from our own code) raise the standard `ValueError`, `TypeError` or
`RuntimeError` instead: they are bugs, not input.

User-facing errors carry what was wrong as attributes, so callers and tests read the
data, not the wording: `path` (the file), `key` (the config key or command-line option),
`value` (what was given) and `expected` (what would be valid).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

_UNSET: Any = object()


class RobotAppError(Exception):
    """Root of all robot_app errors. `exit_code` is what the CLI returns for it.

    Args:
        message: one line saying what was wrong and what would be valid.
        path: the file or folder the error is about.
        key: the config key (dotted) or command-line option the error is about.
        value: the value that was given (absent: `has_value` is False).
        expected: what would have been valid, in words.
    """

    exit_code: int = 1

    def __init__(
        self,
        message: str,
        *,
        path: str | Path | None = None,
        key: str | None = None,
        value: Any = _UNSET,
        expected: str | None = None,
    ) -> None:
        super().__init__(message)
        self.message = message
        self.path = Path(path) if path is not None else None
        self.key = key
        self.has_value = value is not _UNSET
        self.value = None if value is _UNSET else value
        self.expected = expected


class InputError(RobotAppError):
    """A file or argument given by the user is missing, unreadable or malformed."""

    exit_code = 2


class OutputError(InputError):
    """An output path cannot be written (read-only, wrong kind, an existing results folder)."""


class ResourceError(InputError):
    """An input would need more memory or time than the configured limit allows."""


@dataclass(frozen=True)
class ConfigProblem:
    """One bad key of a config: its dotted `key`, what was wrong, and the value given."""

    key: str
    problem: str
    value: Any = None


class ConfigError(InputError):
    """A config value is unknown, of the wrong type or out of range.

    `problems` lists every bad key (a config can have several); `key` and `value` are
    those of the first.
    """

    def __init__(
        self,
        message: str,
        *,
        problems: tuple[ConfigProblem, ...] = (),
        path: str | Path | None = None,
        key: str | None = None,
        value: Any = _UNSET,
        expected: str | None = None,
    ) -> None:
        if problems and key is None:
            key, value = problems[0].key, problems[0].value
        super().__init__(message, path=path, key=key, value=value, expected=expected)
        self.problems = problems or ((ConfigProblem(key, message, self.value),) if key else ())


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


class InterruptError(RobotAppError):
    """The user stopped a command (Ctrl-C or SIGTERM); what was finished is on disk.

    Attributes:
        signal_number: the signal that stopped it (2 SIGINT, 15 SIGTERM).
    """

    def __init__(self, message: str, *, signal_number: int = 2) -> None:
        super().__init__(message)
        self.signal_number = signal_number
        self.exit_code = 128 + signal_number


__all__ = [
    "CalibrationError",
    "ConfigError",
    "ConfigProblem",
    "GraspError",
    "IKError",
    "InputError",
    "InterruptError",
    "ModelError",
    "OutputError",
    "ResourceError",
    "RobotAppError",
    "SimulationError",
    "TrajectoryError",
]
