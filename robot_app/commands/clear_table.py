"""`robot-app clear-table`: several cloths identified, picked one by one, each into its box."""

from __future__ import annotations

import time
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from robot_app.commands._guards import check_world_cameras
from robot_app.commands._options import (
    ForceOption,
    MaxMemoryOption,
    RecordOption,
    SeedOption,
    SettingsOption,
    VideoOption,
    resource_limits,
)
from robot_app.config import load_config
from robot_app.errors import InterruptError
from robot_app.interrupts import stop_at_safe_points
from robot_app.outputs import check_output_file, check_output_folder, unique_folder

if TYPE_CHECKING:
    from robot_app.control.clear_table_records import SurveyRecord
    from robot_app.control.episode import PhaseRecord

DEFAULT_CONFIG = Path(__file__).resolve().parents[2] / "configs" / "clear_table.yaml"


def _print_phase(record: PhaseRecord, meant: str) -> None:
    note = f"  {record.note}" if record.note else ""
    typer.echo(
        f"  {meant:<6} {record.phase:<9} t={record.end_time:6.2f} s ({record.duration:5.2f} s sim){note}"
    )


def _print_survey(record: SurveyRecord) -> None:
    seen = (
        ", ".join(f"{name} ({confidence:.2f})" for name, confidence, *_ in record.detections)
        or "no known cloth"
    )
    unknown = f"; {len(record.unknown)} unknown region(s)" if record.unknown else ""
    chosen = f" -> {record.chosen}" if record.chosen else ""
    typer.echo(f"survey t={record.time:6.2f} s ({record.wall_s:.1f} s wall): {seen}{unknown}{chosen}")


def clear_table(
    config: Annotated[
        Path | None, typer.Option("--config", help="Clear-table YAML (default: configs/clear_table.yaml).")
    ] = None,
    overrides: SettingsOption = None,
    seed: SeedOption = None,
    out: Annotated[
        Path | None, typer.Option("--out", help="Results folder (default: results/clear_table-<time>).")
    ] = None,
    video: VideoOption = None,
    record: RecordOption = None,
    force: ForceOption = False,
    max_memory_gb: MaxMemoryOption = None,
) -> None:
    """Clear the table in simulation: identify the cloths, pick them one by one, sort them into boxes.

    Exit 0 when every cloth the robot knows lies in its box, 1 otherwise (the cause is in
    summary.json), 2 on bad input, 130 (143) when stopped by Ctrl-C (SIGTERM): the
    results folder is written with status 'interrupted'.
    """
    from robot_app.experiments.clear_table import ClearTableConfig, run_clear_table
    from robot_app.experiments.clear_table_results import write_clear_table
    from robot_app.experiments.recording import require_rerun

    path = config if config is not None else (DEFAULT_CONFIG if DEFAULT_CONFIG.is_file() else None)
    settings = load_config(
        ClearTableConfig, path, [*(overrides or []), *([f"seed={seed}"] if seed is not None else [])]
    )
    if video is not None:
        check_output_file(video, key="--video", suffixes=(".mp4",))
    if record is not None:
        require_rerun("--record")
        check_output_file(record, key="--record", suffixes=(".rrd",))
    folder = (
        out
        if out is not None
        else unique_folder(Path("results") / time.strftime("clear_table-%Y%m%d-%H%M%S"))
    )
    check_output_folder(folder, key="--out", force=force)
    check_world_cameras(settings.world, resource_limits(max_memory_gb, False))
    boxes = ", ".join(b.name for b in settings.world.all_boxes)
    typer.echo(
        f"clear-table: seed {settings.seed}, {len(settings.known_numbers)} known cloths, boxes {boxes}; "
        f"{settings.world.cameras.image_size[0]}x{settings.world.cameras.image_size[1]} cameras"
    )
    with stop_at_safe_points() as stop:
        episode = run_clear_table(
            settings,
            on_phase=_print_phase,
            on_survey=_print_survey,
            video_path=video,
            record_path=record,
            stop=stop.check,
        )
    write_clear_table(folder, settings, episode)
    r, v = episode.result, episode.verdict
    if r.interrupted:
        raise InterruptError(
            f"stopped {r.sim_time:.2f} s into the job; results (status 'interrupted') in {folder}",
            signal_number=stop.signal_number or 2,
        )
    placed = sum(1 for c in v.cloths if c.known and c.correct)
    known = sum(1 for c in v.cloths if c.known)
    typer.echo(
        f"{'CLEARED' if v.cleared else 'NOT CLEARED'}: {placed}/{known} known cloths in their boxes"
        + (f", {v.unknown_cloths} unknown left" if v.unknown_cloths else "")
        + f"; {len(r.attempts)} picks, {r.sim_time:.1f} s simulated, {r.wall_s:.1f} s wall; "
        f"limit violations {r.limit_report.violations}; collisions {r.collisions}"
        + (f"\ncause: {v.cause}" if v.cause else "")
    )
    typer.echo(
        f"results: {folder}"
        + (f", video: {video}" if video is not None else "")
        + (f", recording: {record}" if record is not None else "")
    )
    if not v.cleared:
        raise typer.Exit(1)


def register(app: typer.Typer) -> None:
    """Adds `clear-table` to the CLI."""
    app.command("clear-table")(clear_table)


__all__ = ["clear_table", "register"]
