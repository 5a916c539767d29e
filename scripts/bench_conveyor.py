"""Conveyor benchmark: picking a cloth off a moving belt, servo against look-then-move.

    python scripts/bench_conveyor.py [--episodes 40] [--workers 2] [--speeds 0,0.025,0.05,0.1]
                                     [--strategies servo,look_then_move] [--latency 0.06]
                                     [--sweep-latencies 0,0.06,0.12] [--sweep-speed 0.05]
                                     [--realism realistic] [--out results/bench_conveyor]
                                     [--set key=value ...]

Episode i of every cell is the same scene: a random cloth of the whole catalogue (No.1-20),
a random belt direction (0-360 deg), its pose in the upstream half of the range drawn
from the scene seed. Cells: each strategy at each belt speed with `loop.vision_latency`
= --latency; then the latency sweep (servo at --sweep-speed). The cell is the --realism
preset's, whose cameras add their own latency (realistic: 50 +- 10 ms exposure to memory)
before the recognition's.

Printed per cell: placed rate, outcome counts, grasp offset at closure (TCP to the
intended grasp point on the true cloth, in the cloth's plane; first closure of each
episode), tracking error of the filtered pose against the truth during APPROACH and
DESCEND (median, p95 over every vision period), limit violations, arm collisions, cycle
times. Rows go to <out>/rows.jsonl as they finish (a rerun with the same --out resumes),
the table to episodes.csv, the figures to summary.json and tracking_error.png.
"""

from __future__ import annotations

import argparse
import csv
import json
import multiprocessing as mp
import time
from pathlib import Path

import numpy as np

from robot_app.config import load_config
from robot_app.experiments.pick_place_episode import PickPlaceConfig, run_episode
from robot_app.sim.config import CATALOGUE_SIZE
from robot_app.sim.realism import REALISM_NAMES

GOALS = {0.0: 1.0, 0.025: 1.0, 0.05: 0.95, 0.1: 0.8}  # servo placed rate per belt speed [m/s]


def episode_overrides(index: int, base_seed: int) -> list[str]:
    """The scene of episode `index`: the same in every cell."""
    rng = np.random.default_rng([base_seed, index, 16])
    target = int(rng.integers(1, CATALOGUE_SIZE + 1))
    direction = float(rng.uniform(0.0, 360.0))
    return [
        f"seed={base_seed * 100000 + index}",
        f"scene.target={target}",
        f"scene.conveyor_direction_deg={direction:.1f}",
    ]


def run_one(job: tuple[str, str, float, float, int, int, tuple[str, ...]]) -> dict[str, object]:
    cell, strategy, speed, latency, index, base_seed, extra = job
    overrides = [
        *episode_overrides(index, base_seed),
        f"scene.conveyor_speed={speed}",
        f"loop.strategy={strategy}",
        f"loop.vision_latency={latency}",
    ]
    row: dict[str, object] = {
        "cell": cell,
        "strategy": strategy,
        "speed": speed,
        "latency": latency,
        "episode": index,
        "overrides": " ".join(overrides),
    }
    try:
        config = load_config(PickPlaceConfig, None, [*extra, *overrides])
        result = run_episode(config).result
    except Exception as err:  # a crashed episode is a failed row, the sweep goes on
        return row | {"success": False, "outcome": "crashed", "reason": f"{type(err).__name__}: {err}"}
    approach = next((p.start_time for p in result.phases if p.phase == "approach"), None)
    tracking = [
        (t.time - approach if approach is not None else t.time, t.phase, t.error_xy_mm, t.cloth_speed)
        for t in result.tracking
    ]
    first = result.grasps[0] if result.grasps else None
    return row | {
        "target": config.scene.target,
        "direction_deg": config.scene.conveyor_direction_deg,
        "success": result.success,
        "outcome": result.outcome.value,
        "reason": result.reason,
        "placed_fraction": result.placed_fraction,
        "limit_violations": result.limit_report.violations,
        "commanded_samples": result.commanded_samples,
        "collisions": result.collisions,
        "grasp_attempts": result.grasp_attempts,
        "observe_returns": result.observe_returns,
        "grasp_offset_mm": None if first is None else first.offset_mm,
        "grasp_tcp_speed": None if first is None else first.tcp_speed,
        "sim_time_s": result.sim_time,
        "wall_s": result.wall_s,
        "recognition_age_ms": [1e3 * r.age for r in result.recognitions],
        "tracking": tracking,
    }


def quantiles(values: list[float]) -> dict[str, float | int | None]:
    array = np.asarray([v for v in values if v is not None and np.isfinite(v)], dtype=float)
    if not array.size:
        return {"median": None, "p95": None, "n": 0}
    return {"median": float(np.median(array)), "p95": float(np.percentile(array, 95)), "n": int(array.size)}


def cell_summary(rows: list[dict[str, object]]) -> dict[str, object]:
    finished = [r for r in rows if r["outcome"] != "crashed"]
    outcomes: dict[str, int] = {}
    for r in rows:
        outcomes[str(r["outcome"])] = outcomes.get(str(r["outcome"]), 0) + 1
    tracking = [sample for r in finished for sample in r.get("tracking", [])]  # type: ignore[attr-defined]
    return {
        "episodes": len(rows),
        "placed_rate": sum(bool(r["success"]) for r in rows) / max(1, len(rows)),
        "outcomes": outcomes,
        "grasp_offset_mm": quantiles([r.get("grasp_offset_mm") for r in finished]),  # type: ignore[misc]
        "tracking_error_mm": {
            phase: quantiles([s[2] for s in tracking if s[1] == phase]) for phase in ("approach", "descend")
        },
        "recognition_age_ms": quantiles(
            [a for r in finished for a in r.get("recognition_age_ms", [])]  # type: ignore[attr-defined]
        ),
        "limit_violations": int(sum(int(r.get("limit_violations") or 0) for r in finished)),
        "commanded_samples": int(sum(int(r.get("commanded_samples") or 0) for r in finished)),
        "collisions": int(sum(int(r.get("collisions") or 0) for r in finished)),
        "sim_time_s": quantiles([r["sim_time_s"] for r in finished if r["success"]]),  # type: ignore[misc]
        "failures": [
            f"episode {r['episode']} [{r['overrides']}]: {r['outcome']} - {r.get('reason')}"
            for r in rows
            if not r["success"]
        ],
    }


def plot_tracking(rows: list[dict[str, object]], speeds: list[float], latency: float, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 4.5))
    bins = np.arange(0.0, 4.01, 0.1)
    for strategy, style in (("servo", "-"), ("look_then_move", ":")):
        for speed in speeds:
            samples = [
                s
                for r in rows
                if r["strategy"] == strategy and r["speed"] == speed and r["latency"] == latency
                for s in r.get("tracking", [])  # type: ignore[attr-defined]
            ]
            if not samples:
                continue
            t = np.array([s[0] for s in samples])
            e = np.array([s[2] for s in samples])
            index = np.digitize(t, bins)
            centres, medians = [], []
            for k in range(1, len(bins)):
                chosen = e[index == k]
                if chosen.size >= 3:
                    centres.append(bins[k - 1] + 0.05)
                    medians.append(float(np.median(chosen)))
            ax.plot(centres, medians, style, label=f"{strategy} {speed * 1e3:.0f} mm/s")
    ax.set_xlabel("time since APPROACH started [s]")
    ax.set_ylabel("filtered pose error vs truth, x-y [mm] (median)")
    ax.set_yscale("log")
    ax.set_title(f"tracking error during APPROACH and DESCEND (latency {latency * 1e3:.0f} ms + camera)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, ncol=2)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    parser.add_argument("--episodes", type=int, default=40)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--seed", type=int, default=16)
    parser.add_argument("--speeds", default="0,0.025,0.05,0.1")
    parser.add_argument("--strategies", default="servo,look_then_move")
    parser.add_argument("--latency", type=float, default=0.06)
    parser.add_argument("--sweep-latencies", default="0,0.06,0.12")
    parser.add_argument("--sweep-speed", type=float, default=0.05)
    parser.add_argument("--out", default="results/bench_conveyor")
    parser.add_argument("--realism", choices=REALISM_NAMES, default="realistic")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    speeds = [float(v) for v in args.speeds.split(",") if v]
    strategies = [s for s in args.strategies.split(",") if s]
    sweep = [float(v) for v in args.sweep_latencies.split(",") if v]
    fixed = (f"world.realism={args.realism}", "world.cameras.image_size=[320,240]", *args.set)
    cells: list[tuple[str, str, float, float]] = [
        (f"{strategy} {speed * 1e3:g} mm/s", strategy, speed, args.latency)
        for strategy in strategies
        for speed in speeds
    ]
    sweep_name = "servo {:g} mm/s latency {:g} ms"
    cells += [
        (sweep_name.format(args.sweep_speed * 1e3, latency * 1e3), "servo", args.sweep_speed, latency)
        for latency in sweep
        if latency != args.latency or args.sweep_speed not in speeds or "servo" not in strategies
    ]
    rows_file = out / "rows.jsonl"
    done: dict[tuple[str, float, float, int], dict[str, object]] = {}
    if rows_file.exists():
        for line in rows_file.read_text().splitlines():
            row = json.loads(line)
            done[(row["strategy"], row["speed"], row["latency"], row["episode"])] = row
    jobs = [
        (name, strategy, speed, latency, i, args.seed, fixed)
        for name, strategy, speed, latency in cells
        for i in range(args.episodes)
        if (strategy, speed, latency, i) not in done
    ]
    print(f"{len(cells)} cells x {args.episodes} episodes; {len(done)} rows already done, {len(jobs)} to run")
    start = time.perf_counter()
    rows = list(done.values())
    with rows_file.open("a") as sink, mp.get_context("spawn").Pool(args.workers, maxtasksperchild=20) as pool:
        for k, row in enumerate(pool.imap_unordered(run_one, jobs), start=1):
            rows.append(row)
            sink.write(json.dumps(row) + "\n")
            sink.flush()
            print(
                f"[{k}/{len(jobs)}] {row['cell']} episode {row['episode']}: {row['outcome']} "
                f"({'ok' if row['success'] else row.get('reason')})",
                flush=True,
            )
    summary: dict[str, object] = {}
    for name, strategy, speed, latency in cells:
        chosen = [
            r
            for r in rows
            if r["strategy"] == strategy
            and r["speed"] == speed
            and r["latency"] == latency
            and int(r["episode"]) < args.episodes  # type: ignore[call-overload]
        ]
        summary[name] = cell_summary(chosen)
    table = [{k: v for k, v in r.items() if k not in ("tracking", "recognition_age_ms")} for r in rows]
    table.sort(key=lambda r: (str(r["cell"]), int(r["episode"])))  # type: ignore[call-overload]
    with (out / "episodes.csv").open("w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=sorted({k for r in table for k in r}))
        writer.writeheader()
        writer.writerows(table)
    plot_tracking(rows, speeds, args.latency, out / "tracking_error.png")
    meta = {"episodes_per_cell": args.episodes, "workers": args.workers, "realism": args.realism,
            "settings": list(fixed), "wall_s_this_run": time.perf_counter() - start}  # fmt: skip
    (out / "summary.json").write_text(json.dumps({"meta": meta, "cells": summary}, indent=2))
    print_report(summary, speeds, strategies, args)


def print_report(
    summary: dict[str, object], speeds: list[float], strategies: list[str], args: argparse.Namespace
) -> None:
    print()
    header = (
        f"{'cell':<38} {'placed':>7} {'offset mm med/p95':>18} {'track APPR mm med/p95':>22} "
        f"{'track DESC mm med/p95':>22} {'viol':>5} {'coll':>5} {'cycle s':>8}"
    )
    print(header)
    print("-" * len(header))

    def pair(q: dict[str, object]) -> str:
        if q["median"] is None:
            return "-"
        return f"{q['median']:.1f} / {q['p95']:.1f}"

    for name, cell in summary.items():
        c = cell  # type: ignore[assignment]
        tracking = c["tracking_error_mm"]  # type: ignore[index]
        cycle = c["sim_time_s"]["median"]  # type: ignore[index]
        print(
            f"{name:<38} {100 * c['placed_rate']:6.1f}% {pair(c['grasp_offset_mm']):>18} "  # type: ignore[index]
            f"{pair(tracking['approach']):>22} {pair(tracking['descend']):>22} "
            f"{c['limit_violations']:>5} {c['collisions']:>5} "  # type: ignore[index]
            f"{'-' if cycle is None else f'{cycle:.1f}':>8}"
        )
    print()
    for name, cell in summary.items():
        failures = cell["failures"]  # type: ignore[index]
        if failures:
            print(f"{name}: {len(failures)} not placed")
            for line in failures:
                print(f"    {line}")
    print()
    if "servo" in strategies:
        for speed in speeds:
            goal = GOALS.get(speed)
            name = f"servo {speed * 1e3:g} mm/s"
            if goal is not None and name in summary:
                rate = summary[name]["placed_rate"]  # type: ignore[index]
                verdict = "PASS" if rate >= goal else "MISS"
                print(f"goal servo {speed * 1e3:g} mm/s placed >= {goal:.0%}: {verdict} ({rate:.1%})")
        name = f"servo {args.sweep_speed * 1e3:g} mm/s"
        if name in summary:
            offset = summary[name]["grasp_offset_mm"]["median"]  # type: ignore[index]
            verdict = "PASS" if offset is not None and offset <= 5.0 else "MISS"
            speed_mm = args.sweep_speed * 1e3
            print(f"goal grasp offset median <= 5 mm at {speed_mm:g} mm/s: {verdict} ({offset})")
    violations = sum(c["limit_violations"] for c in summary.values())  # type: ignore[index]
    collisions = sum(c["collisions"] for c in summary.values())  # type: ignore[index]
    print(f"goal 0 limit violations, 0 collisions: {'PASS' if violations == collisions == 0 else 'MISS'} "
          f"({violations}, {collisions})")  # fmt: skip


if __name__ == "__main__":
    main()
