"""One trial: its seed, its execution with crash capture, and its typed result."""

from __future__ import annotations

import dataclasses
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np

TrialFunction = Callable[[Any, int, int], Any]
"""`trial_fn(config_at_point, scene_index, seed) -> outcome dataclass`; module-level."""


@dataclass(frozen=True)
class TrialResult:
    """One finished trial, ok or failed.

    Attributes:
        index: trial index in the sweep.
        seed: the trial's seed (from the base seed and the scene index).
        point: sweep point index (0 without a sweep).
        status: "ok", or "failed" if the trial function raised.
        reason: the exception's type, message and place for a failed trial, else "".
        duration_s: wall time of the trial in its worker [s].
        outcome: the trial function's dataclass, None for a failed trial.
    """

    index: int
    seed: int
    point: int
    status: Literal["ok", "failed"]
    reason: str
    duration_s: float
    outcome: Any | None


def trial_seed(base_seed: int, scene_index: int) -> int:
    """Seed of a scene: from (base_seed, scene_index) only, independent across scenes.

    Args:
        base_seed: the config's `seed` (>= 0).
        scene_index: the trial's scene index (>= 0).

    Returns:
        A 63-bit non-negative integer.
    """
    if scene_index < 0 or base_seed < 0:
        raise ValueError(f"seed and scene index must be >= 0, got {base_seed}, {scene_index}")
    state = np.random.SeedSequence(entropy=base_seed, spawn_key=(scene_index,)).generate_state(2, np.uint32)
    return (int(state[0]) << 31) | (int(state[1]) >> 1)


def execute_trial(trial_fn: TrialFunction, config: Any, index: int) -> TrialResult:
    """Runs trial `index` at its sweep point and seed; an exception becomes a failed row.

    Trial i runs sweep point i % P on scene i // P (P sweep points); the seed is that
    of the scene, so every sweep value sees the same scenes.

    Args:
        trial_fn: the trial function.
        config: a trial config (with `point_count`, `at_point`, `seed`).
        index: the trial index (>= 0).
    """
    points = config.point_count
    point, scene = index % points, index // points
    seed = trial_seed(config.seed, scene)
    start = time.perf_counter()
    try:
        outcome = trial_fn(config.at_point(point), scene, seed)
    except Exception as err:
        frames = traceback.extract_tb(err.__traceback__) if err.__traceback__ else []
        where = f" at {Path(frames[-1].filename).name}:{frames[-1].lineno}" if frames else ""
        reason = f"{type(err).__name__}: {err}{where}".replace("\n", " ").replace("\r", " ")
        return TrialResult(index, seed, point, "failed", reason, time.perf_counter() - start, None)
    if not dataclasses.is_dataclass(outcome) or isinstance(outcome, type):
        reason = f"TypeError: trial function returned {type(outcome).__name__}, not a dataclass"
        return TrialResult(index, seed, point, "failed", reason, time.perf_counter() - start, None)
    return TrialResult(index, seed, point, "ok", "", time.perf_counter() - start, outcome)


__all__ = ["TrialFunction", "TrialResult", "execute_trial", "trial_seed"]
