"""Regenerates the calibrated rig files of the realistic preset by the whole procedure.

    python scripts/make_calibrated_rigs.py [--size 320x240] [--views 40] [--seed 0] [--keep DIR]

For each camera size (default: both, 320x240 and 640x480) it runs, exactly as a user
would on a real rig (the simulated cell standing in for the robot):

    robot-app sim calibration-views --out V --views 40 --seed 0 --set "cameras.image_size=[W,H]"
    robot-app calibrate stereo --images V --board V/board.yaml --out R
    robot-app calibrate hand-eye --images V --robot-poses V/robot_poses.csv --rig R --board V/board.yaml

(the world config's default preset, `realistic`: its camera model's noise, vignetting,
exposure and JPEG are in the board images; `calibrate` divides out the flat field it
finds in V/flat_field/), then writes R with a header naming these commands to
configs/rig_calibrated_<W>x<H>.yaml. The seed is 0 because it was 0 before the flat
field existed: the seed is not chosen by the result. Errors against the URDF:
`python scripts/bench_calibration.py --skip accuracy --skip sensitivity --episodes 0`
prints nothing useful; use `rig_file_errors` via bench_calibration's pick-place stage or
this script's own printout (it prints each file's errors against the URDF rig).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import textwrap
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_calibration import rig_file_errors

from robot_app.cli import main as robot_app
from robot_app.outputs import atomic_write_text

CONFIGS = Path(__file__).resolve().parents[1] / "configs"
SIZES = ("320x240", "640x480")


def header(size: str, views: int, seed: int, errors: str) -> str:
    w, h = size.split("x")
    name = f"configs/rig_calibrated_{size}.yaml"
    lines = [
        "The hand stereo rig as the simulated calibration measured it through the realistic",
        f"camera model (vignetting, shading, noise, JPEG), for {size} cameras: what",
        "world.realism=realistic|harsh give the recogniser and the loop (world.cameras.rig_file).",
        f"Made by scripts/make_calibrated_rigs.py --size {size} --views {views} --seed {seed}, i.e.",
        f"  robot-app sim calibration-views --out V --views {views} --seed {seed} \\",
        f'      --set "cameras.image_size=[{w},{h}]"',
        f"  robot-app calibrate stereo --images V --board V/board.yaml --out {name}",
        "  robot-app calibrate hand-eye --images V --robot-poses V/robot_poses.csv \\",
        f"      --rig {name} --board V/board.yaml",
        "(calibrate divides out the flat field of V/flat_field/, written by calibration-views).",
        "Its errors against the URDF rig (% of the focal lengths, mm, deg):",
        *textwrap.wrap(errors, 86, initial_indent="  ", subsequent_indent="  "),
    ]
    return "".join(f"# {line}\n" for line in lines)


def make(size: str, views: int, seed: int, work: Path) -> Path:
    w, h = size.split("x")
    folder, rig = work / f"views_{size}", work / f"rig_{size}.yaml"
    steps = [
        ["sim", "calibration-views", "--out", str(folder), "--views", str(views), "--seed", str(seed)],
        ["calibrate", "stereo", "--images", str(folder), "--board", str(folder / "board.yaml")],
        ["calibrate", "hand-eye", "--images", str(folder), "--robot-poses", str(folder / "robot_poses.csv")],
    ]
    steps[0] += ["--set", f"cameras.image_size=[{w},{h}]"]
    steps[1] += ["--out", str(rig)]
    steps[2] += ["--rig", str(rig), "--board", str(folder / "board.yaml")]
    for step in steps:
        print("robot-app " + " ".join(step), flush=True)
        code = robot_app(step)
        if code != 0:
            raise SystemExit(f"robot-app {step[0]} {step[1]} failed (exit {code})")
    errors = ", ".join(f"{k} {v:+.3f}" for k, v in rig_file_errors(rig).items())
    target = CONFIGS / f"rig_calibrated_{size}.yaml"
    atomic_write_text(target, header(size, views, seed, errors) + rig.read_text())
    print(f"wrote {target}: {errors}", flush=True)
    return target


def run() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    parser.add_argument("--size", action="append", choices=SIZES, help="camera size(s) (default: both)")
    parser.add_argument("--views", type=int, default=40)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--keep", type=Path, help="folder for the views and reports (default: temporary)")
    args = parser.parse_args()
    for size in args.size or SIZES:
        if args.keep is not None:
            args.keep.mkdir(parents=True, exist_ok=True)
            make(size, args.views, args.seed, args.keep)
        else:
            with tempfile.TemporaryDirectory() as work:
                make(size, args.views, args.seed, Path(work))


if __name__ == "__main__":
    run()
