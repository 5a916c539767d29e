"""Trial kinds: which trial function and outcome a config's `kind` runs, and `run_trials`."""

from __future__ import annotations

from functools import partial
from pathlib import Path
from typing import Literal

from robot_app.experiments.experiment_config import (
    AnyTrialConfig,
    PickPlaceTrialConfig,
    RecognitionTrialConfig,
)
from robot_app.experiments.trial_result import TrialFunction
from robot_app.experiments.trials import SweepResult, run_sweep
from robot_app.resources import ResourceLimits


def trial_kind(config: AnyTrialConfig) -> tuple[TrialFunction, type]:
    """The trial function and outcome dataclass of `config.kind`, checked up front.

    Raises:
        ConfigError: `recognition` overrides the recogniser does not accept, or a
            pick_place config the episode runner rejects.
    """
    if isinstance(config, RecognitionTrialConfig):
        from robot_app.experiments.recognition_trial import (
            RecognitionOutcome,
            check_recognition_config,
            run_recognition_trial,
        )

        for point in range(config.point_count):
            check_recognition_config(config.at_point(point))  # type: ignore[arg-type]
        return run_recognition_trial, RecognitionOutcome
    from robot_app.experiments.pick_place_trial import (
        PickPlaceOutcome,
        check_pick_place_config,
        run_pick_place_trial,
    )

    check_pick_place_config(config)
    return run_pick_place_trial, PickPlaceOutcome


def run_trials(
    config: AnyTrialConfig,
    out_dir: str | Path,
    *,
    workers: int = 1,
    backend: Literal["local", "ray"] = "local",
    ray_address: str = "auto",
    progress: bool = True,
    plots: bool = True,
    limits: ResourceLimits | None = None,
) -> SweepResult:
    """Runs (or resumes) the trials of `config` into `out_dir`, with its plots.

    Args:
        config: a recognition or pick_place trial config.
        out_dir: results folder (config.yaml, trials.csv, summary.json, PNGs).
        workers: local worker processes (or CPUs of a private local Ray).
        backend: "local" or "ray".
        ray_address: Ray cluster address ("auto", "local", "host:port").
        progress: show a progress bar.
        plots: write errors.png (and sweep.png for a sweep).
        limits: resource limits for the trial count and workers (default limits if None).
    """
    trial_fn, outcome_type = trial_kind(config)
    if isinstance(config, PickPlaceTrialConfig):
        from robot_app.experiments.pick_place_trial import recordings_folder, run_pick_place_trial

        recordings = recordings_folder(config, out_dir)
        if recordings is not None:  # a module-level function with a path: still picklable
            trial_fn = partial(run_pick_place_trial, recordings=recordings)
    on_finished = None
    if plots:
        from robot_app.experiments.report import plot_trial_folder

        on_finished = plot_trial_folder
    return run_sweep(
        config,
        trial_fn,
        outcome_type,
        out_dir,
        workers=workers,
        backend=backend,
        ray_address=ray_address,
        progress=progress,
        on_finished=on_finished,
        limits=limits,
    )


__all__ = ["run_trials", "trial_kind"]
