"""Closed-loop pick-and-place benchmark: success rate, failure causes, limits, collisions, timings.

    python scripts/bench_pick_place.py [--episodes 100] [--first 0] [--workers 2] [--realism realistic]
                                       [--out results/bench_pick_place] [--set key=value ...]

Episodes are randomised from their index: a random cloth of the whole catalogue (No.1-20),
a random pose in the range (any yaw; the scene seed), one third with the 45% occluder,
one third with a distractor cloth drawn from the whole catalogue (same hue family
included). The cell is the `--realism` preset's (default: realistic). Success = the cloth
lies inside the box (>= 90% of its nodes within the walls), no limit was exceeded on any
commanded sample, no arm collision. Every failed episode is listed with its cause.
"""

from __future__ import annotations

import argparse
import csv
import json
import multiprocessing as mp
import sys
import time
from pathlib import Path

import numpy as np

from robot_app.config import load_config
from robot_app.errors import ConfigError
from robot_app.experiments.pick_place_episode import PickPlaceConfig, run_episode
from robot_app.sim.config import CATALOGUE_SIZE
from robot_app.sim.realism import REALISM_NAMES


def episode_overrides(index: int, base_seed: int) -> list[str]:
    rng = np.random.default_rng([base_seed, index])
    target = int(rng.integers(1, CATALOGUE_SIZE + 1))
    overrides = [f"seed={base_seed * 100000 + index}", f"scene.target={target}"]
    if index % 3 == 1:
        overrides.append("scene.occluder=true")
    elif index % 3 == 2:
        distractor = int(rng.choice([n for n in range(1, CATALOGUE_SIZE + 1) if n != target]))
        overrides.append(f"scene.distractor={distractor}")
    return overrides


def run_one(job: tuple[int, int, tuple[str, ...]]) -> dict[str, object]:
    index, base_seed, extra = job
    overrides = episode_overrides(index, base_seed)
    row: dict[str, object] = {"episode": index, "overrides": " ".join(overrides)}
    try:
        config = load_config(PickPlaceConfig, None, [*extra, *overrides])
        result = run_episode(config).result
    except Exception as err:  # a crashed episode is a failed row, the sweep goes on
        return row | {"success": False, "outcome": "crashed", "reason": f"{type(err).__name__}: {err}"}
    return row | {
        "success": result.success,
        "outcome": result.outcome.value,
        "reason": result.reason,
        "placed_fraction": result.placed_fraction,
        "limit_violations": result.limit_report.violations,
        "commanded_samples": result.commanded_samples,
        "collisions": result.collisions,
        "grasp_attempts": result.grasp_attempts,
        "sim_time_s": result.sim_time,
        "wall_s": result.wall_s,
        "ruckig_median_us": float(np.median(result.ruckig_times_us)) if result.ruckig_times_us else None,
        "ik_median_ms": float(np.median(result.ik_times_ms)) if result.ik_times_ms else None,
        "ruckig_us": list(result.ruckig_times_us),
        "ik_ms": list(result.ik_times_ms),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    parser.add_argument("--episodes", type=int, default=100)
    parser.add_argument("--first", type=int, default=0, help="index of the first episode (default 0)")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--out", default="results/bench_pick_place")
    parser.add_argument("--realism", choices=REALISM_NAMES, default="realistic")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    args = parser.parse_args()
    if args.episodes < 1 or args.workers < 1 or args.first < 0 or args.seed < 0:
        parser.error("--episodes and --workers must be >= 1, --first and --seed >= 0")
    fixed = (f"world.realism={args.realism}", "world.cameras.image_size=[320,240]", *args.set)
    try:  # bad settings stop here, not as a crash in every episode
        load_config(PickPlaceConfig, None, [*fixed, *episode_overrides(args.first, args.seed)])
    except ConfigError as err:
        sys.exit(f"bench_pick_place: {err}")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    jobs = [(i, args.seed, fixed) for i in range(args.first, args.first + args.episodes)]
    rows: list[dict[str, object]] = []
    start = time.perf_counter()
    with mp.get_context("spawn").Pool(args.workers) as pool:
        for row in pool.imap_unordered(run_one, jobs):
            rows.append(row)
            done = len(rows)
            ok = sum(bool(r["success"]) for r in rows)
            print(
                f"[{done}/{args.episodes}] episode {row['episode']}: {row['outcome']} "
                f"({'ok' if row['success'] else row.get('reason')}) - {ok}/{done} successful",
                flush=True,
            )
    rows.sort(key=lambda r: int(r["episode"]))  # type: ignore[arg-type]
    table = [{k: v for k, v in r.items() if k not in ("ruckig_us", "ik_ms")} for r in rows]
    with (out / "episodes.csv").open("w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=sorted({k for r in table for k in r}))
        writer.writeheader()
        writer.writerows(table)
    finished = [r for r in rows if r["outcome"] != "crashed"]
    sim = np.array([r["sim_time_s"] for r in finished], dtype=float)
    wall = np.array([r["wall_s"] for r in finished], dtype=float)
    ruckig = (
        np.concatenate([np.asarray(r["ruckig_us"], dtype=float) for r in finished])
        if finished
        else np.zeros(0)
    )
    ik = np.concatenate([np.asarray(r["ik_ms"], dtype=float) for r in finished]) if finished else np.zeros(0)
    outcomes: dict[str, int] = {}
    for r in rows:
        outcomes[str(r["outcome"])] = outcomes.get(str(r["outcome"]), 0) + 1
    summary = {
        "episodes": len(rows),
        "success_rate": sum(bool(r["success"]) for r in rows) / max(1, len(rows)),
        "outcomes": outcomes,
        "limit_violations": int(sum(int(r.get("limit_violations") or 0) for r in finished)),
        "commanded_samples": int(sum(int(r.get("commanded_samples") or 0) for r in finished)),
        "collisions": int(sum(int(r.get("collisions") or 0) for r in finished)),
        "sim_time_s": {"median": float(np.median(sim)), "worst": float(sim.max())} if sim.size else None,
        "wall_s": {"median": float(np.median(wall)), "worst": float(wall.max())} if wall.size else None,
        "ruckig_us": {"median": float(np.median(ruckig)), "count": int(ruckig.size)} if ruckig.size else None,
        "ik_ms": {"median": float(np.median(ik)), "count": int(ik.size)} if ik.size else None,
        "total_wall_s": time.perf_counter() - start,
        "workers": args.workers,
        "realism": args.realism,
        "settings": list(fixed),
    }
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    print(json.dumps(summary, indent=2))
    failed = [r for r in rows if not r["success"]]
    print(f"{len(failed)} failed episode(s):")
    for r in failed:
        print(f"  episode {r['episode']} [{r['overrides']}]: {r['outcome']} - {r.get('reason')}")
    print(
        f"goal: success >= 98%: {'PASS' if summary['success_rate'] >= 0.98 else 'MISS'}; "
        f"simulated cycle time median <= 10 s: "
        f"{'PASS' if sim.size and np.median(sim) <= 10 else 'MISS'}"
    )


if __name__ == "__main__":
    main()
