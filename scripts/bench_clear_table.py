"""Clear-table benchmark: cleared episodes, wrong boxes, double picks and drops noticed, times.

    python scripts/bench_clear_table.py [--episodes 50] [--workers 2] [--realism realistic]
                                        [--out results/bench_clear_table] [--set key=value ...]

Episodes are drawn from their index: 3-5 cloths from the whole catalogue (No.1-20); a third
laid out to overlap (the largest overlap of two cloths >= 20 % of the smaller one's area),
a third with two or more cloths of one hue family, a third as they fall. Every fifth episode
has a mishap made to happen (alternately: the first transfer drops its cloth at a random
moment, or the first grasp catches the nearest other cloth too), so that the checks have
something to find; natural double picks count too. The cell is the `--realism` preset's
(default: realistic). An episode is cleared when every cloth lies in its box (>= 90 % of
its nodes inside the walls, at any height; the cloths heaped over the rim are counted).
Every episode not cleared is listed with its cause; each episode's results folder
(cloths.csv, picks.csv, surveys.csv, summary.json) is kept in `--out`/episode_NNN.
Ctrl-C stops the sweep: the episodes finished by then are summarised as usual (summary.json
says "interrupted": true; exit 130).
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
import time
from pathlib import Path

import numpy as np

from robot_app.config import load_config
from robot_app.control import Outcome
from robot_app.errors import ConfigError
from robot_app.experiments.clear_table import ClearTableConfig, ClearTableEpisode, run_clear_table
from robot_app.experiments.clear_table_results import write_clear_table
from robot_app.sim.fresh_process import fresh_process_pool
from robot_app.sim.realism import REALISM_NAMES

DEFAULT_CONFIG = Path(__file__).resolve().parents[1] / "configs" / "clear_table.yaml"


def episode_overrides(index: int, base_seed: int) -> list[str]:
    rng = np.random.default_rng([base_seed, index])
    overrides = [f"seed={base_seed * 100000 + index}", "pile.count=[3,5]"]
    kind = index % 3
    if kind == 0:
        overrides += ["pile.overlap=overlap", "pile.min_overlap=0.2"]
    elif kind == 1:
        overrides.append("pile.same_family=true")
    if index % 5 == 4:
        if (index // 5) % 2 == 0:
            overrides += ["faults.drop_transfers=[1]", f"faults.drop_after={rng.uniform(0.1, 1.3):.2f}"]
        else:
            overrides.append("faults.double_grasps=[1]")
    return overrides


def double_pick_counts(episode: ClearTableEpisode) -> dict[str, int]:
    """For the detected double picks (two or more cloths lifted, by the simulator's truth,
    and the lift rejected): the other cloth named (right: the names are exactly the other
    cloths truly lifted; wrong: a name not lifted, or a lifted cloth left unnamed, which
    would ride into the meant cloth's box unbooked), both placed (the named cloth carried
    into the box), put back."""
    counts = dict.fromkeys(
        ("double_named", "double_named_right", "double_named_wrong", "double_both_placed", "double_put_back"),
        0,
    )
    attempts = episode.result.attempts
    for lift in episode.lifts:
        attempt = next((a for a in attempts if a.start_time <= lift.time <= a.end_time), None)
        if len(lift.lifted) < 2 or attempt is None or not attempt.not_meant_alone:
            continue
        named = set(attempt.came_along) | set(attempt.laid_back_too)
        if named:
            others = {f"No.{n}" for n in lift.lifted} - {lift.meant}
            counts["double_named"] += 1
            counts["double_named_right" if named == others else "double_named_wrong"] += 1
        if attempt.came_along and attempt.result.outcome is Outcome.PLACED:
            counts["double_both_placed"] += 1
        counts["double_put_back"] += int(attempt.put_back)
    return counts


def run_one(job: tuple[int, int, tuple[str, ...], str]) -> dict[str, object]:
    index, base_seed, extra, out = job
    overrides = episode_overrides(index, base_seed)
    row: dict[str, object] = {"episode": index, "overrides": " ".join(overrides)}
    try:
        config = load_config(ClearTableConfig, DEFAULT_CONFIG, [*extra, *overrides])
        episode = run_clear_table(config)
    except Exception as err:  # a crashed episode is a failed row, the sweep goes on
        return row | {"cleared": False, "cause": f"crashed: {type(err).__name__}: {err}"}
    write_clear_table(Path(out) / f"episode_{index:03d}", config, episode)
    r, v = episode.result, episode.verdict
    placed = [c for c in r.cloths if c.order is not None]
    per_cloth = [c.sim_time for c in placed]
    known = sum(1 for c in v.cloths if c.known)
    return row | {
        "cleared": v.cleared,
        "cause": v.cause,
        "robot_cleared": r.cleared,
        "stop_reason": r.stop_reason,
        "pile": " ".join(f"No.{n}" for n in episode.pile),
        "cloths": len(episode.pile),
        "known_cloths": known,
        "max_overlap": round(episode.max_overlap, 3),
        "same_family": episode.same_family,
        "in_right_box": sum(1 for c in v.cloths if c.known and c.correct),
        "wrong_box": v.wrong_box,
        "double_picks": v.double_picks,
        "double_picks_detected": v.double_picks_detected,
        "double_picks_noticed_after": v.double_picks_noticed_after,
        "wrong_lifts": v.wrong_lifts,
        "wrong_lifts_detected": v.wrong_lifts_detected,
        "false_alarms": v.false_alarms,
        "drops": v.drops,
        "drops_detected": v.drops_detected,
        # where the known cloths not in their box ended, and what the simulator flung
        "left_on_table": sum(1 for c in v.cloths if c.known and not c.correct and c.final == "table"),
        "on_floor": sum(1 for c in v.cloths if c.known and c.final == "floor"),
        "partly_in": sum(1 for c in v.cloths if c.known and c.final.startswith("partly in")),
        # in their box, heaped over its rim (the simulated cloth's thickness fills the box)
        "over_rim": sum(1 for c in v.cloths if c.known and c.correct and c.over_rim > 0),
        "flung": len(v.flung),
        "flung_not_in_box": sum(1 for c in v.cloths if c.number in v.flung and not c.correct),
        **double_pick_counts(episode),
        # lifts that brought up a cloth not held by the fingers, and of those, the ones whose
        # meshes crossed the held cloth's after the lift (and already at the grasp): the
        # simulator lets meshes pass through each other (`sim.mesh_crossing`)
        "dragged_lifts": sum(1 for lift in episode.lifts if set(lift.lifted) - set(lift.held)),
        "dragged_crossed": sum(1 for lift in episode.lifts if lift.crossed > 0),
        "dragged_crossed_at_grasp": sum(1 for lift in episode.lifts if lift.crossed_before > 0),
        "attempts": len(r.attempts),
        "surveys": len(r.surveys),
        "sim_time_s": r.sim_time,
        "sim_time_per_cloth_s": r.sim_time / max(known, 1),
        "attempt_time_per_placed_cloth_s": float(np.median(per_cloth)) if per_cloth else None,
        "survey_wall_s": float(sum(s.wall_s for s in r.surveys)),
        "wall_s": r.wall_s,
        "limit_violations": r.limit_report.violations,
        "commanded_samples": r.limit_report.samples,
        "collisions": r.collisions,
        # steps the free-slide guard (world.cloth.free_slide_speed) held a lying cloth back
        "slides_held": episode.slides_held,
        "phase_times": json.dumps({k: round(t, 2) for k, t in sorted(episode.phase_times.items())}),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    parser.add_argument("--episodes", type=int, default=50)
    parser.add_argument("--first", type=int, default=0, help="index of the first episode")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--out", default="results/bench_clear_table")
    parser.add_argument("--realism", choices=REALISM_NAMES, default="realistic")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    args = parser.parse_args()
    if args.episodes < 1 or args.workers < 1 or args.first < 0 or args.seed < 0:
        parser.error("--episodes and --workers must be >= 1, --first and --seed >= 0")
    fixed = (f"world.realism={args.realism}", *args.set)
    try:  # bad settings stop here, not as a crash in every episode
        load_config(ClearTableConfig, DEFAULT_CONFIG, [*fixed, *episode_overrides(args.first, args.seed)])
    except ConfigError as err:
        sys.exit(f"bench_clear_table: {err}")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    jobs = [(i, args.seed, fixed, str(out)) for i in range(args.first, args.first + args.episodes)]
    rows: list[dict[str, object]] = []
    start = time.perf_counter()
    # each episode the first world of a fresh process: it depends on its seed and settings only
    interrupted = False
    try:
        with fresh_process_pool(args.workers) as pool:
            for row in pool.imap_unordered(run_one, jobs):
                rows.append(row)
                done = len(rows)
                ok = sum(bool(r["cleared"]) for r in rows)
                print(
                    f"[{done}/{args.episodes}] episode {row['episode']}: "
                    f"{'cleared' if row['cleared'] else 'NOT cleared: ' + str(row.get('cause'))} "
                    f"- {ok}/{done} cleared",
                    flush=True,
                )
                _write_rows(out / "episodes.csv", rows)
    except KeyboardInterrupt:  # Ctrl-C: the episodes finished so far are summarised, not lost
        interrupted = True
        print(f"\ninterrupted: summary of the {len(rows)} episode(s) finished", file=sys.stderr, flush=True)
    if not rows:
        sys.exit(130)
    rows.sort(key=lambda r: int(r["episode"]))  # type: ignore[arg-type]
    _write_rows(out / "episodes.csv", rows)
    summary = _summary(rows, args, fixed, time.perf_counter() - start)
    summary["interrupted"] = interrupted
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    print(json.dumps(summary, indent=2))
    failed = [r for r in rows if not r["cleared"]]
    print(f"{len(failed)} episode(s) not cleared:")
    for r in failed:
        print(f"  episode {r['episode']} [{r['overrides']}] pile {r.get('pile')}: {r.get('cause')}")
    goals = summary["goals"]
    print("goals: " + "; ".join(f"{name}: {'PASS' if ok else 'MISS'}" for name, ok in goals.items()))
    if interrupted:
        sys.exit(130)


def _summary(
    rows: list[dict[str, object]], args: argparse.Namespace, fixed: tuple[str, ...], wall: float
) -> dict:
    finished = [r for r in rows if "wrong_box" in r]

    def total(key: str) -> int:
        return int(sum(int(r.get(key) or 0) for r in finished))

    per_cloth = np.array([r["sim_time_per_cloth_s"] for r in finished], dtype=float)
    attempt_time = np.array(
        [
            r["attempt_time_per_placed_cloth_s"]
            for r in finished
            if r["attempt_time_per_placed_cloth_s"] is not None
        ],
        dtype=float,
    )
    cleared = sum(bool(r["cleared"]) for r in rows)
    overlap = [r for r in finished if float(r["max_overlap"]) >= 0.2]  # type: ignore[arg-type]
    family = [r for r in finished if r["same_family"]]
    faulty = [r for r in rows if "faults." in str(r["overrides"])]
    summary = {
        "episodes": len(rows),
        "cleared": cleared,
        "cleared_rate": cleared / max(1, len(rows)),
        "cleared_without_made_mishaps": sum(bool(r["cleared"]) for r in rows if r not in faulty),
        "episodes_without_made_mishaps": len(rows) - len(faulty),
        "episodes_with_overlap_ge_20pct": len(overlap),
        "cleared_with_overlap_ge_20pct": sum(bool(r["cleared"]) for r in overlap),
        "episodes_with_same_family": len(family),
        "cleared_with_same_family": sum(bool(r["cleared"]) for r in family),
        "cloths": total("cloths"),
        "in_right_box": total("in_right_box"),
        "wrong_box": total("wrong_box"),
        "double_picks": total("double_picks"),
        "double_picks_detected": total("double_picks_detected"),
        # not at the lift, but by the next survey (an unidentified cloth moved by the pick)
        "double_picks_noticed_after": total("double_picks_noticed_after"),
        "wrong_lifts": total("wrong_lifts"),
        "wrong_lifts_detected": total("wrong_lifts_detected"),
        "false_alarms": total("false_alarms"),
        "double_named": total("double_named"),
        "double_named_right": total("double_named_right"),
        "double_named_wrong": total("double_named_wrong"),
        "double_both_placed": total("double_both_placed"),
        "double_put_back": total("double_put_back"),
        "dragged_lifts": total("dragged_lifts"),
        "dragged_crossed": total("dragged_crossed"),
        "dragged_crossed_at_grasp": total("dragged_crossed_at_grasp"),
        "drops": total("drops"),
        "drops_detected": total("drops_detected"),
        "left_on_table": total("left_on_table"),
        "on_floor": total("on_floor"),
        "partly_in": total("partly_in"),
        "in_their_box_over_the_rim": total("over_rim"),
        "cloths_flung_by_the_simulator": total("flung"),
        "flung_and_not_in_their_box": total("flung_not_in_box"),
        "episodes_with_a_fling": sum(1 for r in finished if r.get("flung")),
        "cleared_without_a_fling": sum(bool(r["cleared"]) for r in finished if not r.get("flung")),
        "slides_held": total("slides_held"),
        "episodes_with_slides_held": sum(1 for r in finished if r.get("slides_held")),
        "limit_violations": total("limit_violations"),
        "commanded_samples": total("commanded_samples"),
        "collisions": total("collisions"),
        "sim_time_per_cloth_s": {"median": float(np.median(per_cloth)), "worst": float(per_cloth.max())}
        if per_cloth.size
        else None,
        "attempt_time_per_placed_cloth_s": {"median": float(np.median(attempt_time))}
        if attempt_time.size
        else None,
        "sim_time_per_known_cloth_by_phase_s": _per_phase(finished),
        "crashed": sum(1 for r in rows if "wrong_box" not in r),
        "total_wall_s": wall,
        "workers": args.workers,
        "realism": args.realism,
        "settings": list(fixed),
    }
    summary["goals"] = {
        "cleared >= 95%": summary["cleared_rate"] >= 0.95,
        "0 cloths in a wrong box": summary["wrong_box"] == 0,
        "every double pick detected": summary["double_picks_detected"] == summary["double_picks"],
        "every drop detected": summary["drops_detected"] == summary["drops"],
        "median sim time per cloth <= 12 s": bool(per_cloth.size) and float(np.median(per_cloth)) <= 12.0,
        "0 limit violations": summary["limit_violations"] == 0,
        "0 collisions": summary["collisions"] == 0,
        "every failed episode has a cause": all(r.get("cause") for r in rows if not r["cleared"]),
    }
    return summary


def _per_phase(rows: list[dict[str, object]]) -> dict[str, float]:
    """Simulated time per known cloth in each phase over all `rows` [s], largest first."""
    totals: dict[str, float] = {}
    for r in rows:
        for phase, t in json.loads(str(r.get("phase_times") or "{}")).items():
            totals[phase] = totals.get(phase, 0.0) + float(t)
    known = max(1, sum(int(r["known_cloths"]) for r in rows))  # type: ignore[call-overload]
    return {k: round(t / known, 2) for k, t in sorted(totals.items(), key=lambda item: -item[1])}


def _write_rows(path: Path, rows: list[dict[str, object]]) -> None:
    with path.open("w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=sorted({k for r in rows for k in r}))
        writer.writeheader()
        writer.writerows(sorted(rows, key=lambda r: int(r["episode"])))  # type: ignore[arg-type]


if __name__ == "__main__":
    main()
