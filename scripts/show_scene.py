"""Writes PNGs of the simulated cell: overview, hand stereo pair, the 20 cloths side by side.

python scripts/show_scene.py --out out/sim_pictures [--realism harsh] [--seed 3] [--target 3] [--occluder]
                             [--distractor 4]
"""

from __future__ import annotations

import argparse

from robot_app.sim import REALISM_NAMES, SceneSettings, load_world_config
from robot_app.sim.pictures import write_pictures


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    parser.add_argument("--out", default="out/sim_pictures")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--target", type=int, default=3)
    parser.add_argument("--occluder", action="store_true")
    parser.add_argument("--distractor", type=int, default=None)
    parser.add_argument("--drop-height", type=float, default=0.0)
    parser.add_argument("--realism", choices=REALISM_NAMES, default="realistic")
    args = parser.parse_args()
    scene = SceneSettings(
        target=args.target, occluder=args.occluder, distractor=args.distractor, drop_height=args.drop_height
    )
    world = load_world_config(overrides=(f"realism={args.realism}",))
    for path in write_pictures(args.out, world, scene, args.seed):
        print(path)


if __name__ == "__main__":
    main()
