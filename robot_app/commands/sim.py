"""`robot-app sim ...`: pictures of the simulated cell and model photos from the station."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

ConfigOption = Annotated[Path | None, typer.Option(help="World config YAML (default configs/world.yaml).")]
SetOption = Annotated[list[str] | None, typer.Option("--set", help="Override a config key: key.path=value.")]

# The commands import pybullet and the simulator in their bodies: every `robot-app`
# command imports this module to register them.
sim_app = typer.Typer(help="The pybullet simulation: pictures, model photos, rig file.", no_args_is_help=True)


@sim_app.command("show")
def show(
    out: Annotated[Path, typer.Option(help="Folder for the PNGs.")] = Path("out/sim_pictures"),
    seed: Annotated[int, typer.Option(help="Scene seed.")] = 0,
    target: Annotated[int, typer.Option(help="Target cloth No.1-12.")] = 3,
    occluder: Annotated[bool, typer.Option(help="Cover 45% of the target with blue paper.")] = False,
    distractor: Annotated[int | None, typer.Option(help="A second cloth No.1-12.")] = None,
    config: ConfigOption = None,
    set_: SetOption = None,
) -> None:
    """Writes overview.png, stereo.png and catalogue.png of the cell."""
    from robot_app.sim import SceneSettings, load_world_config
    from robot_app.sim.pictures import write_pictures

    world = load_world_config(config, tuple(set_ or ()))
    scene = SceneSettings(target=target, occluder=occluder, distractor=distractor)
    for path in write_pictures(out, world, scene, seed):
        typer.echo(str(path))


@sim_app.command("model-photo")
def model_photo(
    cloth: Annotated[int, typer.Argument(help="Catalogue cloth No.1-12.")],
    out: Annotated[Path, typer.Option(help="Folder for photo.png, background.png, camera.yaml.")] = Path(
        "out/model_photo"
    ),
    config: ConfigOption = None,
    set_: SetOption = None,
) -> None:
    """Photographs a cloth at the Fig. 7 station, for `robot-app model make`."""
    import cv2

    from robot_app.sim import cloth_spec, load_world_config
    from robot_app.sim.station import ModelStation
    from robot_app.vision.camera import save_model_camera

    world = load_world_config(config, tuple(set_ or ()))
    spec = cloth_spec(cloth)
    out.mkdir(parents=True, exist_ok=True)
    with ModelStation(world.station, world.cloth, world.range.sheet_rgb) as station:
        photo = station.photograph(spec)
    cv2.imwrite(str(out / "photo.png"), photo.photo_bgr)
    cv2.imwrite(str(out / "background.png"), photo.background_bgr)
    save_model_camera(photo.model_camera, out / "camera.yaml")
    typer.echo(str(out))


@sim_app.command("rig")
def rig(
    out: Annotated[Path, typer.Option(help="Stereo rig YAML to write.")] = Path("out/rig.yaml"),
    config: ConfigOption = None,
    set_: SetOption = None,
) -> None:
    """Writes the hand stereo rig file that matches the simulated cameras."""
    from robot_app.sim import World, load_world_config

    out.parent.mkdir(parents=True, exist_ok=True)
    with World(load_world_config(config, tuple(set_ or ()))) as world:
        world.save_rig(out)
    typer.echo(str(out))


def register(app: typer.Typer) -> None:
    """Adds `sim` to the `robot-app` CLI."""
    app.add_typer(sim_app, name="sim")


__all__ = ["register"]
