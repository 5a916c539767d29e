"""`robot-app sim ...`: pictures of the simulated cell and model photos from the station."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

ConfigOption = Annotated[Path | None, typer.Option(help="World config YAML (default configs/world.yaml).")]
SetOption = Annotated[list[str] | None, typer.Option("--set", help="Override a config key: key.path=value.")]
RealismOption = Annotated[
    str | None, typer.Option(help="clean, realistic or harsh (default: the config's world.realism).")
]


def _overrides(realism: str | None, set_: list[str] | None) -> tuple[str, ...]:
    """--realism NAME is `--set realism=NAME`, before the other --set keys."""
    return ((f"realism={realism}",) if realism is not None else ()) + tuple(set_ or ())


# The commands import pybullet and the simulator in their bodies: every `robot-app`
# command imports this module to register them.
sim_app = typer.Typer(help="The pybullet simulation: pictures, model photos, rig file.", no_args_is_help=True)


@sim_app.command("show")
def show(
    out: Annotated[Path, typer.Option(help="Folder for the PNGs.")] = Path("out/sim_pictures"),
    seed: Annotated[int, typer.Option(help="Scene seed.")] = 0,
    target: Annotated[int, typer.Option(help="Target cloth No.1-20.")] = 3,
    occluder: Annotated[bool, typer.Option(help="Cover 45% of the target with blue paper.")] = False,
    distractor: Annotated[int | None, typer.Option(help="A second cloth No.1-20.")] = None,
    realism: RealismOption = None,
    config: ConfigOption = None,
    set_: SetOption = None,
) -> None:
    """Writes overview.png, stereo.png and catalogue.png of the cell."""
    from robot_app.config import validate
    from robot_app.sim import SceneSettings, load_world_config
    from robot_app.sim.pictures import write_pictures

    world = load_world_config(config, _overrides(realism, set_))
    scene = validate(
        SceneSettings, {"target": target, "occluder": occluder, "distractor": distractor}, "options"
    )
    for path in write_pictures(out, world, scene, seed):
        typer.echo(str(path))


@sim_app.command("model-photo")
def model_photo(
    cloth: Annotated[int, typer.Argument(help="Catalogue cloth No.1-20.")],
    out: Annotated[Path, typer.Option(help="Folder for photo.png, background.png, camera.yaml.")] = Path(
        "out/model_photo"
    ),
    realism: RealismOption = None,
    config: ConfigOption = None,
    set_: SetOption = None,
) -> None:
    """Photographs a cloth at the Fig. 7 station, for `robot-app model make`."""
    import cv2

    from robot_app.sim import cloth_spec, load_world_config
    from robot_app.sim.station import ModelStation
    from robot_app.vision.camera import save_model_camera

    world = load_world_config(config, _overrides(realism, set_))
    spec = cloth_spec(cloth)
    out.mkdir(parents=True, exist_ok=True)
    with ModelStation.for_world(world) as station:
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
