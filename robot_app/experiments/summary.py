"""summary.json of a sweep: counts, rates, error statistics (mean, std, mean ± 3σ), timings.

Column conventions of the per-trial table: `error_*` columns are errors (statistics
over the ok rows with a finite value), bool columns are rates (share of True among ok
rows), `*_s` columns are times [s].
"""

from __future__ import annotations

import json
import math
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from robot_app.experiments.results_table import BASE_COLUMNS, Row, is_timing_column
from robot_app.outputs import atomic_write_text


@dataclass(frozen=True)
class ErrorStats:
    """Statistics of one error column over the ok trials.

    Attributes:
        count: finite values used.
        mean: mean error (unit of the column).
        std: standard deviation (ddof=1 when count > 1).
        low: mean - 3 std.
        high: mean + 3 std.
        max_abs: largest absolute error.
    """

    count: int
    mean: float
    std: float
    low: float
    high: float
    max_abs: float


def error_stats(values: list[float] | np.ndarray) -> ErrorStats:
    """`ErrorStats` of the finite entries of `values` (NaN fields if none)."""
    data = np.asarray(values, dtype=float)
    data = data[np.isfinite(data)]
    if data.size == 0:
        nan = float("nan")
        return ErrorStats(0, nan, nan, nan, nan, nan)
    mean = float(data.mean())
    std = float(data.std(ddof=1)) if data.size > 1 else 0.0
    return ErrorStats(int(data.size), mean, std, mean - 3 * std, mean + 3 * std, float(np.abs(data).max()))


def _clean(value: Any) -> Any:
    """JSON-safe: NaN/inf become None, numpy scalars become Python numbers."""
    if isinstance(value, dict):
        return {k: _clean(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_clean(v) for v in value]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def _group_stats(rows: list[Row], columns: list[str]) -> dict[str, Any]:
    ok = [r for r in rows if r["status"] == "ok"]
    reasons = Counter(str(r["reason"]) for r in rows if r["status"] != "ok")
    result: dict[str, Any] = {
        "finished": len(rows),
        "ok": len(ok),
        "failed": len(rows) - len(ok),
        "failure_reasons": dict(reasons.most_common(10)),
        "rates": {},
        "errors": {},
        "mean_times_s": {},
    }
    for column in columns:
        values = [r[column] for r in ok if r[column] != ""]
        if column.startswith("error_"):
            result["errors"][column] = error_stats([float(v) for v in values]).__dict__
        elif values and all(isinstance(v, bool) for v in values):
            result["rates"][column] = sum(values) / len(values)
        elif is_timing_column(column) and values:
            result["mean_times_s"][column] = float(np.mean([float(v) for v in values]))
    return result


def summarize(
    config: Any, rows: list[Row], *, wall_time_s: float, ran: int, workers: int, backend: str
) -> dict[str, Any]:
    """The summary of a sweep's table.

    Args:
        config: the trial config (name, kind, trials, sweep).
        rows: parsed rows of the per-trial table.
        wall_time_s: wall time of this run [s].
        ran: trials run in this run (the rest were resumed).
        workers: worker processes of this run.
        backend: "local" or "ray".
    """
    rows = [r for r in rows if int(r["index"]) < config.trials]
    columns = [c for c in (rows[0].keys() if rows else []) if c not in BASE_COLUMNS or c == "duration_s"]
    summary: dict[str, Any] = {
        "name": config.name,
        "kind": config.kind,
        "config_hash": config.config_hash(),
        "trials": config.trials,
        **_group_stats(rows, columns),
        "run": {
            "backend": backend,
            "workers": workers,
            "ran": ran,
            "wall_time_s": wall_time_s,
            "trials_per_s": ran / wall_time_s if wall_time_s > 0 else None,
        },
    }
    if config.sweep is not None:
        summary["sweep"] = {
            config.sweep_label(point): _group_stats([r for r in rows if int(r["point"]) == point], columns)
            for point in range(config.point_count)
        }
    return _clean(summary)


def write_summary(summary: dict[str, Any], path: str | Path) -> None:
    """Writes the summary as indented JSON, atomically."""
    atomic_write_text(path, json.dumps(_clean(summary), indent=2) + "\n")


__all__ = ["ErrorStats", "error_stats", "summarize", "write_summary"]
