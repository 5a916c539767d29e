"""`robot-app model ...`: make a cloth model from a photo, and inspect a model file."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Annotated

import typer

from robot_app.config import load_config
from robot_app.errors import InputError
from robot_app.vision.camera import load_model_camera
from robot_app.vision.photo_model import ClothModel, ModelSettings, load_photo, make_model
from robot_app.vision.plots import save_preview

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
) -> None:
    """Make a cloth model (S_in, S_out, hues) from a photo and write it as .npz."""
    settings = load_config(ModelSettings, config, overrides or [])
    model_camera = load_model_camera(camera)
    photo_bgr = load_photo(photo)
    background_bgr = load_photo(background) if background is not None else None
    for target in (out, preview):
        if target is not None and not target.parent.is_dir():
            raise InputError(f"cannot write {target}: folder {target.parent} does not exist")
    sources = {"photo": str(photo), "camera": str(camera)}
    if background is not None:
        sources["background"] = str(background)
    model = make_model(
        photo_bgr, model_camera, background_bgr, settings, name=name or photo.stem, sources=sources
    )
    model.save(out)
    if preview is not None:
        save_preview(model, photo_bgr, preview)
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
