"""Pile physics check: lift from a pile and put back, per seed; counts soft-body blow-ups.

    python scripts/pile_physics.py [--seeds 12 13 14] [--count 4 5] [--lay-out M] [--set key=value ...]

Each seed lays a pile as the clear-table job does (configs/clear_table.yaml's world and
pile settings, overlap >= 20 %, `--count` cloths), then `sim.checks.pile_trial` grips the top
cloth where it lies on another (anchoring every cloth's nodes in the grasp radius, as
the job's grasp does, so double picks happen), lifts it to 0.40 m, lowers it again to
0.05 m, lets go and lets the pile settle. A blow-up: a node faster than 5 m/s, a node
more than 20 mm inside the table, an edge still 1.5x its rest length after settling,
or a cloth off the table. Compare settings with `--set world.cloth.substeps=1`.

`--alone S` then leaves the pile alone for S more seconds (the arm away) and prints how far
each cloth's mean node moved on the table [mm] and its deepest node's depth in the table
[mm] (negative: above it): a put-back heap that slides by itself (the simulator artefact
docs/history.md describes) shows as a cloth moving hundreds of mm. Each seed runs in a fresh
process (`sim.fresh_process`), so its line does not depend on the seeds before it.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from robot_app.config import load_config
from robot_app.errors import ConfigError
from robot_app.experiments.clear_table import ClearTableConfig
from robot_app.sim import World
from robot_app.sim.checks import PileTrialResult, PileTrialSettings, pile_trial
from robot_app.sim.fresh_process import fresh_process_pool
from robot_app.sim.pile import make_pile

DEFAULT_CONFIG = Path(__file__).resolve().parents[1] / "configs" / "clear_table.yaml"


def one_seed(
    job: tuple[int, tuple[int, int], str, tuple[str, ...], float, float],
) -> tuple[str, PileTrialResult]:
    """The trial of one seed (run in a fresh process): its printed line and its result."""
    seed, count, config_path, settings, lay_out, alone_s = job
    overrides = [
        f"seed={seed}",
        f"pile.count=[{count[0]},{count[1]}]",
        "pile.overlap=overlap",
        "pile.min_overlap=0.2",
        *settings,
    ]
    config = load_config(ClearTableConfig, Path(config_path), overrides)
    start = time.perf_counter()
    with World(config.world) as world:
        pile = make_pile(world, config.pile, seed=seed)
        result = pile_trial(world, pile, PileTrialSettings(lay_out=lay_out))
        alone = ""
        if alone_s > 0:
            before = [cloth.body.nodes() for cloth in pile.cloths]
            for _ in range(round(alone_s / world.dt)):
                world.step()
            after = [cloth.body.nodes() for cloth in pile.cloths]
            top = world.config.table.top_z
            moved = [
                float(np.hypot(*(a.mean(axis=0) - b.mean(axis=0))[:2])) * 1000
                for a, b in zip(after, before, strict=True)
            ]
            depth = [(top - float(a[:, 2].min())) * 1000 for a in after]
            shown = f"moved mm {[round(m) for m in moved]}, depth mm {[round(d) for d in depth]}"
            alone = f" | {alone_s:g} s alone: {shown}"
    return f"seed {seed}: {result.line()}{alone}  [{time.perf_counter() - start:.0f} s wall]", result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    parser.add_argument("--seeds", type=int, nargs="+", default=[3, 12, 13, 14])
    parser.add_argument("--count", type=int, nargs=2, default=(4, 5), metavar=("FEWEST", "MOST"))
    parser.add_argument("--config", default=str(DEFAULT_CONFIG))
    parser.add_argument("--workers", type=int, default=1, help="processes (each seed in a fresh one)")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument(
        "--lay-out", type=float, default=0.0, metavar="M", help="put down laid out over M metres (0: slid)"
    )
    parser.add_argument(
        "--alone",
        type=float,
        default=0.0,
        metavar="S",
        help="then leave the pile alone S s, print each cloth's slide",
    )
    args = parser.parse_args()
    if args.workers < 1:
        parser.error(f"--workers must be >= 1, got {args.workers}")
    if args.alone < 0:
        parser.error(f"--alone must be >= 0 s, got {args.alone}")
    try:  # bad settings stop here, before any process starts
        load_config(
            ClearTableConfig, Path(args.config), [f"pile.count=[{args.count[0]},{args.count[1]}]", *args.set]
        )
    except ConfigError as err:
        sys.exit(f"pile_physics: {err}")
    jobs = [
        (seed, tuple(args.count), args.config, tuple(args.set), args.lay_out, args.alone)
        for seed in args.seeds
    ]
    blown = dragged = crossed = 0
    with fresh_process_pool(args.workers) as pool:  # each seed the first world of its process: repeatable
        for line, result in pool.imap(one_seed, jobs):
            blown += result.blew_up
            dragged += bool(result.dragged)
            crossed += result.crossed_lifted > 0
            print(line, flush=True)
    shown = " ".join([*args.set, *([f"--lay-out {args.lay_out}"] if args.lay_out else [])]) or "config"
    print(f"blow-ups: {blown} of {len(args.seeds)} (settings: {shown})")
    print(
        f"lifts that brought a cloth up unheld: {dragged} of {len(args.seeds)}; "
        f"lifts with a held cloth's mesh crossed with another's at the top: {crossed} of {len(args.seeds)}"
    )


if __name__ == "__main__":
    main()
