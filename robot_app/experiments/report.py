"""Plots of trial results: error histograms with mean ± 3σ (Fig. 12), sweep curves,
the identification matrix, and the plots of a finished trial folder.

Matplotlib runs headless (Agg); every function writes one PNG and returns its path.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import numpy.typing as npt

from robot_app.experiments.results_table import Row, read_table
from robot_app.experiments.summary import error_stats
from robot_app.outputs import atomic_path

ERROR_LABELS = {
    "error_x_mm": "position x error [mm]",
    "error_y_mm": "position y error [mm]",
    "error_z_mm": "position z error [mm]",
    "error_yaw_deg": "yaw error [deg]",
    "error_tilt_deg": "tilt error [deg]",
}
"""Axis labels of the recognition error columns."""


def column_values(rows: Sequence[Row], column: str, only_ok: bool = True) -> npt.NDArray[np.float64]:
    """Finite float values of `column` over the (ok) rows."""
    values = [r[column] for r in rows if (r["status"] == "ok" or not only_ok) and r.get(column, "") != ""]
    data = np.asarray(values, dtype=float)
    return data[np.isfinite(data)]


def plot_error_histograms(
    rows: Sequence[Row],
    path: str | Path,
    columns: Sequence[str] | None = None,
    title: str = "",
    tolerances: dict[str, float] | None = None,
) -> Path:
    """Histograms of error columns with the mean and mean ± 3σ marked (paper Fig. 12).

    Args:
        rows: per-trial rows (ok rows are used).
        path: output PNG.
        columns: error columns (default: every `error_*` column present).
        title: figure title.
        tolerances: column -> ± bound drawn as grey dotted lines (e.g. the paper's 10).
    """
    if columns is None:
        columns = [c for c in (rows[0].keys() if rows else []) if c.startswith("error_")]
    columns = list(columns) or ["error"]
    ncols = min(3, len(columns))
    nrows = -(-len(columns) // ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(4.2 * ncols, 3.3 * nrows), squeeze=False)
    for ax in axes.ravel()[len(columns) :]:
        ax.set_visible(False)
    for ax, column in zip(axes.ravel(), columns, strict=False):
        data = column_values(rows, column) if rows and column in rows[0] else np.empty(0)
        stats = error_stats(data)
        if data.size:
            ax.hist(data, bins=min(40, max(5, data.size // 10)), color="#4477aa", alpha=0.85)
            ax.axvline(stats.mean, color="k", lw=1.2, label=f"mean {stats.mean:+.2f}")
            for bound in (stats.low, stats.high):
                ax.axvline(bound, color="#cc3311", ls="--", lw=1.2)
            ax.plot([], [], color="#cc3311", ls="--", label=f"±3σ [{stats.low:+.1f}, {stats.high:+.1f}]")
        else:
            ax.text(0.5, 0.5, "no data", ha="center", va="center", transform=ax.transAxes)
        if tolerances and column in tolerances:
            for bound in (-tolerances[column], tolerances[column]):
                ax.axvline(bound, color="0.5", ls=":", lw=1.0)
        ax.set_xlabel(ERROR_LABELS.get(column, column))
        ax.set_ylabel("trials")
        ax.set_title(f"n = {stats.count}", fontsize=9)
        if data.size:
            ax.legend(fontsize=7, loc="upper right")
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return _save(fig, path)


def plot_sweep(summary: dict[str, Any], path: str | Path, columns: Sequence[str] = ()) -> Path:
    """Error spread (3σ) and mean recognition time against the swept value.

    Args:
        summary: a sweep's summary.json content (with a "sweep" section).
        path: output PNG.
        columns: error columns to draw (default: x, y, yaw errors when present).
    """
    sweep = summary.get("sweep", {})
    labels = list(sweep)
    values = [label.split("=", 1)[1] for label in labels]
    key = labels[0].split("=", 1)[0] if labels else "sweep"
    columns = list(columns) or ["error_x_mm", "error_y_mm", "error_yaw_deg"]
    fig, (ax_error, ax_time) = plt.subplots(1, 2, figsize=(10, 3.6))
    positions = np.arange(len(labels))
    for column in columns:
        spread = [3 * (sweep[label]["errors"].get(column, {}).get("std") or np.nan) for label in labels]
        ax_error.plot(positions, spread, "o-", label=f"3σ of {ERROR_LABELS.get(column, column)}")
    rates = [sweep[label]["rates"].get("success") for label in labels]
    if any(r is not None for r in rates):
        twin = ax_error.twinx()
        twin.plot(positions, [100 * (r or 0) for r in rates], "k^--", label="success [%]")
        twin.set_ylabel("success [%]")
        twin.set_ylim(0, 105)
    times = [sweep[label]["mean_times_s"].get("recognition_time_s", np.nan) for label in labels]
    ax_time.plot(positions, times, "o-", color="#228833")
    for ax in (ax_error, ax_time):
        ax.set_xticks(positions, values)
        ax.set_xlabel(key)
    ax_error.set_ylabel("3σ error [mm or deg]")
    ax_error.legend(fontsize=7, loc="center right")
    ax_time.set_ylabel("mean recognition time [s]")
    fig.tight_layout()
    return _save(fig, path)


def plot_matrix(
    matrix: npt.ArrayLike, path: str | Path, labels: Sequence[str], title: str = "", fmt: str = "{:.2f}"
) -> Path:
    """A square matrix as a heat map with its values written in (identification matrix).

    Args:
        matrix: (n, n) values; row = model, column = scene.
        path: output PNG.
        labels: n tick labels.
        title: figure title.
        fmt: format of the written values.
    """
    data = np.asarray(matrix, dtype=float)
    fig, ax = plt.subplots(figsize=(0.55 * len(labels) + 2.5, 0.55 * len(labels) + 2))
    image = ax.imshow(data, cmap="viridis", vmin=0.0, vmax=max(1.0, float(np.nanmax(data))))
    for (i, j), value in np.ndenumerate(data):
        colour = "k" if value > 0.6 else "w"
        ax.text(j, i, fmt.format(value), ha="center", va="center", fontsize=6, color=colour)
    ax.set_xticks(range(len(labels)), labels, rotation=90, fontsize=7)
    ax.set_yticks(range(len(labels)), labels, fontsize=7)
    ax.set_xlabel("cloth in the scene")
    ax.set_ylabel("model searched for")
    fig.colorbar(image, ax=ax, label="best fitness")
    if title:
        ax.set_title(title)
    fig.tight_layout()
    return _save(fig, path)


def plot_trial_folder(folder: str | Path) -> list[Path]:
    """Plots of a finished `robot-app trial` folder: errors.png (+ sweep.png for sweeps)."""
    folder = Path(folder)
    summary = json.loads((folder / "summary.json").read_text())
    rows = read_table(folder / "trials.csv")
    written = [plot_error_histograms(rows, folder / "errors.png", title=summary.get("name", ""))]
    if "sweep" in summary:
        written.append(plot_sweep(summary, folder / "sweep.png"))
    return written


def _save(fig: Any, path: str | Path) -> Path:
    file = Path(path)
    try:
        with atomic_path(file) as temporary:  # a PNG is whole or absent
            fig.savefig(temporary, dpi=110)
    finally:
        plt.close(fig)
    return file


__all__ = [
    "ERROR_LABELS",
    "column_values",
    "plot_error_histograms",
    "plot_matrix",
    "plot_sweep",
    "plot_trial_folder",
]
