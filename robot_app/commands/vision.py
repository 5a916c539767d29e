"""`robot-app recognize` and `robot-app fullsearch`: recognition on a stereo pair of image files."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import numpy as np
import typer

from robot_app.commands._guards import (
    check_full_search,
    check_model_size,
    check_recognition_settings,
    check_stereo_images,
)
from robot_app.commands._options import (
    AllowLargeOption,
    ForceOption,
    MaxMemoryOption,
    SeedOption,
    resource_limits,
)
from robot_app.commands.recognize_pairs import read_pairs, recognize_pairs
from robot_app.config import dump_config, load_config
from robot_app.errors import InputError, RobotAppError
from robot_app.outputs import atomic_path, atomic_write_text, check_output_folder, output_folder
from robot_app.resources import ResourceLimits
from robot_app.vision.camera import load_rig
from robot_app.vision.fitness import FitnessEvaluator
from robot_app.vision.full_search import find_peaks, full_search
from robot_app.vision.photo_model import ClothModel, load_photo
from robot_app.vision.plots import plot_full_search
from robot_app.vision.recognizer import RecognitionSettings, Recognizer

ModelOption = Annotated[Path, typer.Option("--model", help="Cloth model file (.npz from 'model make').")]
RigOption = Annotated[
    Path, typer.Option("--rig", help="Stereo rig YAML (OpenCV stereoCalibrate conventions).")
]
LeftOption = Annotated[Path, typer.Option("--left", help="Left camera image.")]
RightOption = Annotated[Path, typer.Option("--right", help="Right camera image.")]
PairsOption = Annotated[
    Path | None,
    typer.Option(
        "--pairs",
        help="CSV with header left,right (paths relative to its folder or absolute): "
        "one JSON line per row, instead of --left/--right.",
    ),
]
ConfigOption = Annotated[
    Path | None, typer.Option("--config", help="YAML of recognition settings (fitness, ga, bounds, ...).")
]
SetOption = Annotated[list[str] | None, typer.Option("--set", help="Setting key=value (repeatable).")]


def check_recognition_inputs(
    model: Path, left: Path, right: Path, settings: RecognitionSettings, limits: ResourceLimits
) -> ClothModel:
    """Everything a recognition reads, checked before it runs; returns the loaded model."""
    cloth_model = ClothModel.load(model)
    check_model_size(cloth_model, "--model", limits)
    check_recognition_settings(settings, limits)
    check_stereo_images(left, right, limits)
    return cloth_model


def recognize(
    model: ModelOption,
    rig: RigOption,
    left: Annotated[Path | None, typer.Option("--left", help="Left camera image.")] = None,
    right: Annotated[Path | None, typer.Option("--right", help="Right camera image.")] = None,
    pairs: PairsOption = None,
    seed: SeedOption = None,
    as_json: Annotated[
        bool, typer.Option("--json", help="One compact JSON line instead of indented.")
    ] = False,
    peaks: Annotated[bool, typer.Option("--peaks", help="Also report the best pose of each peak.")] = False,
    rival: Annotated[
        list[Path] | None,
        typer.Option(
            "--rival",
            help="A catalogue model the cloth could be confused with (repeatable): an accepted "
            "recognition is rejected if one explains its region better (config: rivals.*).",
        ),
    ] = None,
    config: ConfigOption = None,
    overrides: SetOption = None,
    max_memory_gb: MaxMemoryOption = None,
    allow_large: AllowLargeOption = False,
) -> None:
    """Recognise the model's cloth in a stereo pair; print the pose of Σ_M in the right camera as JSON.

    A cloth that is not there is a result, not an error: `found` is false and the exit
    code is 0. Bad input (missing file, image size not the rig's, non-rotation R, a file
    that is not a cloth model) exits with 2. With --pairs, each row prints one JSON line
    (a row that fails prints {"row": i, "error": ...} and the rest go on; exit 1 at the
    end if any failed), with a progress bar on stderr.
    """
    if pairs is not None and (left is not None or right is not None):
        raise InputError("give either --pairs or --left and --right, not both", key="--pairs")
    if pairs is None and (left is None or right is None):
        raise InputError("give --left and --right (or --pairs PAIRS.csv)", key="--left")
    settings = load_config(RecognitionSettings, config, overrides or [])
    limits = resource_limits(max_memory_gb, allow_large)
    if pairs is not None:
        rows = read_pairs(pairs)  # a malformed CSV is bad input before any work
        cloth_model = ClothModel.load(model)
        check_model_size(cloth_model, "--model", limits)
        check_recognition_settings(settings, limits)
        recognizer = _with_rivals(Recognizer(cloth_model, load_rig(rig), settings), rival or [], limits)
        summary = recognize_pairs(recognizer, rows, seed=seed, report_peaks=peaks)
        if summary.failed:  # a result, not bad input: exit 1 after every row has printed
            raise RobotAppError(f"{summary.failed} of {summary.rows} pairs failed (their rows say why)")
        return
    if left is None or right is None:  # unreachable (checked above); narrows the types
        raise InputError("give --left and --right", key="--left")
    cloth_model = check_recognition_inputs(model, left, right, settings, limits)
    recognizer = _with_rivals(Recognizer(cloth_model, load_rig(rig), settings), rival or [], limits)
    result = recognizer.recognize(load_photo(left), load_photo(right), seed=seed, report_peaks=peaks)
    typer.echo(json.dumps(result.to_json(), indent=None if as_json else 2))


def _with_rivals(recognizer: Recognizer, paths: list[Path], limits: ResourceLimits) -> Recognizer:
    """The recogniser with the rival models of `--rival` (each loaded and size-checked)."""
    rivals = []
    for path in paths:
        rival_model = ClothModel.load(path)
        check_model_size(rival_model, "--rival", limits)
        rivals.append(Recognizer(rival_model, recognizer.rig, recognizer.settings))
    recognizer.set_rivals(rivals)
    return recognizer


def fullsearch(
    model: ModelOption,
    rig: RigOption,
    left: LeftOption,
    right: RightOption,
    out: Annotated[Path, typer.Option("--out", help="Folder for the plots and summary.json.")],
    step: Annotated[float, typer.Option("--step", help="Grid step [m] (paper: 0.001).")] = 0.002,
    depth: Annotated[float, typer.Option("--depth", help="Depth of the model origin [m].")] = 0.58,
    yaw_step_deg: Annotated[
        float | None, typer.Option("--yaw-step-deg", help="Also search yaw over a full turn in these steps.")
    ] = None,
    seed: SeedOption = None,
    config: ConfigOption = None,
    overrides: SetOption = None,
    force: ForceOption = False,
    max_memory_gb: MaxMemoryOption = None,
    allow_large: AllowLargeOption = False,
) -> None:
    """Fitness distribution over the x-y plane (Fig. 13) with the GA's individuals on top."""
    limits = resource_limits(max_memory_gb, allow_large)
    if not (np.isfinite(step) and step > 0):
        raise InputError(f"--step must be a grid step > 0 [m], got {step}", key="--step", value=step)
    if not (np.isfinite(depth) and depth > 0):
        raise InputError(f"--depth must be > 0 [m], got {depth}", key="--depth", value=depth)
    if yaw_step_deg is not None and not 0 < yaw_step_deg <= 360:
        raise InputError(
            f"--yaw-step-deg must be in (0, 360], got {yaw_step_deg}",
            key="--yaw-step-deg",
            value=yaw_step_deg,
        )
    check_output_folder(out, key="--out", force=force)
    settings = load_config(RecognitionSettings, config, overrides or [])
    cloth_model = check_recognition_inputs(model, left, right, settings, limits)
    yaws = None if yaw_step_deg is None else np.deg2rad(np.arange(-180.0, 180.0, yaw_step_deg)).tolist()
    check_full_search(settings, step, len(yaws or [0.0]), cloth_model.n_in + cloth_model.n_out, limits)
    stereo_rig = load_rig(rig)
    image_left, image_right = load_photo(left), load_photo(right)
    evaluator = FitnessEvaluator(cloth_model, stereo_rig, settings.fitness)
    evaluator.update(image_left, image_right)
    bounds = settings.propose.bounds
    with typer.progressbar(length=1, label="full search") as bar:

        def progress(done: int, total: int) -> None:
            bar.length = total
            bar.update(done - bar.pos)

        result = full_search(evaluator, bounds.x, bounds.y, step, depth, None, yaws, progress=progress)
    recognizer = Recognizer(cloth_model, stereo_rig, settings)
    recognition = recognizer.recognize(image_left, image_right, seed=seed, report_peaks=True)
    summary = {
        "full_search": {
            "best_fitness": result.best_fitness,
            "best_position": result.best_transform[:3, 3].tolist(),
            "best_yaw_deg": float(np.rad2deg(np.arctan2(result.rotation[1, 0], result.rotation[0, 0]))),
            "evaluations": result.evaluations,
            "step_m": step,
            "depth_m": depth,
            "peaks": [
                p._asdict()
                for p in find_peaks(
                    result, settings.propose.peak_separation, settings.propose.peak_min_fitness
                )
            ],
        },
        "ga": recognition.to_json(),
    }
    with (
        output_folder(out),
        atomic_path(out / "fullsearch_2d.png") as map_png,
        atomic_path(out / "fullsearch_3d.png") as surface_png,
    ):
        plot_full_search(
            result,
            map_png,
            surface_png,
            individuals=recognizer.population,
            title=f"{cloth_model.name}: fitness distribution",
        )
        dump_config(settings, out / "config.yaml")
        atomic_write_text(out / "summary.json", json.dumps(summary, indent=2))
    typer.echo(
        f"full search: best fitness {result.best_fitness:.3f} at "
        f"({result.best_transform[0, 3] * 1e3:.1f}, {result.best_transform[1, 3] * 1e3:.1f}) mm; "
        f"GA: {recognition.fitness:.3f}; plots and summary in {out}"
    )


def register(app: typer.Typer) -> None:
    """Adds `recognize` and `fullsearch` to the CLI."""
    app.command("recognize")(recognize)
    app.command("fullsearch")(fullsearch)


__all__ = ["fullsearch", "recognize", "register"]
