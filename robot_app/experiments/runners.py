"""Backends that map `execute_trial` over trial indices: local processes or Ray tasks.

Both call `record(result)` in the parent as each trial finishes (completion order) and
show one tqdm bar with rate and ETA. Heavy objects are never sent to workers: each
worker process builds its own (one pybullet client per process) through the trial
function's per-process cache.

A worker process that dies (a crash in native code) does not stop the sweep: the
trials that were in flight are rerun one by one in a fresh process, and the one that
kills its process again is recorded as failed.
"""

from __future__ import annotations

import multiprocessing
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from typing import Any

from tqdm import tqdm

from robot_app.errors import InputError
from robot_app.experiments.trial_result import TrialFunction, TrialResult, execute_trial, trial_seed
from robot_app.interrupts import SignalInterrupt, stop_at_safe_points

Record = Callable[[TrialResult], None]


def progress_bar(total: int, initial: int, enabled: bool) -> tqdm:
    """A tqdm bar on stderr counting trials, with rate [trials/s] and ETA."""
    return tqdm(
        total=total,
        initial=initial,
        unit="trial",
        desc="trials",
        disable=not enabled,
        dynamic_ncols=True,
        smoothing=0.1,
    )


def _died(config: Any, index: int, reason: str) -> TrialResult:
    points = config.point_count
    seed = trial_seed(config.seed, index // points)
    return TrialResult(index, seed, index % points, "failed", reason, 0.0, None)


def _stop_workers(pool: ProcessPoolExecutor) -> None:
    """Ends the pool's worker processes now instead of waiting for their trials (interrupt)."""
    processes = getattr(pool, "_processes", None) or {}  # no public API before Python 3.14
    for process in list(processes.values()):
        if process.is_alive():
            process.terminate()


def _run_isolated(trial_fn: TrialFunction, config: Any, index: int) -> TrialResult:
    """Runs one trial alone in a fresh process, so a native crash is attributed to it."""
    context = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(1, mp_context=context) as pool:
        try:
            return pool.submit(execute_trial, trial_fn, config, index).result()
        except BrokenProcessPool:
            return _died(config, index, "WorkerDied: the worker process died during this trial")


def run_local(
    trial_fn: TrialFunction,
    config: Any,
    indices: Sequence[int],
    record: Record,
    *,
    workers: int,
    progress: bool,
    initial: int,
    total: int,
) -> None:
    """Runs `indices` in this process (workers=1) or a spawn-context process pool.

    Args:
        trial_fn: module-level trial function (picklable by reference).
        config: the trial config (picklable).
        indices: trial indices to run.
        record: called in this process with each finished `TrialResult`.
        workers: number of worker processes (1 = in this process).
        progress: show the progress bar.
        initial: trials already done (resumed), for the bar.
        total: trials in the sweep, for the bar.
    """
    with progress_bar(total, initial, progress) as bar:
        if workers == 1:
            # The first signal sets a flag checked between trials: raised from the handler in
            # the middle of a trial it could land where Python swallows it (a fresh clone's
            # sweep ran on to its end after SIGINT). A second signal stops at once.
            with stop_at_safe_points() as stop:
                for index in indices:
                    record(execute_trial(trial_fn, config, index))
                    bar.update()
                    if stop.signal_number is not None:
                        raise SignalInterrupt(stop.signal_number)
            return
        pending = list(reversed(indices))
        context = multiprocessing.get_context("spawn")
        while pending:
            pool = ProcessPoolExecutor(workers, mp_context=context)
            in_flight: dict[Future[TrialResult], int] = {}
            broken: list[int] = []
            try:
                while pending or in_flight:
                    while pending and len(in_flight) < 2 * workers:
                        index = pending.pop()
                        in_flight[pool.submit(execute_trial, trial_fn, config, index)] = index
                    finished, _ = wait(in_flight, return_when=FIRST_COMPLETED)
                    for future in finished:
                        index = in_flight.pop(future)
                        try:
                            record(future.result())
                            bar.update()
                        except BrokenProcessPool:
                            broken.append(index)
                    if broken:
                        broken.extend(in_flight.values())
                        in_flight.clear()
                        break
            except KeyboardInterrupt:
                _stop_workers(pool)  # their trials are not recorded: a resumed run redoes them
                raise
            finally:
                pool.shutdown(wait=True, cancel_futures=True)
            for index in sorted(broken):
                record(_run_isolated(trial_fn, config, index))
                bar.update()


def _import_ray() -> Any:
    try:
        import ray
    except ImportError as err:
        raise InputError(
            "the ray backend needs Ray: pip install 'robot_app[cluster]' (or use --backend local)"
        ) from err
    return ray


def run_ray(
    trial_fn: TrialFunction,
    config: Any,
    indices: Sequence[int],
    record: Record,
    *,
    address: str,
    progress: bool,
    initial: int,
    total: int,
    local_cpus: int | None = None,
) -> None:
    """Runs `indices` as Ray tasks (one CPU each) on the cluster at `address`.

    Args:
        trial_fn: module-level trial function, importable on the cluster's workers.
        config: the trial config.
        indices: trial indices to run.
        record: called in this process with each finished `TrialResult`.
        address: "auto" joins a running cluster (`ray start --head`), "local" starts a
            private instance on this machine, anything else is a `ray://` or `host:port`.
        progress: show the progress bar.
        initial: trials already done (resumed), for the bar.
        total: trials in the sweep, for the bar.
        local_cpus: CPUs of a private "local" instance (None = all).
    """
    ray = _import_ray()
    started_here = not ray.is_initialized()
    if started_here:
        try:
            if address == "local":
                ray.init(num_cpus=local_cpus, include_dashboard=False, log_to_driver=False)
            else:
                ray.init(address=address, log_to_driver=False)
        except (ConnectionError, RuntimeError, ValueError) as err:
            raise InputError(
                f"cannot join a Ray cluster at {address!r} ({err}); start one with `ray start --head` "
                "or pass --ray-address local for a private instance"
            ) from err
    try:
        task = ray.remote(num_cpus=1, max_retries=0)(execute_trial)
        fn_ref, config_ref = ray.put(trial_fn), ray.put(config)
        capacity = max(2, 2 * int(ray.cluster_resources().get("CPU", 1)))
        pending = list(reversed(indices))
        in_flight: dict[Any, int] = {}
        with progress_bar(total, initial, progress) as bar:
            while pending or in_flight:
                while pending and len(in_flight) < capacity:
                    index = pending.pop()
                    in_flight[task.remote(fn_ref, config_ref, index)] = index
                done, _ = ray.wait(list(in_flight), num_returns=1)
                for ref in done:
                    index = in_flight.pop(ref)
                    try:
                        result = ray.get(ref)
                    except ray.exceptions.RayError as err:
                        reason = f"RayError: {type(err).__name__}: {err}".splitlines()[0]
                        result = _died(config, index, reason)
                    record(result)
                    bar.update()
    finally:
        if started_here:
            ray.shutdown()


__all__ = ["progress_bar", "run_local", "run_ray"]
