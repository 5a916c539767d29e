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
from robot_app.errors import ConfigError, InputError, InterruptError, OutputError
from robot_app.experiments.experiment_config import AnyTrialConfig, parse_trial_config
from robot_app.experiments.results_table import ResultsTable, table_columns
from robot_app.experiments.runners import run_local, run_ray
from robot_app.experiments.summary import summarize, write_summary
from robot_app.experiments.trial_result import TrialFunction, TrialResult
from robot_app.interrupts import interrupt_signal, signal_name
from robot_app.outputs import check_output_folder
from robot_app.resources import ResourceLimits, check_trial_time, check_workers

CONFIG_FILE = "config.yaml"
TABLE_FILE = "trials.csv"
SUMMARY_FILE = "summary.json"


class SweepInterruptedError(InterruptError):
    """The user interrupted a sweep (Ctrl-C or SIGTERM); its finished rows are kept for resuming."""


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


def _check_folder(config: AnyTrialConfig, out_dir: Path, resume: bool) -> None:
    """Checks, creating nothing, that `out_dir` is new, empty, or holds this config's results."""
    config_file = out_dir / CONFIG_FILE
    if not config_file.is_file():
        check_output_folder(out_dir, key="--out")  # a file, a folder of other files, unwritable
        return
    if not resume:
        raise OutputError(
            f"--out {out_dir} already holds results; resume them or choose another --out",
            path=out_dir,
            key="--out",
            value=str(out_dir),
            expected="a new or empty folder (or resume)",
        )
    try:
        previous = parse_trial_config(read_yaml(config_file), str(config_file))
    except ConfigError as err:
        first = str(err).splitlines()[0]
        raise OutputError(
            f"cannot resume {out_dir}: its {CONFIG_FILE} is not a trial config ({first})",
            path=out_dir,
            key="--out",
            value=str(out_dir),
            expected="a new or empty folder, or one holding a trial run",
        ) from err
    if previous.config_hash() != config.config_hash():
        raise OutputError(
            f"cannot resume {out_dir}: it holds results of a different config "
            f"(hash {previous.config_hash()} vs {config.config_hash()}; only 'trials' may differ); "
            "use the same config and --set values, or choose another --out",
            path=out_dir,
            key="--out",
            value=str(out_dir),
            expected=f"a new or empty folder, or one holding results of config {config.config_hash()}",
        )
    check_output_folder(out_dir, key="--out", resumable=True)


def check_sweep(
    config: AnyTrialConfig,
    outcome_type: type,
    out_dir: str | Path,
    *,
    workers: int = 1,
    backend: str = "local",
    resume: bool = True,
    limits: ResourceLimits | None = None,
    trials_key: str = "trials",
) -> list[int]:
    """Everything `run_sweep` checks before it creates or writes anything.

    Returns:
        The trial indices still to run.

    Raises:
        InputError: bad workers or backend; OutputError: the folder cannot hold this sweep;
        ResourceError: the trials or workers exceed the limits.
    """
    limits = limits or ResourceLimits()
    check_workers(limits, workers, config.source)
    if backend not in ("local", "ray"):
        raise InputError(
            f"--backend must be 'local' or 'ray', got {backend!r}", key="--backend", value=backend
        )
    folder = Path(out_dir)
    _check_folder(config, folder, resume)
    table_file = folder / TABLE_FILE
    if table_file.exists() and not table_file.is_file():
        raise OutputError(
            f"{table_file} is not a file; choose another --out",
            path=table_file,
            key="--out",
            value=str(folder),
        )
    done = ResultsTable(table_file, outcome_type, repair=False).complete_indices()
    todo = sorted(set(range(config.trials)) - done)
    check_trial_time(
        limits,
        kind=config.kind,
        source=config.source,
        to_run=len(todo),
        workers=workers,
        key=trials_key,
        value=config.trials,
    )
    return todo


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
    limits: ResourceLimits | None = None,
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
        limits: resource limits for the trial count and workers (default limits if None).

    Raises:
        InputError: bad workers or backend; OutputError: the folder is a file, holds
            other files, or holds a different config; ResourceError: over a limit
            (all checked before anything is written, see `check_sweep`).
        SweepInterruptedError: Ctrl-C or SIGTERM; the finished rows are in the CSV and
            summary.json says `"status": "interrupted"`.
    """
    table_columns(outcome_type)  # a bad outcome type fails before the folder is made
    todo = check_sweep(
        config, outcome_type, out_dir, workers=workers, backend=backend, resume=resume, limits=limits
    )
    folder = Path(out_dir)
    folder.mkdir(parents=True, exist_ok=True)
    dump_config(config, folder / CONFIG_FILE)
    table = ResultsTable(folder / TABLE_FILE, outcome_type)
    start = time.perf_counter()
    ran = 0
    interrupted: KeyboardInterrupt | None = None
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
        except KeyboardInterrupt as err:  # SIGINT or SIGTERM: keep what finished, then say so
            interrupted = err
    wall = time.perf_counter() - start
    table.sort_by_index()
    rows = table.read_rows()
    summary = summarize(config, rows, wall_time_s=wall, ran=ran, workers=workers, backend=backend)
    summary["status"] = "interrupted" if interrupted is not None else "finished"
    write_summary(summary, folder / SUMMARY_FILE)
    if interrupted is not None:
        number = interrupt_signal(interrupted)
        raise SweepInterruptedError(
            f"stopped by {signal_name(number)} after {ran} of {len(todo)} trials; the {len(rows)} finished "
            f"rows are in {table.path}; rerun the same command to resume",
            signal_number=number,
        ) from interrupted
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
    "check_sweep",
    "run_sweep",
]
