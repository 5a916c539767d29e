"""The sweep machinery: run N seeded trials, stream rows to CSV, resume, summarise.

A trial function is a pure, picklable, module-level callable
`trial_fn(config, trial_index, seed) -> outcome` where the outcome is a frozen
dataclass (its fields become CSV columns). It may raise: `execute_trial` turns any
exception into a failed `TrialResult` with its reason, and the sweep goes on. Heavy
objects (a pybullet world, cloth models) are built once per worker process by the
trial function's own cache, never shipped from the parent.

Trial i's seed derives from the config's base seed and i only, so the rows do not
depend on the backend or the number of workers.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from robot_app.config import dump_config, read_yaml
from robot_app.errors import ConfigError, InputError, InterruptError
from robot_app.experiments.experiment_config import AnyTrialConfig, parse_trial_config
from robot_app.experiments.results_table import ResultsTable, table_columns
from robot_app.experiments.runners import run_local, run_ray
from robot_app.experiments.summary import summarize, write_summary
from robot_app.experiments.trial_result import TrialFunction, TrialResult

CONFIG_FILE = "config.yaml"
TABLE_FILE = "trials.csv"
SUMMARY_FILE = "summary.json"


class SweepInterruptedError(InterruptError):
    """The user interrupted a sweep (Ctrl-C); its finished rows are kept for resuming."""


@dataclass(frozen=True)
class SweepResult:
    """What `run_sweep` did.

    Attributes:
        out_dir: the results folder.
        total: trials in the sweep.
        skipped: trials already in the CSV (resumed), not rerun.
        ran: trials run now.
        failed: failed trials in the whole table.
        wall_time_s: wall time of this run [s].
        summary: the summary written to summary.json.
    """

    out_dir: Path
    total: int
    skipped: int
    ran: int
    failed: int
    wall_time_s: float
    summary: dict[str, Any]


def _prepare_folder(config: AnyTrialConfig, out_dir: Path, resume: bool) -> None:
    """Creates the folder or checks that it holds the same config (same hash)."""
    config_file = out_dir / CONFIG_FILE
    if config_file.exists():
        if not resume:
            raise InputError(
                f"{out_dir} already holds results; resume them or choose another --out", path=out_dir
            )
        try:
            previous = parse_trial_config(read_yaml(config_file), str(config_file))
        except ConfigError as err:
            raise InputError(
                f"cannot resume {out_dir}: its {CONFIG_FILE} is invalid: {err}", path=out_dir
            ) from err
        if previous.config_hash() != config.config_hash():
            raise InputError(
                f"cannot resume {out_dir}: it holds results of a different config "
                f"(hash {previous.config_hash()} vs {config.config_hash()}; only 'trials' may differ); "
                "use the same config and --set values, or choose another --out"
            )
    out_dir.mkdir(parents=True, exist_ok=True)
    dump_config(config, config_file)


def run_sweep(
    config: AnyTrialConfig,
    trial_fn: TrialFunction,
    outcome_type: type,
    out_dir: str | Path,
    *,
    workers: int = 1,
    backend: Literal["local", "ray"] = "local",
    ray_address: str = "auto",
    resume: bool = True,
    progress: bool = True,
    on_finished: Callable[[Path], object] | None = None,
) -> SweepResult:
    """Runs `config.trials` trials, streaming rows to `out_dir/trials.csv`.

    Args:
        config: the validated trial config.
        trial_fn: module-level `trial_fn(config, scene_index, seed) -> outcome_type`.
        outcome_type: the frozen dataclass the trial function returns (CSV columns).
        out_dir: results folder; created, or resumed if it holds the same config.
        workers: worker processes for the local backend (1 = run in this process).
        backend: "local" (process pool) or "ray" (tasks on a Ray cluster).
        ray_address: `ray.init(address=...)`: "auto" joins a running cluster, "local"
            starts a private one.
        resume: continue a folder that already holds this config's results.
        progress: show a progress bar with rate and ETA on stderr.
        on_finished: called with the folder after summary.json is written (plots).

    Raises:
        InputError: the folder holds a different config, or bad workers/backend.
    """
    if workers < 1:
        raise InputError(f"workers must be >= 1, got {workers}")
    if backend not in ("local", "ray"):
        raise InputError(f"backend must be 'local' or 'ray', got {backend!r}")
    table_columns(outcome_type)  # a bad outcome type fails before the folder is made
    folder = Path(out_dir)
    _prepare_folder(config, folder, resume)
    table = ResultsTable(folder / TABLE_FILE, outcome_type)
    done = table.finished_indices()
    todo = sorted(set(range(config.trials)) - done)
    start = time.perf_counter()
    ran = 0
    with table.appender() as append:

        def record(result: TrialResult) -> None:
            nonlocal ran
            append(result, config.sweep_label(result.point))
            ran += 1

        run_args = (trial_fn, config, todo, record)
        initial = config.trials - len(todo)
        try:
            if backend == "ray":
                run_ray(
                    *run_args,
                    address=ray_address,
                    local_cpus=workers,
                    progress=progress,
                    initial=initial,
                    total=config.trials,
                )
            else:
                run_local(*run_args, workers=workers, progress=progress, initial=initial, total=config.trials)
        except KeyboardInterrupt as err:
            raise SweepInterruptedError(
                f"interrupted after {ran} of {len(todo)} trials; finished rows are in {table.path}; "
                "rerun the same command to resume"
            ) from err
    wall = time.perf_counter() - start
    table.sort_by_index()
    rows = table.read_rows()
    summary = summarize(config, rows, wall_time_s=wall, ran=ran, workers=workers, backend=backend)
    write_summary(summary, folder / SUMMARY_FILE)
    if on_finished is not None:
        on_finished(folder)
    failed = sum(1 for row in rows if row["status"] != "ok")
    return SweepResult(folder, config.trials, config.trials - len(todo), ran, failed, wall, summary)


__all__ = [
    "CONFIG_FILE",
    "SUMMARY_FILE",
    "TABLE_FILE",
    "SweepInterruptedError",
    "SweepResult",
    "run_sweep",
]
