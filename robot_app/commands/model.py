"""`robot-app model ...`: make a cloth model from a photo, and inspect a model file."""

from __future__ import annotations

import json
import math
from contextlib import nullcontext
from pathlib import Path
from typing import Annotated

import typer

from robot_app.commands._guards import check_made_model, check_model_making, read_colour_photo
from robot_app.commands._options import AllowLargeOption, MaxMemoryOption, resource_limits
from robot_app.config import load_config
from robot_app.errors import InputError
from robot_app.outputs import atomic_path, check_output_file
from robot_app.vision.camera import load_model_camera
from robot_app.vision.photo_model import ClothModel, ModelSettings, make_model
from robot_app.vision.plots import save_preview

PREVIEW_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff")
"""Image formats a preview can be written in (OpenCV chooses by the suffix)."""

model_app = typer.Typer(
    help="Cloth models from photos on a green sheet (paper Sec. II-B).", no_args_is_help=True
)


@model_app.command("make")
def make(
    photo: Annotated[Path, typer.Argument(help="Photo of the cloth on the green sheet (PNG/JPEG).")],
    camera: Annotated[Path, typer.Option("--camera", help="Model camera YAML (intrinsics, distance in m).")],
    out: Annotated[Path, typer.Option("--out", help="Model file to write (.npz).")],
    background: Annotated[Path | None, typer.Option("--background", help="Photo of the empty sheet.")] = None,
    preview: Annotated[Path | None, typer.Option("--preview", help="Fig. 4 style preview PNG.")] = None,
    name: Annotated[str | None, typer.Option("--name", help="Model name (default: photo's stem).")] = None,
    config: Annotated[Path | None, typer.Option("--config", help="YAML of model settings.")] = None,
    overrides: Annotated[
        list[str] | None, typer.Option("--set", help="Setting key=value (repeatable).")
    ] = None,
    max_memory_gb: MaxMemoryOption = None,
    allow_large: AllowLargeOption = False,
) -> None:
    """Make a cloth model (S_in, S_out, hues) from a photo and write it as .npz.

    Both files are written only when both are made (a failing preview leaves no model).
    """
    limits = resource_limits(max_memory_gb, allow_large)
    check_output_file(out, key="--out", suffixes=(".npz",), create_parents=False)
    if preview is not None:
        check_output_file(preview, key="--preview", suffixes=PREVIEW_SUFFIXES, create_parents=False)
    inputs = [p.resolve() for p in (photo, camera, background) if p is not None]
    for target, key in ((out, "--out"), (preview, "--preview")):
        if target is not None and target.resolve() in inputs:
            raise InputError(f"{key} {target} is one of the input files", key=key, value=str(target))
    settings = load_config(ModelSettings, config, overrides or [])
    model_camera = load_model_camera(camera)
    photo_bgr = read_colour_photo(photo, "the photo", "PHOTO", limits)
    background_bgr = (
        read_colour_photo(background, "the background photo", "--background", limits)
        if background is not None
        else None
    )
    check_model_making(model_camera, camera, settings, limits)
    sources = {"photo": str(photo), "camera": str(camera)}
    if background is not None:
        sources["background"] = str(background)
    model = make_model(
        photo_bgr, model_camera, background_bgr, settings, name=name or photo.stem, sources=sources
    )
    check_made_model(model, model_camera, camera, limits)
    with atomic_path(out) as model_file, atomic_path(preview) if preview else nullcontext() as preview_file:
        model.save(model_file)
        if preview_file is not None:
            save_preview(model, photo_bgr, preview_file)
    typer.echo(
        f"model '{model.name}': {model.n_in} S_in + {model.n_out} S_out points, "
        f"{model.extent[0] * 1e3:.0f} x {model.extent[1] * 1e3:.0f} mm, "
        f"background hue {model.background_hue:.1f} -> {out}"
    )


@model_app.command("show")
def show(model_file: Annotated[Path, typer.Argument(help="A cloth model (.npz) from 'model make'.")]) -> None:
    """Print a model's summary as JSON."""
    model = ClothModel.load(model_file)
    summary = {
        "name": model.name,
        "n_in": model.n_in,
        "n_out": model.n_out,
        "extent_mm": [round(v * 1e3, 2) for v in model.extent],
        "background_hue": round(model.background_hue, 2),
        "grasp_point_mm": [round(v * 1e3, 2) for v in model.grasp_point.tolist()],
        "symmetry_angles_deg": [round(math.degrees(a), 1) for a in model.symmetry_angles],
        "sources": model.metadata.get("sources", {}),
    }
    typer.echo(json.dumps(summary))


def register(app: typer.Typer) -> None:
    """Adds the `model` group to the `robot-app` CLI."""
    app.add_typer(model_app, name="model")


__all__ = ["register"]
