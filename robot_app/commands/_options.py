"""Command-line options several commands share: seeds, --set, --video, --record, --force and the
resource limits."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from robot_app.resources import ResourceLimits


def check_seed(value: int | None) -> int | None:
    """A seed is an integer >= 0 (numpy's generators take no negative seeds)."""
    if value is not None and value < 0:
        raise typer.BadParameter(f"{value} is negative; a seed is an integer >= 0")
    return value


def check_memory_gb(value: float | None) -> float | None:
    """A memory limit is a positive number of GB."""
    if value is not None and not value > 0:
        raise typer.BadParameter(f"{value} is not a positive number of GB")
    return value


SeedOption = Annotated[
    int | None,
    typer.Option("--seed", callback=check_seed, help="Seed (an integer >= 0; default: the settings')."),
]
SettingsOption = Annotated[list[str] | None, typer.Option("--set", help="Setting key=value (repeatable).")]
VideoOption = Annotated[Path | None, typer.Option("--video", help="Write an MP4 of the run.")]
RecordOption = Annotated[
    Path | None,
    typer.Option(
        "--record",
        help="Write a Rerun recording (.rrd) of the run; open it with `rerun FILE.rrd` "
        "(needs the viewer extra: pip install 'robot_app\\[viewer]').",
    ),
]
ForceOption = Annotated[
    bool, typer.Option("--force", help="Write into an --out folder that already holds files.")
]
MaxMemoryOption = Annotated[
    float | None,
    typer.Option(
        "--max-memory-gb",
        callback=check_memory_gb,
        help="Memory the inputs may need, in GB [default: 8 or half the machine's memory].",
    ),
]
AllowLargeOption = Annotated[
    bool,
    typer.Option(
        "--allow-large", help="Run inputs that would take very long (huge grids, models, trial counts)."
    ),
]


def resource_limits(max_memory_gb: float | None, allow_large: bool) -> ResourceLimits:
    """The limits from `--max-memory-gb` and `--allow-large`."""
    return ResourceLimits(max_memory_gb=max_memory_gb, allow_large=allow_large)


__all__ = [
    "AllowLargeOption",
    "ForceOption",
    "MaxMemoryOption",
    "SeedOption",
    "check_memory_gb",
    "check_seed",
    "resource_limits",
]
