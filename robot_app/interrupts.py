"""Ctrl-C and SIGTERM: stop at once, or at the next safe point, and say which signal it was.

Two ways a command can be stopped:

- at once (`signals_raise_interrupts`, around every command): SIGINT and SIGTERM both raise
  `SignalInterrupt`, a `KeyboardInterrupt` that remembers its signal, wherever the
  program is. Files are written atomically (`robot_app.outputs`), so this never leaves
  a half file; a command that streams results (a trial sweep) catches it, keeps what
  was finished and raises `InterruptError`.
- at a safe point (`stop_at_safe_points`, long loops such as the pick-and-place
  episode): the first signal only sets a flag, which the loop checks between two control
  steps (`StopRequest.check` raises `InterruptError`); the loop then ends its episode
  cleanly, and the command writes what it has. A second signal stops at once.

The exit code of an interrupted command is 128 + the signal number: 130 for SIGINT
(Ctrl-C), 143 for SIGTERM.
"""

from __future__ import annotations

import functools
import os
import signal
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from types import FrameType
from typing import Any, TypeVar

from robot_app.errors import InterruptError

F = TypeVar("F", bound=Callable[..., Any])

HANDLED_SIGNALS = (signal.SIGINT, signal.SIGTERM)
"""The signals a command handles (Ctrl-C, and what `kill` and service managers send)."""


class SignalInterrupt(KeyboardInterrupt):
    """A `KeyboardInterrupt` raised for SIGINT or SIGTERM, carrying which one.

    Attributes:
        signal_number: 2 (SIGINT) or 15 (SIGTERM).
    """

    def __init__(self, signal_number: int) -> None:
        super().__init__(signal_name(signal_number))
        self.signal_number = signal_number


def signal_name(signal_number: int) -> str:
    """'SIGINT', 'SIGTERM', ... for a signal number."""
    try:
        return signal.Signals(signal_number).name
    except ValueError:
        return f"signal {signal_number}"


def interrupt_signal(err: BaseException) -> int:
    """The signal behind an interrupt: its own for `SignalInterrupt`/`InterruptError`, else SIGINT."""
    return int(getattr(err, "signal_number", signal.SIGINT))


def _raise_interrupt(signal_number: int, _frame: FrameType | None) -> None:
    raise SignalInterrupt(signal_number)


def _in_main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


@contextmanager
def signals_raise_interrupts() -> Iterator[None]:
    """Inside the block, SIGINT and SIGTERM raise `SignalInterrupt` (main thread only).

    The previous handlers are restored on leaving (the CLI's `main` runs inside it, so
    calling `main` from Python leaves the caller's handlers as they were).
    """
    if not _in_main_thread():
        yield
        return
    previous = {number: signal.getsignal(number) for number in HANDLED_SIGNALS}
    for number in HANDLED_SIGNALS:
        signal.signal(number, _raise_interrupt)
    try:
        yield
    finally:
        _restore(previous)


def _restore(previous: dict[signal.Signals, Any]) -> None:
    for number, old in previous.items():
        if old is not None:  # None: a handler not set from Python; nothing to restore
            signal.signal(number, old)


class StopRequest:
    """The flag a loop checks at its safe points; set by the first SIGINT or SIGTERM.

    Attributes:
        signal_number: the signal received, None while none was.
    """

    def __init__(self) -> None:
        self.signal_number: int | None = None

    @property
    def requested(self) -> bool:
        """A signal arrived: the loop should stop at its next safe point."""
        return self.signal_number is not None

    def request(self, signal_number: int) -> None:
        """Marks a stop as requested (what the signal handler does; tests call it too)."""
        if self.signal_number is None:
            self.signal_number = signal_number

    def check(self) -> None:
        """Raises `InterruptError` (with the signal) if a stop was requested."""
        if self.signal_number is not None:
            raise InterruptError(
                f"stopped by {signal_name(self.signal_number)}", signal_number=self.signal_number
            )


@contextmanager
def stop_at_safe_points() -> Iterator[StopRequest]:
    """Inside the block, the first SIGINT/SIGTERM sets the yielded `StopRequest`.

    A second signal raises `SignalInterrupt` at once. The previous handlers are restored
    on leaving. Outside the main thread (where Python cannot handle signals) the flag is
    yielded but never set.
    """
    stop = StopRequest()
    if not _in_main_thread():
        yield stop
        return

    def handler(signal_number: int, frame: FrameType | None) -> None:
        if stop.requested:
            _raise_interrupt(signal_number, frame)
        stop.request(signal_number)
        # os.write, not print: a handler may run in the middle of another write to stderr
        note = f"{signal_name(signal_number)}: stopping at the next safe point (again to stop at once)\n"
        os.write(2, note.encode())

    previous = {number: signal.getsignal(number) for number in HANDLED_SIGNALS}
    for number in HANDLED_SIGNALS:
        signal.signal(number, handler)
    try:
        yield stop
    finally:
        _restore(previous)


def interruptible(command: F) -> F:
    """Wraps a command so an interrupt in its body becomes `InterruptError` (exit 128 + signal).

    Without it, typer turns every `KeyboardInterrupt` into exit code 130 and SIGTERM's
    143 is lost. Commands that keep partial results raise `InterruptError` themselves.
    """

    @functools.wraps(command)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return command(*args, **kwargs)
        except KeyboardInterrupt as err:
            number = interrupt_signal(err)
            raise InterruptError(
                f"stopped by {signal_name(number)}; files are written whole or not at all, "
                "so nothing half-written was left",
                signal_number=number,
            ) from err

    return wrapper  # type: ignore[return-value]


__all__ = [
    "HANDLED_SIGNALS",
    "SignalInterrupt",
    "StopRequest",
    "interrupt_signal",
    "interruptible",
    "signal_name",
    "signals_raise_interrupts",
    "stop_at_safe_points",
]
