"""What a user sees on the terminal: one-line warnings, and native libraries kept quiet.

- `InputWarning`: an input that is suspicious but usable (a grayscale stereo pair, a
  rig with zero baseline, a short distortion vector, an empty config file). Code that
  reads the input calls `warn_input`; the CLI prints each as one line,
  `warning: <message>`, on stderr (`show_warnings_as_lines`).
- `native_output_silenced`: C libraries print to the process's file descriptors, past
  Python's `sys.stderr` (pybullet's "pybullet build time" banner at import, libpng's
  and OpenCV's warnings while decoding). Around such calls both descriptors point at
  /dev/null, so the first line on stderr is ours. ROBOT_APP_DEBUG=1 leaves them open.
"""

from __future__ import annotations

import contextlib
import ctypes
import importlib
import os
import sys
import warnings
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType
from typing import Any, TextIO

DEBUG_VARIABLE = "ROBOT_APP_DEBUG"


def debug_enabled() -> bool:
    """ROBOT_APP_DEBUG is set: tracebacks and third-party output are shown."""
    return bool(os.environ.get(DEBUG_VARIABLE))


class InputWarning(UserWarning):
    """An input that is usable but probably not what the user meant.

    Attributes:
        path: the file it is about, if any.
        key: the config key or option it is about, if any.
    """

    def __init__(self, message: str, *, path: str | Path | None = None, key: str | None = None) -> None:
        super().__init__(message)
        self.path = Path(path) if path is not None else None
        self.key = key


def warn_input(message: str, *, path: str | Path | None = None, key: str | None = None) -> None:
    """Issues an `InputWarning` (printed by the CLI as 'warning: <message>')."""
    warnings.warn(InputWarning(message, path=path, key=key), stacklevel=2)


def _show_warning(
    message: Warning | str,
    category: type[Warning],
    filename: str,
    lineno: int,
    file: TextIO | None = None,
    line: str | None = None,
) -> None:
    if not issubclass(category, InputWarning) and not debug_enabled():
        return  # a library's own warning: not the user's business unless debugging
    text = str(message).replace("\n", " ")
    prefix = "warning" if issubclass(category, InputWarning) else f"warning ({category.__name__})"
    print(f"{prefix}: {text}", file=file or sys.stderr, flush=True)


def show_warnings_as_lines() -> None:
    """Prints every `InputWarning` as one line on stderr (others only with ROBOT_APP_DEBUG)."""
    warnings.showwarning = _show_warning
    warnings.simplefilter("always", InputWarning)


def _flush_c_streams() -> None:
    with contextlib.suppress(OSError, AttributeError, TypeError):
        ctypes.CDLL(None).fflush(None)


@contextlib.contextmanager
def native_output_silenced() -> Iterator[None]:
    """Points file descriptors 1 and 2 at /dev/null for the block (not with ROBOT_APP_DEBUG)."""
    if debug_enabled():
        yield
        return
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    try:
        saved = [os.dup(1), os.dup(2)]
    except OSError:  # no descriptors to redirect (embedded interpreter)
        yield
        return
    null = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(null, 1)
        os.dup2(null, 2)
        yield
    finally:
        _flush_c_streams()
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for fd in (*saved, null):
            os.close(fd)


def quiet_import(name: str) -> ModuleType:
    """Imports module `name` with its import-time printing silenced (pybullet's banner)."""
    if name in sys.modules:
        return sys.modules[name]
    with native_output_silenced():
        return importlib.import_module(name)


def one_line(value: Any) -> str:
    """`str(value)` on one line (for messages built from other messages)."""
    return " ".join(str(value).split())


__all__ = [
    "DEBUG_VARIABLE",
    "InputWarning",
    "debug_enabled",
    "native_output_silenced",
    "one_line",
    "quiet_import",
    "show_warnings_as_lines",
    "warn_input",
]
