"""Resource guards: inputs that scale memory or time are checked before anything is allocated.

A command estimates what an input will cost (bytes of memory, or a count that sets the
run time: poses to evaluate, model points, trials) and compares it with a limit
*before* it allocates. Over the limit is a `ResourceError` (exit 2) that names the
input, its value, the estimate, the limit and the flag that raises it:

- memory: `--max-memory-gb` (default: the smaller of 8 GB and half the machine's memory);
- counts that only cost time: `--allow-large` lifts them (memory limits still apply).

The estimates are upper bounds of the big arrays (bytes per grid cell, per pixel, per
point, per worker, measured on this code); they are not exact, only the right size.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Any

from robot_app.errors import InputError, ResourceError

GB = 1024**3
MAX_DEFAULT_MEMORY_GB = 8.0
"""The default memory limit is this, or half the machine's memory if that is less [GB]."""

# --- limits that only cost time (lifted by --allow-large) ---------------------------------
MAX_FULL_SEARCH_EVALUATIONS = 50_000_000
"""Poses of one full search (~2 min at ~400k poses/s with a 750-point model)."""
MAX_MODEL_POINTS = 50_000
"""S_in + S_out points of a cloth model (a 15 x 12 cm cloth at 0.4 m has ~750; each
fitness evaluation is linear in them)."""
MAX_TRIAL_HOURS = 24.0
"""Estimated wall time of one `robot-app trial` run (finished trials not counted) [h]."""
SECONDS_PER_TRIAL = {
    ("recognition", "synthetic"): 0.2,
    ("recognition", "sim"): 1.0,
    ("pick_place", "synthetic"): 5.0,
    ("pick_place", "sim"): 5.0,
}
"""Lower estimates of one trial's time on one core [s] (measured, warm caches)."""
WORKERS_PER_CPU = 4
"""More worker processes than this many per CPU only add memory and contention."""

# --- bytes per unit, for the memory estimates ------------------------------------------------
BYTES_PER_GRID_CELL = 160
"""Full search: grids, translations, best fitness and yaw, peaks, the plots (per x-y cell)."""
BYTES_PER_IMAGE_PIXEL = 64
"""An image being recognised: BGR, HSV, colour codes and the fitness tables (per pixel)."""
BYTES_PER_RENDERED_PIXEL = 48
"""A simulated camera: RGBA, depth and segmentation buffers and the BGR copy (per pixel)."""
BYTES_PER_PHOTO_PIXEL = 96
"""Model making: HSV, colour codes, the metric grid, masks and distance maps (per pixel)."""
BYTES_PER_MODEL_GRID_POINT = 112
"""Model making: the sampling grid through the photo plane (per grid point)."""
BYTES_PER_INDIVIDUAL = 400
"""GA: genes, poses and fitness of one individual, with the islands' copies."""
WORKER_BYTES = {"synthetic": 0.45 * GB, "sim": 0.7 * GB}
"""One trial worker process (imports, compiled kernels, models, a pybullet client)."""


def machine_memory_bytes() -> float | None:
    """Physical memory of this machine [bytes], None where it cannot be read."""
    try:
        return float(os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (AttributeError, ValueError, OSError):
        return None


def default_memory_gb() -> float:
    """The default memory limit: 8 GB, or half the machine's memory if that is less [GB]."""
    total = machine_memory_bytes()
    return MAX_DEFAULT_MEMORY_GB if total is None else min(MAX_DEFAULT_MEMORY_GB, total / 2 / GB)


def format_bytes(value: float) -> str:
    """'1.2 GB', '350 MB' (binary units)."""
    if value >= 1e6 * GB:
        return f"{value / GB:.1e} GB"
    if value >= GB:
        return f"{value / GB:.1f} GB"
    return f"{value / 1024**2:.0f} MB"


def format_count(value: float) -> str:
    """'1,234,567' for counts below 1e12, else '1.2e+15'."""
    return f"{value:,.0f}" if value < 1e12 else f"{value:.1e}"


@dataclass(frozen=True)
class ResourceLimits:
    """How much one command may use.

    Attributes:
        max_memory_gb: memory for the big arrays [GB] (`--max-memory-gb`); None: the default.
        allow_large: lift the limits that only cost time (`--allow-large`).
    """

    max_memory_gb: float | None = None
    allow_large: bool = False

    def __post_init__(self) -> None:
        if self.max_memory_gb is not None and not 0.0 < self.max_memory_gb < 1e6:
            raise InputError(
                f"--max-memory-gb must be a positive number of GB, got {self.max_memory_gb}",
                key="--max-memory-gb",
                value=self.max_memory_gb,
                expected="a number of GB > 0",
            )

    @property
    def memory_bytes(self) -> float:
        """The memory limit [bytes]."""
        return (self.max_memory_gb if self.max_memory_gb is not None else default_memory_gb()) * GB

    def check_memory(self, estimate_bytes: float, *, key: str, value: Any, what: str) -> None:
        """Raises `ResourceError` if `estimate_bytes` exceeds the memory limit.

        Args:
            estimate_bytes: the estimate [bytes].
            key: the input that causes it (an option or config key).
            value: its value, as given.
            what: what the memory is for, e.g. 'a 51000 x 39000 grid'.
        """
        if estimate_bytes > self.memory_bytes:
            raise ResourceError(
                f"{key} {value}: {what} needs about {format_bytes(estimate_bytes)} of memory, "
                f"above the limit of {format_bytes(self.memory_bytes)} "
                "(--max-memory-gb raises it)",
                key=key,
                value=value,
                expected=f"at most {format_bytes(self.memory_bytes)} of memory",
            )

    def check_count(
        self, count: float, limit: float, *, key: str, value: Any, what: str, cost: str = ""
    ) -> None:
        """Raises `ResourceError` if `count` exceeds `limit`, unless `allow_large`.

        Args:
            count: the estimated count (poses, points, trials, hours).
            limit: the largest count allowed without `--allow-large`.
            key: the input that causes it.
            value: its value, as given.
            what: what is counted, e.g. 'full-search poses'.
            cost: what that means in time, e.g. 'about 40 min'.
        """
        if count > limit and not self.allow_large:
            note = f" ({cost})" if cost else ""
            raise ResourceError(
                f"{key} {value}: {format_count(count)} {what}{note}, above the limit of "
                f"{format_count(limit)} (--allow-large runs it anyway)",
                key=key,
                value=value,
                expected=f"at most {format_count(limit)} {what}",
            )


def format_duration(seconds: float) -> str:
    """'45 s', '12 min', '3.5 h', '4.2 days'."""
    if seconds < 90:
        return f"{seconds:.0f} s"
    if seconds < 5400:
        return f"{seconds / 60:.0f} min"
    if seconds < 2 * 86400:
        return f"{seconds / 3600:.1f} h"
    return f"{seconds / 86400:.1f} days"


def check_workers(limits: ResourceLimits, workers: int, source: str, key: str = "--workers") -> None:
    """Worker processes: at most `WORKERS_PER_CPU` per CPU (or --allow-large) and within memory.

    Raises:
        InputError: fewer than one worker.
        ResourceError: too many for the CPUs or the memory limit.
    """
    if workers < 1:
        raise InputError(f"{key} must be >= 1, got {workers}", key=key, value=workers, expected="1 or more")
    cpus = os.cpu_count() or 1
    limits.check_count(
        workers,
        max(4, WORKERS_PER_CPU * cpus),
        key=key,
        value=workers,
        what="worker processes",
        cost=f"this machine has {cpus} CPU{'s' if cpus > 1 else ''}",
    )
    each = WORKER_BYTES.get(source, max(WORKER_BYTES.values()))
    limits.check_memory(
        workers * each, key=key, value=workers, what=f"{workers} worker processes of ~{format_bytes(each)}"
    )


def check_trial_time(
    limits: ResourceLimits, *, kind: str, source: str, to_run: int, workers: int, key: str, value: Any
) -> None:
    """The estimated wall time of the trials still to run within `MAX_TRIAL_HOURS` (or --allow-large).

    Raises:
        ResourceError: over the limit without --allow-large.
    """
    each = SECONDS_PER_TRIAL.get((kind, source), max(SECONDS_PER_TRIAL.values()))
    parallel = max(1, min(workers, os.cpu_count() or 1))
    seconds = to_run * each / parallel
    if seconds > MAX_TRIAL_HOURS * 3600 and not limits.allow_large:
        raise ResourceError(
            f"{key} {value}: {to_run:,} {kind} trials to run would take about {format_duration(seconds)} "
            f"(at least {each:g} s each, {parallel} at a time), above the limit of {MAX_TRIAL_HOURS:g} h "
            "(--allow-large runs them anyway; an interrupted run resumes where it stopped)",
            key=key,
            value=value,
            expected=f"at most {MAX_TRIAL_HOURS:g} h of trials",
        )


def grid_cells(low: float, high: float, step: float) -> int:
    """Points of a grid from `low` to `high` in steps of `step` (both ends included)."""
    return int((high - low) / step + 1e-9) + 1


def full_search_estimate(
    x_range: tuple[float, float], y_range: tuple[float, float], step: float, yaws: int
) -> tuple[int, int, float]:
    """(cells, evaluations, memory [bytes]) of a full search over an x-y grid and `yaws` yaws."""
    cells = grid_cells(*x_range, step) * grid_cells(*y_range, step)
    return cells, cells * max(1, yaws), float(cells) * BYTES_PER_GRID_CELL


def model_make_estimate(
    image_size: tuple[int, int],
    focal_px: tuple[float, float],
    distance: float,
    point_spacing: float,
    reach: float,
) -> tuple[float, float]:
    """(memory [bytes], sampling grid points) of making a model from one photo.

    Args:
        image_size: the photo's (width, height) [px].
        focal_px: the model camera's (fx, fy) [px].
        distance: lens to the photo plane [m].
        point_spacing: S_in grid step [m].
        reach: how far sampling looks outside the cloth [m] (band and a grid step or two):
            the photo is padded by this many metres' worth of pixels on each side.
    """
    width, height = image_size
    fx, fy = focal_px
    metres_per_pixel = distance / fx
    pad = reach / metres_per_pixel + 2
    padded_pixels = (width + 2 * pad) * (height + 2 * pad)
    plane_w = (width + 2 * pad) * distance / fx
    plane_h = (height + 2 * pad) * distance / fy
    grid_points = (plane_w / point_spacing + 1) * (plane_h / point_spacing + 1)
    memory = (
        width * height * BYTES_PER_PHOTO_PIXEL
        + padded_pixels * 12  # padded mask (1 byte) and two float32 distance maps
        + grid_points * BYTES_PER_MODEL_GRID_POINT
    )
    return float(memory), float(grid_points)


__all__ = [
    "BYTES_PER_IMAGE_PIXEL",
    "BYTES_PER_INDIVIDUAL",
    "BYTES_PER_RENDERED_PIXEL",
    "GB",
    "MAX_FULL_SEARCH_EVALUATIONS",
    "MAX_MODEL_POINTS",
    "MAX_TRIAL_HOURS",
    "SECONDS_PER_TRIAL",
    "WORKERS_PER_CPU",
    "WORKER_BYTES",
    "ResourceLimits",
    "check_trial_time",
    "check_workers",
    "default_memory_gb",
    "format_bytes",
    "format_count",
    "format_duration",
    "full_search_estimate",
    "grid_cells",
    "machine_memory_bytes",
    "model_make_estimate",
]
