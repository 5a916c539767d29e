"""Subcommands of `robot-app`, one module per area; each exposes `register(app)`."""

from __future__ import annotations

import importlib

import typer

# Modules are registered in this order; a module that does not exist yet is skipped so
# that areas can land independently.
_MODULES = ("demo", "model", "vision", "sim", "control", "experiments")


def register_all(app: typer.Typer) -> None:
    """Adds every area's subcommands to `app`."""
    for name in _MODULES:
        try:
            module = importlib.import_module(f"robot_app.commands.{name}")
        except ModuleNotFoundError as err:
            if err.name == f"robot_app.commands.{name}":
                continue
            raise
        module.register(app)


__all__ = ["register_all"]
