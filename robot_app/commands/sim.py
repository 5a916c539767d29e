"""`robot-app sim ...`: pictures of the simulated cell and model photos from the station."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated

import typer

ConfigOption = Annotated[Path | None, typer.Option(help="World config YAML (default configs/world.yaml).")]
SetOption = Annotated[list[str] | None, typer.Option("--set", help="Override a config key: key.path=value.")]

# The commands import pybullet and the simulator in their bodies: every `robot-app`
# command imports this module to register them.
sim_app = typer.Typer(
    help="The pybullet simulation: pictures, model photos, rig file, calibration views.", no_args_is_help=True
)


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


@sim_app.command("calibration-views")
def calibration_views(
    out: Annotated[Path, typer.Option("--out", help="New or empty folder for the views.")],
    views: Annotated[int, typer.Option("--views", help="Image pairs to capture.")] = 40,
    seed: Annotated[int, typer.Option("--seed", help="Seed of the camera poses.")] = 0,
    config: ConfigOption = None,
    set_: SetOption = None,
) -> None:
    """Board views for `robot-app calibrate`: a checkerboard on the table, the arm over it.

    Writes left_<n>.png, right_<n>.png, robot_poses.csv (flange in base), board.yaml and
    truth/rig.yaml (the URDF's rig, to compare a calibration with). The cameras are the
    world config's (set world.cameras.image_size to the resolution you will run at).
    """
    from robot_app.sim import load_world_config
    from robot_app.sim.calibration_views import CalibrationViewSettings, capture_calibration_views

    world = load_world_config(config, tuple(set_ or ()))
    settings = CalibrationViewSettings(views=views, seed=seed)
    with typer.progressbar(length=views, label="capturing", file=sys.stderr) as bar:
        result = capture_calibration_views(world, settings, out, progress=lambda done, total: bar.update(1))
    typer.echo(
        f"{result.count} views ({result.tried} camera poses tried) of a {settings.board.describe()} "
        f"in {result.folder}"
    )
    typer.echo(
        f"next: robot-app calibrate stereo --images {out} --board {out}/board.yaml --out {out}/rig.yaml"
    )
    typer.echo(
        f"then: robot-app calibrate hand-eye --images {out} --robot-poses {out}/robot_poses.csv "
        f"--rig {out}/rig.yaml --board {out}/board.yaml"
    )


def register(app: typer.Typer) -> None:
    """Adds `sim` to the `robot-app` CLI."""
    app.add_typer(sim_app, name="sim")


__all__ = ["register"]
