"""Do released cloths land inside their box? Lays piles and puts all of each into one box.

    python scripts/bench_release.py [--seeds 1 2 3] [--count 3 4] [--box colours] [--edge 0.1]
                                    [--pairs] [--workers 2] [--set key=value ...]

Each seed lays a pile as the clear-table job does (configs/clear_table.yaml's world and pile
settings, `--count` cloths), then `experiments.clear_table.release_trial` picks its cloths
one after another at a node drawn anywhere on them clear of the others (`--edge 0.1`: among
the tenth farthest from the cloth's centre; there a cloth hangs up to twice as long as from
its middle; `--pairs`: where it lies on another, so that the fingers hold both, a double
pick that goes into the box as one load), and lays each into `--box` with the
job's own transfer and release and the job's check after it (`TableClearer.check_box`: the
heap measured for the next release; a cloth seen over a wall's rim laid again,
`clear.rim_tries`; `--set clear.rim_tries=0` measures the release alone).
After the last release every cloth is judged as the bench judges it: in the box (90 % of
its nodes inside the walls), partly in, table or floor. No recognition and no grasp
planning: the release alone is measured, and compared between settings with `--set
loop.release_fold=0.5` etc. Each seed runs in a fresh process (`sim.fresh_process`), so its
lines do not depend on the seeds before it.

Prints one line per cloth and a summary: cloths wholly in the box, partly in, elsewhere, by
their place in the box's order (the first into an empty box, the second onto one cloth, ...),
the median release time, how often a cloth was seen over a wall and laid again.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from robot_app.config import load_config
from robot_app.errors import ConfigError, SimulationError
from robot_app.experiments.clear_table import ClearTableConfig, ReleasedCloth, release_trial
from robot_app.sim.fresh_process import fresh_process_pool

DEFAULT_CONFIG = Path(__file__).resolve().parents[1] / "configs" / "clear_table.yaml"


def one_seed(
    job: tuple[int, tuple[int, int], str, str, tuple[str, ...]],
) -> tuple[int, str, tuple[ReleasedCloth, ...]]:
    """The trial of one seed (run in a fresh process): the seed, a note, the cloths."""
    seed, count, config_path, box, edge, pairs, settings = job
    overrides = [f"seed={seed}", f"pile.count=[{count[0]},{count[1]}]", *settings]
    config = load_config(ClearTableConfig, Path(config_path), overrides)
    start = time.perf_counter()
    try:
        cloths = release_trial(config, box, edge, pairs)
    except SimulationError as err:
        return seed, f"no trial: {err}", ()
    return seed, f"{time.perf_counter() - start:.0f} s wall", cloths


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    parser.add_argument("--seeds", type=int, nargs="+", default=list(range(1, 11)))
    parser.add_argument("--count", type=int, nargs=2, default=(3, 4), metavar=("FEWEST", "MOST"))
    parser.add_argument("--box", default="colours", help="the box every cloth goes into")
    parser.add_argument(
        "--edge", type=float, default=1.0, help="grasp among this share of nodes farthest from the centre"
    )
    parser.add_argument(
        "--pairs", action="store_true", help="grasp where a cloth lies on another: both lifted"
    )
    parser.add_argument("--config", default=str(DEFAULT_CONFIG))
    parser.add_argument("--workers", type=int, default=1, help="processes (each seed in a fresh one)")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    args = parser.parse_args()
    if args.workers < 1:
        parser.error(f"--workers must be >= 1, got {args.workers}")
    if not 0.0 < args.edge <= 1.0:
        parser.error(f"--edge must be in (0, 1], got {args.edge}")
    try:  # bad settings stop here, before any process starts
        config = load_config(
            ClearTableConfig, Path(args.config), [f"pile.count=[{args.count[0]},{args.count[1]}]", *args.set]
        )
    except ConfigError as err:
        sys.exit(f"bench_release: {err}")
    boxes = [b.name for b in config.world.all_boxes]
    if args.box not in boxes:
        sys.exit(f"bench_release: no box {args.box!r} in the cell (boxes: {', '.join(boxes)})")
    jobs = [
        (seed, tuple(args.count), args.config, args.box, args.edge, args.pairs, tuple(args.set))
        for seed in args.seeds
    ]
    by_order: dict[int, list[str]] = {}
    times: list[float] = []
    outside: list[float] = []
    along: list[bool] = []
    laid: list[str] = []
    with fresh_process_pool(args.workers) as pool:  # each seed the first world of its process: repeatable
        for seed, note, cloths in pool.imap(one_seed, jobs):
            print(f"seed {seed}: {note}", flush=True)
            for k, c in enumerate(cloths):
                by_order.setdefault(k, []).append(c.place)
                times.append(c.release_s)
                outside.append(c.outside)
                along.append(c.came_along)
                if c.laid_again and not c.came_along:
                    laid.append(c.laid_again)
                rim = f" ({c.over_rim:.0%} over the rim)" if c.over_rim > 0 else ""
                tag = " (came along)" if c.came_along else ""
                print(
                    f"  {k + 1}. {c.name}{tag}: {c.place}{rim}, {c.outside:.0%} outside the walls; "
                    f"hung {c.reach * 1000:.0f} mm, "
                    f"held {c.off_centre * 1000:.0f} mm off its centre, heap {c.heap * 1000:.0f} mm, "
                    f"release {c.release_s:.2f} s" + (f"; {c.laid_again}" if c.laid_again else ""),
                    flush=True,
                )
    placed = [p for places in by_order.values() for p in places]
    shown = " ".join(args.set) or "config"
    where = "on another cloth" if args.pairs else "clear of the others"
    print(
        f"settings: {shown}; box {args.box}; grasps {where}, among the {args.edge:.0%} of nodes farthest out"
    )
    for k, places in sorted(by_order.items()):
        inside = sum(p == args.box for p in places)
        partly = sum(p.startswith("partly in") for p in places)
        print(f"  {k + 1}. into the box: {inside} of {len(places)} in it, {partly} partly in")
    inside = sum(p == args.box for p in placed)
    partly = sum(p.startswith("partly in") for p in placed)
    elsewhere = len(placed) - inside - partly
    print(
        f"in the box {inside} of {len(placed)}, partly in {partly}, elsewhere {elsewhere}; "
        f"nodes outside the walls: mean {float(np.mean(outside)) if outside else 0.0:.1%}, "
        f"cloths with any {sum(o > 0 for o in outside)}; came along {sum(along)}; "
        f"a cloth seen over a wall after {len(laid)} releases, laid again after "
        f"{sum('laid again' in n for n in laid)}; "
        f"median release {float(np.median(times)) if times else float('nan'):.2f} s"
    )


if __name__ == "__main__":
    main()
