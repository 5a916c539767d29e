"""Where recognition breaks, one camera axis at a time, inside and beyond the realistic range.

    python scripts/bench_camera_axes.py [--scenes 20] [--absent 10] [--axes gain,noise]
                                        [--kinds flat,covered] [--seed 0] [--set key=value ...]

`scripts/bench_recognition.py` draws every scene's camera from the realistic ranges at once
(gain 0.65-1.35, white balance 0.88-1.12 per channel, shading up to 0.3, noise up to 7, blur
up to 1.2 px, JPEG 70-92), so it says how well the recogniser does on the whole range, not
where it stops working. Here one axis is moved at a time, in steps that go past the realistic
range both ways, while the others stay at a middle camera (gain 1, white balance 1, shading
0.15, noise 3.5, blur 0.6 px, JPEG 81). The scenes are the same at every step of an axis
(same cloths, poses and sheets; only the camera differs), so a step's figures differ from its
neighbours' by the camera alone:

- per present kind (flat, covered: 45 % under a sheet of a colour drawn from blue, grey,
  white, brown), the share *within* (x, y within 6 mm, yaw within 6 deg; flat also within
  1.5 mm / 1.5 deg) and *found* (confidence >= the one threshold);
- absent: the target's hue-family cloth (or another cloth) in view, the share *rejected*.

A step is marked `*` where a figure falls below 95 % (`--floor`); steps inside the realistic
range are marked `r`. The last line per axis names the first failing step on either side of
the realistic range. Nothing here is tuned to pass: the steps are fixed, and a failing step
is the result.

White balance is moved as a colour temperature: blue x 1/f, red x f (f 0.7-1.4).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from dataclasses import replace

import numpy as np
from bench_recognition import RIG, errors_of, make_models, random_pose

from robot_app.config import load_config
from robot_app.errors import ConfigError
from robot_app.vision import RecognitionSettings, Recognizer, occluder_covering, render_stereo_pair
from robot_app.vision.synthetic import OCCLUDER_COLOURS
from robot_app.vision.synthetic_camera import CameraRealism
from robot_app.vision.synthetic_prints import EXTENDED_CATALOGUE_SIZE, family_of

N = EXTENDED_CATALOGUE_SIZE
MIDDLE = CameraRealism(
    gain=1.0, white_balance=(1.0, 1.0, 1.0), shading=0.15, noise_sigma=3.5, blur_sigma=0.6, jpeg_quality=81
)


def _wb(f: float) -> CameraRealism:
    return replace(MIDDLE, white_balance=(1.0 / f, 1.0, f))


# axis -> (steps, realistic range (low, high), the camera at a step)
AXES = {
    "gain": ((0.35, 0.5, 0.65, 1.0, 1.35, 1.7, 2.0), (0.65, 1.35), lambda v: replace(MIDDLE, gain=v)),
    "white_balance": ((0.7, 0.8, 0.88, 1.0, 1.12, 1.25, 1.4), (0.88, 1.12), _wb),
    "shading": ((0.0, 0.15, 0.3, 0.45, 0.6), (0.0, 0.3), lambda v: replace(MIDDLE, shading=v)),
    "noise": ((0.0, 3.5, 7.0, 10.0, 14.0, 20.0), (0.0, 7.0), lambda v: replace(MIDDLE, noise_sigma=v)),
    "blur": ((0.0, 0.6, 1.2, 2.0, 3.0), (0.0, 1.2), lambda v: replace(MIDDLE, blur_sigma=v)),
    "jpeg": ((92, 81, 70, 50, 30, 15), (70, 92), lambda v: replace(MIDDLE, jpeg_quality=int(v))),
}
MIDDLE_STEP = {"gain": 1.0, "white_balance": 1.0, "shading": 0.15, "noise": 3.5, "blur": 0.6, "jpeg": 81}
KINDS = ("flat", "covered")


def scene_rng(seed: int, kind: str, k: int) -> np.random.Generator:
    """The scene's own draws (cloth pose, sheet), the same at every step of every axis."""
    return np.random.default_rng([seed, KINDS.index(kind) if kind in KINDS else 9, k])


def present(kind: str, k: int, cloths, models, camera: CameraRealism, seed: int):
    index = k % N
    rng = scene_rng(seed, kind, k)
    truth = random_pose(rng, models[index])
    occluder = None
    if kind == "covered":
        colour = list(OCCLUDER_COLOURS.values())[int(rng.integers(len(OCCLUDER_COLOURS)))]
        occluder = occluder_covering(
            cloths[index], truth, 0.45, float(rng.uniform(0, 2 * np.pi)), colour_bgr=colour
        )
    noise = np.random.default_rng([seed, 77, KINDS.index(kind), k])
    left, right = render_stereo_pair(
        RIG, [(cloths[index], truth)], occluder=occluder, rng=noise, camera=camera
    )
    return index, left, right, truth


def absent(k: int, cloths, models, camera: CameraRealism, seed: int):
    index = k % N
    rng = scene_rng(seed, "absent", k)
    members = family_of(index)
    other = int(rng.choice(members)) if members else int(rng.choice([j for j in range(N) if j != index]))
    pose = random_pose(rng, models[other])
    noise = np.random.default_rng([seed, 78, k])
    left, right = render_stereo_pair(RIG, [(cloths[other], pose)], rng=noise, camera=camera)
    return index, left, right


def measure(axis: str, value: float, args, cloths, models, recognizers) -> dict[str, float]:
    camera = AXES[axis][2](value)
    out: dict[str, float] = {}
    for kind in args.kinds:
        within, found, tight = [], [], []
        for k in range(args.scenes):
            index, left, right, truth = present(kind, k, cloths, models, camera, args.seed)
            result = recognizers[index].recognize(left, right, seed=k)
            e = errors_of(models[index], result.transform_model_to_camera, truth)
            within.append(max(abs(e[0]), abs(e[1])) <= 6 and abs(e[3]) <= 6)
            tight.append(max(abs(e[0]), abs(e[1])) <= 1.5 and abs(e[3]) <= 1.5)
            found.append(bool(result.found))
        out[f"{kind} within"] = float(np.mean(within))
        out[f"{kind} found"] = float(np.mean(found))
        if kind == "flat":
            out["flat within 1.5"] = float(np.mean(tight))
    if args.absent:
        rejected = []
        for k in range(args.absent):
            index, left, right = absent(k, cloths, models, camera, args.seed)
            rejected.append(not recognizers[index].recognize(left, right, seed=k).found)
        out["absent rejected"] = float(np.mean(rejected))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "--scenes", type=int, default=20, help="present scenes per kind and step (cloths in turn)"
    )
    parser.add_argument("--absent", type=int, default=10, help="absent-target scenes per step (0: none)")
    parser.add_argument("--axes", default=",".join(AXES), help=f"comma-separated, of {', '.join(AXES)}")
    parser.add_argument("--kinds", default=",".join(KINDS), help=f"present kinds, of {', '.join(KINDS)}")
    parser.add_argument(
        "--floor", type=float, default=0.95, help="a figure below this marks a step as failing"
    )
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--set", dest="overrides", action="append", default=[], help="RecognitionSettings key=value"
    )
    args = parser.parse_args()
    axes = [a for a in args.axes.split(",") if a]
    args.kinds = [k for k in args.kinds.split(",") if k]
    bad = [a for a in axes if a not in AXES] + [k for k in args.kinds if k not in KINDS]
    if bad or not axes or args.scenes < 1 or args.absent < 0 or not 0 < args.floor <= 1:
        parser.error(
            f"unknown axis or kind {bad}"
            if bad
            else "--scenes >= 1, --absent >= 0, 0 < --floor <= 1, an axis"
        )
    try:
        settings = load_config(RecognitionSettings, None, args.overrides)
    except ConfigError as err:
        parser.error(str(err))
    print(f"load average (1, 5, 15 min): {os.getloadavg()}; middle camera: {MIDDLE}")
    kinds = ", ".join(args.kinds)
    print(f"{args.scenes} present scenes per kind ({kinds}) and {args.absent} absent per step, "
          f"seed {args.seed}, threshold {settings.decide.threshold}")  # fmt: skip
    cloths, models = make_models()
    recognizers = [Recognizer(m, RIG, settings) for m in models]
    start = time.perf_counter()
    for axis in axes:
        steps, (low, high), _ = AXES[axis]
        print(f"\n{axis} (realistic {low}-{high})")
        failing: list[tuple[float, bool, list[str]]] = []
        header = None
        rows: dict[float, dict[str, float]] = {}
        for value in steps:
            figures = rows[value] = measure(axis, value, args, cloths, models, recognizers)
            if header is None:
                header = list(figures)
                print("  step     " + "  ".join(f"{name:>16}" for name in header))
            realistic = low <= value <= high
            fails = [name for name, v in figures.items() if v < args.floor and name != "flat within 1.5"]
            mark = ("r" if realistic else " ") + ("*" if fails else " ")
            print(
                f"  {value:<6g} {mark} " + "  ".join(f"{figures[n] * 100:>15.0f}%" for n in header),
                flush=True,
            )
            if fails:
                failing.append((value, realistic, fails))
        reference = rows[MIDDLE_STEP[axis]]
        pairs = [(n, v) for v in steps for n in header or ()]
        name, step = min(pairs, key=lambda nv: rows[nv[1]][nv[0]] - reference[nv[0]])
        fall = rows[step][name] - reference[name]
        print(
            f"  largest fall from the middle camera's figures ({axis} {MIDDLE_STEP[axis]:g}): "
            + (f"{name} {fall * 100:+.0f} % at {step:g}" if fall < 0 else "none")
        )
        inside = sorted({n for _, r, fails in failing if r for n in fails})
        below = [v for v, r, _ in failing if not r and v < low]
        above = [v for v, r, _ in failing if not r and v > high]
        print(
            f"  {axis}: "
            + (
                f"under {args.floor:.0%} inside the realistic range: {', '.join(inside)}; "
                if inside
                else "holds over the realistic range; "
            )
            + f"first failing step below it: {max(below) if below else 'none'}, "
            + f"above it: {min(above) if above else 'none'}"
        )
    print(f"\nwall time {time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    try:
        main()
    except KeyboardInterrupt:
        sys.exit(130)
