"""Throughput of recognition trials with 1 and 2 local workers, and local vs Ray equality.

Runs the same config (default: configs/recognition_1000.yaml, 1000 trials) three times
into fresh folders: local with 1 worker, local with 2 workers, and Ray tasks on a
private local Ray instance with 2 CPUs. Prints trials/s of each (wall time of the
sweep, including each worker's one-off model building) and whether the three per-trial
tables are equal apart from the timing columns (`*_s`).

    python scripts/bench_trials.py [--trials 1000] [--out results/bench_trials] [--no-ray]
"""

from __future__ import annotations

import argparse
import csv
import shutil
import time
from pathlib import Path

from robot_app.experiments import load_trial_config, run_trials
from robot_app.experiments.results_table import is_timing_column

ROOT = Path(__file__).resolve().parents[1]


def _comparable(folder: Path) -> list[dict[str, str]]:
    """The table's rows as written (strings, so NaN == NaN), timing columns dropped."""
    with (folder / "trials.csv").open(newline="") as file:
        return [{k: v for k, v in row.items() if not is_timing_column(k)} for row in csv.DictReader(file)]


def _newest_source() -> float:
    """Latest modification time of the package's sources (edits mid-run spoil equality)."""
    return max(path.stat().st_mtime for path in (ROOT / "robot_app").rglob("*.py"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", type=Path, default=ROOT / "configs" / "recognition_1000.yaml")
    parser.add_argument("--trials", type=int, default=1000)
    parser.add_argument("--out", type=Path, default=ROOT / "results" / "bench_trials")
    parser.add_argument("--no-ray", action="store_true", help="skip the Ray backend")
    args = parser.parse_args()
    config = load_trial_config(args.config, [f"trials={args.trials}"])
    runs = [("local", 1), ("local", 2)] + ([] if args.no_ray else [("ray", 2)])
    tables = {}
    started = time.time()
    for backend, workers in runs:
        folder = args.out / f"{backend}_{workers}"
        shutil.rmtree(folder, ignore_errors=True)
        result = run_trials(
            config, folder, workers=workers, backend=backend, ray_address="local", progress=True, plots=False
        )
        rate = result.ran / result.wall_time_s
        print(
            f"{backend:5s} workers={workers}: {result.ran} trials in {result.wall_time_s:.1f} s = "
            f"{rate:.2f} trials/s ({result.failed} failed, success "
            f"{100 * result.summary['rates'].get('success', float('nan')):.1f} %)",
            flush=True,
        )
        tables[f"{backend}_{workers}"] = _comparable(folder)
    if _newest_source() > started:
        print("WARNING: robot_app sources changed during the run; the backends ran different code")
    reference = tables["local_1"]
    for name, rows in tables.items():
        differing = sum(a != b for a, b in zip(rows, reference, strict=False))
        differing += abs(len(rows) - len(reference))
        equal = rows == reference
        print(f"{name} rows equal to local_1 (timing columns excluded): {equal} ({differing} differ)")


if __name__ == "__main__":
    main()
