"""Measures the simulator: render and physics speed, settling, lifting and recognition per cloth.

python scripts/bench_sim.py                 # everything (several minutes)
python scripts/bench_sim.py --only speed    # just the two speed figures
python scripts/bench_sim.py --cloths 1 3 7  # a subset of the catalogue
python scripts/bench_sim.py --set cloth.damping_stiffness=0.3  # a world.yaml value changed
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from robot_app.sim import CATALOGUE, World, cloth_spec, load_world_config
from robot_app.sim.checks import lift_check, recognition_check
from robot_app.sim.station import ModelStation


def bench_speed(repeats: int, overrides: tuple[str, ...]) -> None:
    config = load_world_config(overrides=("cameras.image_size=[320, 240]", *overrides))
    with World(config) as world:
        large = world.add_cloth(cloth_spec(11), *config.range.centre_xy, 0.4)  # the most nodes
        small = world.add_cloth(cloth_spec(3), config.range.centre_xy[0] + 0.1, 0.15, 1.0)
        times, cpu = [], []
        for _ in range(repeats):
            start, start_cpu = time.perf_counter(), time.process_time()
            world.stereo.render()
            times.append(time.perf_counter() - start)
            cpu.append(time.process_time() - start_cpu)
        print(
            f"render 320x240 stereo pair: median {np.median(times) * 1000:.1f} ms wall "
            f"({np.median(cpu) * 1000:.1f} ms CPU), min {np.min(times) * 1000:.1f} ms over {repeats} "
            "(target <= 80 ms)"
        )
        steps = round(1.0 / world.dt)
        nodes = (len(large.mesh.vertices), len(small.mesh.vertices))
        cases = ((f"two cloths ({nodes[0]} + {nodes[1]} nodes)", 2), (f"one cloth ({nodes[0]} nodes)", 1))
        for label, n_cloths in cases:
            while len(world.cloths) > n_cloths:
                world.remove_body(world.cloths[-1])
            start, start_cpu = time.perf_counter(), time.process_time()
            world.step(steps)
            wall, cpu_s = time.perf_counter() - start, time.process_time() - start_cpu
            print(
                f"physics, {label} on the table + arm under position control: 1 simulated s "
                f"({steps} steps at {1 / world.dt:.0f} Hz) took {wall:.2f} s wall ({cpu_s:.2f} s CPU) "
                "(target <= 1 s)"
            )


def bench_cloths(numbers: list[int], recognise: bool, seed: int, overrides: tuple[str, ...]) -> None:
    config = load_world_config(overrides=overrides)
    print(
        "No. nodes settle_s lift_stretch lifted_m | found fitness  dx_mm  dy_mm  dz_mm "
        "dyaw_deg dtilt_deg  time_s"
    )
    station = ModelStation(config.station, config.cloth, config.range.sheet_rgb) if recognise else None
    try:
        for number in numbers:
            spec = cloth_spec(number)
            with World(config) as world:
                cloth = world.add_cloth(spec, *config.range.centre_xy, 0.5, drop_height=0.03, settle=False)
                settle = world.settle([cloth])
                lift = lift_check(world, cloth)
            line = (
                f"{number:3d} {len(cloth.mesh.vertices):5d} {settle:8.2f} {lift.max_stretch:12.3f} "
                f"{lift.lifted:8.3f}"
            )
            if station is not None:
                r = recognition_check(spec, config, seed=seed + number, station=station)
                line += (
                    f" | {r.found!s:5} {r.fitness:7.3f} {r.error_x_mm:6.2f} {r.error_y_mm:6.2f} "
                    f"{r.error_z_mm:6.2f} {r.error_yaw_deg:8.2f} {r.error_tilt_deg:9.2f} {r.time_s:7.2f}"
                )
            print(line, flush=True)
    finally:
        if station is not None:
            station.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    parser.add_argument("--only", choices=("speed", "cloths"), default=None)
    parser.add_argument("--cloths", type=int, nargs="*", default=[s.number for s in CATALOGUE])
    parser.add_argument("--no-recognition", action="store_true")
    parser.add_argument("--repeats", type=int, default=20)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--set",
        dest="overrides",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override a world.yaml value (repeatable)",
    )
    args = parser.parse_args()
    overrides = tuple(args.overrides)
    if args.only in (None, "speed"):
        bench_speed(args.repeats, overrides)
    if args.only in (None, "cloths"):
        bench_cloths(args.cloths, not args.no_recognition, args.seed, overrides)


if __name__ == "__main__":
    main()
