"""Identification in piles: the clear-table job's first survey of each bench episode, judged
against where the cloths truly lie.

    python scripts/bench_survey.py [--first 0] [--episodes 30] [--workers 2]
                                   [--out results/bench_survey] [--set key=value ...]

The episodes are bench_clear_table.py's (same index, same pile, same realistic cell); only
the first survey is made, from the observation pose, as the job makes it (its settings,
its models of the whole catalogue, the boxes taken out of the unknown regions). Each
detection is judged by the simulator's truth:
- *right*: its name is a cloth of the pile and its pose lies within `--near` (30 mm) of
  that cloth's centre on the table;
- *misplaced*: a cloth of the pile, farther than that (the search ended elsewhere);
- *wrong name*: no cloth of that name lies on the table (the dangerous one: picked, it
  would be booked and sorted as what it is not; the load cell and the box check after the
  pick are all that stand in the way).
Each is split into found (the recogniser's own decision) and candidate (kept below the
threshold: the pick loop searches again). A pile cloth no right detection names is
*missed* (hidden under others, or not recognised); each cloth's share in view (its pixels in
the true right camera, by pybullet's segmentation, over its flat outline's) is printed
beside its name, and the cloths at least half in view (*seen*) are counted apart. The
figures are what the job starts from; the pile changes after every pick, so they are not
the job's whole identification.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from robot_app.config import load_config
from robot_app.errors import InputError
from robot_app.experiments.clear_table import ClearTableConfig, first_survey
from robot_app.outputs import atomic_write_csv, atomic_write_text, check_output_folder
from robot_app.sim.fresh_process import fresh_process_pool
from robot_app.sim.realism import REALISM_NAMES

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_clear_table import DEFAULT_CONFIG, episode_overrides

KINDS = ("right", "misplaced", "wrong_name")
SEEN = 0.5  # a cloth the camera truly sees this share of (of its flat outline) is "seen"
COLUMNS = (
    "episode", "overrides", "pile", "cloths", "seen", "seen_right", "same_family", "max_overlap",
    "detections", "missed",
    *(f"{k}_{s}" for k in KINDS for s in ("found", "candidate")),
    "unknown_regions", "recognitions", "searched_again", "wall_s", "crashed",
)  # fmt: skip


def run_one(job: tuple[int, int, tuple[str, ...], float]) -> dict[str, object]:
    index, base_seed, fixed, near = job
    overrides = episode_overrides(index, base_seed)
    row: dict[str, object] = {"episode": index, "overrides": " ".join(overrides)}
    try:
        config = load_config(ClearTableConfig, DEFAULT_CONFIG, [*fixed, *overrides])
        wall = time.perf_counter()
        survey = first_survey(config)
        wall = time.perf_counter() - wall
    except Exception as err:  # a crashed episode is a failed row, the sweep goes on
        return row | {"crashed": f"{type(err).__name__}: {err}"}
    ident, truth = survey.identification, survey.truth
    row |= {f"{k}_{s}": 0 for k in KINDS for s in ("found", "candidate")}
    judged = []
    right_names = set()
    for d in ident.detections:
        pose = survey.transform_camera_to_world @ d.transform_model_to_camera
        kind = "wrong_name"
        error = float("nan")
        if d.name in truth:
            error = float(np.linalg.norm(pose[:2, 3] - truth[d.name][:2, 3]))
            kind = "right" if error <= near else "misplaced"
        if kind == "right":
            right_names.add(d.name)
        state = "found" if d.found else "candidate"
        judged.append(f"{d.name}:{kind}/{state}:{d.confidence:.2f}:{error * 1000:.0f}mm")
        row[f"{kind}_{state}"] = int(row.get(f"{kind}_{state}", 0)) + 1  # type: ignore[call-overload]
    missed = [name for name in truth if name not in right_names]
    seen = [name for name in truth if survey.visible[name] >= SEEN]
    return row | {
        "pile": " ".join(f"{name}({survey.visible[name]:.0%})" for name in truth),
        "cloths": len(truth),
        "seen": len(seen),
        "seen_right": sum(1 for name in seen if name in right_names),
        "same_family": survey.same_family,
        "max_overlap": round(survey.max_overlap, 3),
        "detections": " ".join(judged),
        "missed": " ".join(f"{name}({survey.visible[name]:.0%})" for name in missed),
        "unknown_regions": len(ident.unknown),
        "recognitions": len(ident.recognitions) + len(ident.searched_again),
        "searched_again": " ".join(ident.searched_again),
        "wall_s": round(wall, 2),
    }


def summary_of(rows: list[dict[str, object]], fixed: tuple[str, ...]) -> dict[str, object]:
    done = [r for r in rows if "crashed" not in r]

    def total(key: str) -> int:
        return int(sum(int(r.get(key) or 0) for r in done))  # type: ignore[call-overload]

    cloths = total("cloths")
    counts = {f"{k}_{s}": total(f"{k}_{s}") for k in KINDS for s in ("found", "candidate")}
    right = counts["right_found"] + counts["right_candidate"]
    missed: dict[str, int] = {}
    for r in done:
        for name in str(r["missed"]).split():
            number = name.split("(")[0]
            missed[number] = missed.get(number, 0) + 1
    return {
        "episodes": len(rows),
        "crashed": len(rows) - len(done),
        "cloths": cloths,
        "identified_right": right,
        "identified_right_rate": right / max(cloths, 1),
        "seen": total("seen"),
        "seen_identified_right": total("seen_right"),
        "seen_identified_right_rate": total("seen_right") / max(total("seen"), 1),
        **counts,
        "wrong_name": counts["wrong_name_found"] + counts["wrong_name_candidate"],
        "episodes_with_a_wrong_name": sum(
            1 for r in done if r.get("wrong_name_found") or r.get("wrong_name_candidate")
        ),
        "missed_by_cloth": dict(sorted(missed.items(), key=lambda item: (-item[1], item[0]))),
        "recognitions_per_survey": float(np.mean([int(r["recognitions"]) for r in done])) if done else None,  # type: ignore[call-overload]
        "settings": list(fixed),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    parser.add_argument("--episodes", type=int, default=30)
    parser.add_argument("--first", type=int, default=0, help="index of the first episode")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--near", type=float, default=0.03, help="a right detection lies this near [m]")
    parser.add_argument("--out", default="results/bench_survey")
    parser.add_argument("--force", action="store_true", help="replace an --out folder's results")
    parser.add_argument("--realism", choices=REALISM_NAMES, default="realistic")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    args = parser.parse_args()
    if args.episodes < 1 or args.workers < 1 or args.first < 0 or args.seed < 0 or args.near <= 0:
        parser.error("--episodes and --workers must be >= 1, --first and --seed >= 0, --near > 0")
    fixed = (f"world.realism={args.realism}", *args.set)
    try:  # bad settings and a bad --out stop here, before any episode
        load_config(ClearTableConfig, DEFAULT_CONFIG, [*fixed, *episode_overrides(args.first, args.seed)])
        out = check_output_folder(args.out, key="--out", force=args.force)
    except InputError as err:
        sys.exit(f"bench_survey: {err}")
    out.mkdir(parents=True, exist_ok=True)
    jobs = [(i, args.seed, fixed, args.near) for i in range(args.first, args.first + args.episodes)]
    rows: list[dict[str, object]] = []
    with fresh_process_pool(args.workers) as pool:
        for row in pool.imap_unordered(run_one, jobs):
            rows.append(row)
            rows.sort(key=lambda r: int(r["episode"]))  # type: ignore[call-overload]
            print(
                f"[{len(rows)}/{args.episodes}] episode {row['episode']} pile {row.get('pile')}: "
                f"{row.get('detections', row.get('crashed'))}; missed {row.get('missed', '')}",
                flush=True,
            )
            atomic_write_csv(out / "episodes.csv", [{c: r.get(c, "") for c in COLUMNS} for r in rows])
    summary = summary_of(rows, fixed)
    atomic_write_text(out / "summary.json", json.dumps(summary, indent=2))
    print(json.dumps(summary, indent=2))


if __name__ == "__main__":
    main()
