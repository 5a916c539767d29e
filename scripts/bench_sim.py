"""Measures the simulator per realism preset: capture and physics speed, settling and lifting,
and recognition of every catalogue cloth at the observation pose.

python scripts/bench_sim.py                          # speed per preset, then all 20 cloths (realistic)
python scripts/bench_sim.py --only speed             # the speed figures of clean, realistic, harsh
python scripts/bench_sim.py --only cloths --cloths 1 3 13 --realism harsh
python scripts/bench_sim.py --set cloth.damping_stiffness=0.3   # a world.yaml value changed

Speed: median wall and CPU time of one 320x240 stereo capture (render both cameras, the
key lamp's shadow map and shadows, and both camera models), and the wall time of one
simulated second of two cloths on the table with the arm under position control.
Cloths: the settle time and a 0.3 m lift of each cloth; then its station model recognised
in one capture at the observation pose against the simulator's truth (right camera frame).
Timings depend on the machine and its load; pin with `taskset -c 0` and repeat.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from robot_app.sim import CATALOGUE, REALISM_NAMES, World, cloth_spec, load_world_config
from robot_app.sim.checks import RecognitionCheck, lift_check, recognition_check
from robot_app.sim.cloth_visual import ClothLook
from robot_app.sim.realism import scene_defaults
from robot_app.sim.station import ModelStation

CAPTURE_GOAL_S = 0.100
PHYSICS_GOAL_S = 1.0


def bench_speed(realism: str, repeats: int, overrides: tuple[str, ...]) -> None:
    config = load_world_config(overrides=(f"realism={realism}", "cameras.image_size=[320, 240]", *overrides))
    defaults = scene_defaults(realism)
    rng = np.random.default_rng(0)
    with World(config) as world:
        world.reseed(0)
        looks = [ClothLook.draw(rng, cloth_spec(n).size, defaults["wrinkle_amplitude"], 0.0) for n in (11, 3)]
        large = world.add_cloth(cloth_spec(11), *config.range.centre_xy, 0.4, look=looks[0])  # most nodes
        small = world.add_cloth(cloth_spec(3), config.range.centre_xy[0] + 0.1, 0.15, 1.0, look=looks[1])
        target = world.transform_observation_camera_to_world.copy()
        target[2, 3] = config.table.top_z + 0.3  # the hand low enough for its shadow to be in view
        lowered = world.robot.solve_frame_ik("camera_right_optical", target, world.observation_joints)
        for label, joints in (("observation pose", world.observation_joints), ("hand 0.3 m up", lowered)):
            world.robot.reset_joints(joints)
            world.stereo.render()  # first capture: auto-exposure settles, caches warm
            times, cpu = [], []
            for _ in range(repeats):
                start, start_cpu = time.perf_counter(), time.process_time()
                world.stereo.render()
                times.append(time.perf_counter() - start)
                cpu.append(time.process_time() - start_cpu)
            median = float(np.median(times))
            print(
                f"[{realism}] 320x240 stereo capture at the {label} (render + shadows + imaging): "
                f"median {median * 1000:.1f} ms wall ({np.median(cpu) * 1000:.1f} ms CPU), "
                f"min {np.min(times) * 1000:.1f} ms over {repeats} (goal <= {CAPTURE_GOAL_S * 1000:.0f} ms: "
                f"{'PASS' if median <= CAPTURE_GOAL_S else 'MISS'})",
                flush=True,
            )
        world.robot.reset_joints(world.observation_joints)
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
                f"[{realism}] physics, {label} on the table + arm under position control: 1 simulated s "
                f"({steps} steps at {1 / world.dt:.0f} Hz) took {wall:.2f} s wall ({cpu_s:.2f} s CPU) "
                f"(goal <= {PHYSICS_GOAL_S:.0f} s: {'PASS' if wall <= PHYSICS_GOAL_S else 'MISS'})",
                flush=True,
            )


def bench_cloths(
    realism: str, numbers: list[int], recognise: bool, lift: bool, seed: int, overrides: tuple[str, ...]
) -> None:
    config = load_world_config(overrides=(f"realism={realism}", *overrides))
    print(f"[{realism}] per cloth, {config.cameras.image_size[0]}x{config.cameras.image_size[1]} cameras:")
    print(
        "No. nodes settle_s lift_stretch lifted_m | found fitness  dx_mm  dy_mm  dz_mm "
        "dyaw_deg dtilt_deg  time_s"
    )
    station = ModelStation.for_world(config) if recognise else None
    checks: list[RecognitionCheck] = []
    try:
        for number in numbers:
            spec = cloth_spec(number)
            line = f"{number:3d}"
            if lift:
                with World(config) as world:
                    cloth = world.add_cloth(
                        spec, *config.range.centre_xy, 0.5, drop_height=0.03, settle=False
                    )
                    settle = world.settle([cloth])
                    result = lift_check(world, cloth)
                line += (
                    f" {len(cloth.mesh.vertices):5d} {settle:8.2f} {result.max_stretch:12.3f} "
                    f"{result.lifted:8.3f}"
                )
            else:
                line += " " * 36
            if station is not None:
                r = recognition_check(spec, config, seed=seed + number, station=station)
                checks.append(r)
                line += (
                    f" | {r.found!s:5} {r.fitness:7.3f} {r.error_x_mm:6.2f} {r.error_y_mm:6.2f} "
                    f"{r.error_z_mm:6.2f} {r.error_yaw_deg:8.2f} {r.error_tilt_deg:9.2f} {r.time_s:7.2f}"
                )
            print(line, flush=True)
    finally:
        if station is not None:
            station.close()
    if checks:
        position = np.array([np.hypot(r.error_x_mm, r.error_y_mm) for r in checks])
        yaw = np.array([abs(r.error_yaw_deg) for r in checks])
        good = [
            r.number
            for r in checks
            if r.found and np.hypot(r.error_x_mm, r.error_y_mm) <= 10 and abs(r.error_yaw_deg) <= 10
        ]
        print(
            f"[{realism}] {sum(r.found for r in checks)}/{len(checks)} found; "
            f"{len(good)}/{len(checks)} found within 10 mm and 10 deg; "
            f"position error median {np.median(position):.1f} mm (worst {position.max():.1f}), "
            f"yaw error median {np.median(yaw):.1f} deg (worst {yaw.max():.1f}); "
            f"missed or off: {[r.number for r in checks if r.number not in good]}"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    parser.add_argument("--only", choices=("speed", "cloths"), default=None)
    parser.add_argument("--cloths", type=int, nargs="*", default=[s.number for s in CATALOGUE])
    parser.add_argument(
        "--realism",
        nargs="*",
        choices=REALISM_NAMES,
        default=None,
        help="presets (default: all three for speed, realistic for the cloths)",
    )
    parser.add_argument("--no-recognition", action="store_true")
    parser.add_argument("--lift", action="store_true", help="also settle and lift every cloth")
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
        for realism in args.realism or REALISM_NAMES:
            bench_speed(realism, args.repeats, overrides)
    if args.only in (None, "cloths"):
        for realism in args.realism or ("realistic",):
            bench_cloths(realism, args.cloths, not args.no_recognition, args.lift, args.seed, overrides)


if __name__ == "__main__":
    main()
