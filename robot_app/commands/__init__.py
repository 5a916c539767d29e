"""Subcommands of `robot-app`, one module per area; each exposes `register(app)`."""

from __future__ import annotations

import typer

from robot_app.commands import calibrate, control, demo, experiments, model, sim, vision


def register_all(app: typer.Typer) -> None:
    """Adds every area's subcommands to `app`, in the order `--help` lists them."""
    for module in (demo, model, vision, calibrate, sim, control, experiments):
        module.register(app)


__all__ = ["register_all"]
