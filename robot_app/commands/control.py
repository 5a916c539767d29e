"""`robot-app pick-place`: the main job, one closed-loop pick-and-place episode."""

from __future__ import annotations

import time
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from robot_app.commands._guards import check_display, check_world_cameras
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
    from robot_app.control.episode import PhaseRecord

DEFAULT_CONFIG = Path(__file__).resolve().parents[2] / "configs" / "pick_place.yaml"


def _print_phase(record: PhaseRecord) -> None:
    note = f"  {record.note}" if record.note else ""
    typer.echo(
        f"  {record.phase:<9} t={record.end_time:6.2f} s  "
        f"({record.duration:5.2f} s sim, {record.wall_s:5.1f} s wall){note}"
    )


def pick_place(
    config: Annotated[
        Path | None, typer.Option("--config", help="Pick-and-place YAML (default: configs/pick_place.yaml).")
    ] = None,
    overrides: SettingsOption = None,
    seed: SeedOption = None,
    out: Annotated[
        Path | None, typer.Option("--out", help="Results folder (default: results/pick_place-<time>).")
    ] = None,
    video: VideoOption = None,
    record: RecordOption = None,
    gui: Annotated[bool, typer.Option("--gui", help="Show pybullet's GUI (needs a display).")] = False,
    force: ForceOption = False,
    max_memory_gb: MaxMemoryOption = None,
) -> None:
    """Run one pick-and-place episode in simulation: find the cloth, grasp it, put it in the box.

    With `--set scene.conveyor_speed=0.05` the cloth comes on a belt; a belt no robot could
    keep up with is refused before the start (outcome 'unreachable', exit code 2).

    Ctrl-C (or SIGTERM) stops it after the current control step: the results folder is
    written with outcome 'interrupted' and the phases so far, the video is closed
    playable, the recording holds the episode up to the stop, and the exit code is 130 (143).
    """
    # here, not at the top: every `robot-app` command imports this module (pybullet, Pinocchio)
    from robot_app.control.episode import Outcome
    from robot_app.experiments.pick_place_episode import PickPlaceConfig, run_episode, write_episode
    from robot_app.experiments.recording import require_rerun

    path = config if config is not None else (DEFAULT_CONFIG if DEFAULT_CONFIG.is_file() else None)
    settings = load_config(
        PickPlaceConfig, path, [*(overrides or []), *([f"seed={seed}"] if seed is not None else [])]
    )
    # every output and resource checked before the cell is built: a bad path never costs an episode
    if video is not None:
        check_output_file(video, key="--video", suffixes=(".mp4",))
    if record is not None:
        require_rerun("--record")  # the optional extra: one line saying how to install it
        check_output_file(record, key="--record", suffixes=(".rrd",))
    folder = (
        out if out is not None else unique_folder(Path("results") / time.strftime("pick_place-%Y%m%d-%H%M%S"))
    )
    check_output_folder(folder, key="--out", force=force)
    check_world_cameras(settings.world, resource_limits(max_memory_gb, False))
    check_display(gui)
    wanted = settings.wanted
    scene = settings.scene
    extras = [
        f"occluder {scene.occluded_fraction:.0%}" if scene.occluder else "",
        f"distractor No.{scene.distractor}" if scene.distractor else "",
    ]
    with stop_at_safe_points() as stop:  # from here, Ctrl-C or SIGTERM stops after the current step
        typer.echo(
            f"pick-place: cloth No.{wanted}, scene seed {settings.seed}"
            + "".join(f", {e}" for e in extras if e)
            + f"; {settings.world.cameras.image_size[0]}x{settings.world.cameras.image_size[1]} cameras"
        )
        episode = run_episode(
            settings, gui=gui, on_phase=_print_phase, video_path=video, stop=stop.check, record_path=record
        )
    write_episode(folder, settings, episode)
    r = episode.result
    if r.outcome is Outcome.INTERRUPTED:
        shown = f"; video (up to the stop): {video}" if video is not None and video.exists() else ""
        shown += f"; recording (up to the stop): {record}" if record is not None and record.exists() else ""
        raise InterruptError(
            f"{r.reason}, {r.sim_time:.2f} s into the episode; results (outcome 'interrupted', "
            f"{len(r.phases)} phases) in {folder}{shown}",
            signal_number=stop.signal_number or 2,
        )
    if r.outcome is Outcome.UNREACHABLE:  # refused before the start: the settings ask the impossible
        typer.echo(f"REFUSED: unreachable ({r.reason}); results: {folder}", err=True)
        raise typer.Exit(2)
    verdict = "SUCCESS" if r.success else "FAILED"
    placed = f"{r.placed_fraction:.0%} of the cloth in the box" if r.placed_fraction is not None else ""
    typer.echo(
        f"{verdict}: {r.outcome.value} ({r.reason}); {placed}; "
        f"{r.sim_time:.1f} s simulated, {r.wall_s:.1f} s wall; "
        f"limit violations {r.limit_report.violations} in {r.commanded_samples} commanded samples; "
        f"collisions {r.collisions}"
    )
    typer.echo(
        f"results: {folder}"
        + (f", video: {video}" if video is not None else "")
        + (f", recording: {record} (open it with: rerun {record})" if record is not None else "")
    )
    if not r.success:
        raise typer.Exit(1)


def register(app: typer.Typer) -> None:
    """Adds `pick-place` to the CLI."""
    app.command("pick-place")(pick_place)


__all__ = ["pick_place", "register"]
