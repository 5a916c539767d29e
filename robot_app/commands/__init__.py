"""Subcommands of `robot-app`, one module per area; each exposes `register(app)`."""

from __future__ import annotations

import typer

from robot_app.commands import calibrate, control, demo, experiments, model, sim, vision
from robot_app.interrupts import interruptible


def _make_interruptible(app: typer.Typer) -> None:
    """Wraps every command of `app` and its groups (see `interruptible`)."""
    for command in app.registered_commands:
        if command.callback is not None:
            command.callback = interruptible(command.callback)
    for group in app.registered_groups:
        if isinstance(group.typer_instance, typer.Typer):
            _make_interruptible(group.typer_instance)


def register_all(app: typer.Typer) -> None:
    """Adds every area's subcommands to `app`, in the order `--help` lists them.

    Every command is wrapped so that Ctrl-C or SIGTERM in its body exits with 128 +
    the signal (130, 143) and a one-line message.
    """
    for module in (demo, model, vision, calibrate, sim, control, experiments):
        module.register(app)
    _make_interruptible(app)


__all__ = ["register_all"]
