"""Does a put-back heap left alone stay where it lies? Reloads traced heaps and watches them.

    python scripts/heap_replay.py [--rest 6] [--set key=value ...]

scripts/data/heap_episode9.npz holds every cloth's nodes (simulator truth) of bench episode 9
(`scripts/bench_clear_table.py --first 9 --episodes 1 --set loop.vision_latency=0.06`, main
0bae771) at four moments when no cloth was held and the arm was 0.3-0.48 m up. No.9 lay on No.2 in
a heap whose layers crossed (a put-back of both), No.13 apart. In that run the heap slid off the
table's edge by itself (the cloths judged "floor"). Each snapshot is laid into a fresh cell of
that episode (`ClothBody.set_nodes`, nodes at rest) and left alone for `--rest` s. A heap that
moves its centre more than 20 mm, or a node more than 5 mm into the table, slid. Nothing
touches the cloths, so every slide is the simulator's doing (a pybullet soft-soft contact that
pushes a crossed node to the wrong side; docs/history.md). Compare physics settings with
`--set world.cloth.substeps=8` etc. Each moment runs in a fresh process (`sim.fresh_process`).
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
from robot_app.sim.fresh_process import fresh_process_pool
from robot_app.sim.pile import make_pile

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "scripts" / "data" / "heap_episode9.npz"
EPISODE = [  # bench_clear_table.episode_overrides(9, 1)
    "seed=100009",
    "pile.count=[3,5]",
    "pile.overlap=overlap",
    "pile.min_overlap=0.2",
    "faults.double_grasps=[1]",
]


def replay(job: tuple[str, float, tuple[str, ...]]) -> tuple[str, bool]:
    """One stored moment laid into a fresh cell and left alone (run in a fresh process):
    its printed line and whether the heap slid."""
    moment, rest, settings = job
    data = np.load(DATA)
    config = load_config(ClearTableConfig, ROOT / "configs" / "clear_table.yaml", [*EPISODE, *settings])
    start = time.perf_counter()
    with World(config.world) as world:
        pile = make_pile(world, config.pile, seed=config.seed)
        for cloth in pile.cloths:
            cloth.body.set_nodes(data[f"{moment}_No{cloth.number}"])
        top = world.config.table.top_z
        centres = [c.body.nodes().mean(axis=0) for c in pile.cloths]
        before = [c.body.nodes() for c in pile.cloths]
        depth, speed = -np.inf, 0.0
        for _ in range(round(rest / world.dt)):
            world.step()
            now = [c.body.nodes() for c in pile.cloths]
            for current, last in zip(now, before, strict=True):
                depth = max(depth, top - float(current[:, 2].min()))
                speed = max(speed, float(np.linalg.norm(current - last, axis=1).max()) / world.dt)
            before = now
        moved = {
            c.number: float(np.hypot(*(c.body.nodes().mean(axis=0) - centre)[:2]))
            for c, centre in zip(pile.cloths, centres, strict=True)
        }
    bad = depth > 0.005 or max(moved.values()) > 0.02
    shown = ", ".join(f"No.{n} {m * 1000:.0f} mm" for n, m in moved.items())
    line = (
        f"t = {float(moment[1:]):.2f} s: moved {shown}; deepest node {depth * 1000:+.1f} mm "
        f"into the table, fastest {speed:.2f} m/s: {'SLID' if bad else 'still'}  "
        f"[{time.perf_counter() - start:.0f} s wall]"
    )
    return line, bad


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    parser.add_argument("--rest", type=float, default=6.0, help="simulated seconds left alone")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    args = parser.parse_args()
    if not args.rest > 0:
        parser.error(f"--rest must be > 0 s, got {args.rest}")
    data = np.load(DATA)
    times = sorted({key.split("_")[0] for key in data.files}, key=lambda t: float(t[1:]))
    try:  # bad settings stop here, before any process starts
        load_config(ClearTableConfig, ROOT / "configs" / "clear_table.yaml", [*EPISODE, *args.set])
    except ConfigError as err:
        sys.exit(f"heap_replay: {err}")
    slid = 0
    with fresh_process_pool(1) as pool:  # each moment the first world of its process: repeatable
        for line, bad in pool.imap(replay, [(moment, args.rest, tuple(args.set)) for moment in times]):
            slid += bad
            print(line, flush=True)
    print(f"slid: {slid} of {len(times)} (settings: {' '.join(args.set) or 'config'})")


if __name__ == "__main__":
    main()
