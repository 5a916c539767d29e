"""`robot-app sim ...`: pictures of the simulated cell and model photos from the station.

These commands write pictures and files under fixed names: rerunning them replaces
those files (each written whole), and an output path is checked before the world is
built.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated

import typer

from robot_app.commands._guards import check_world_cameras
from robot_app.commands._options import MaxMemoryOption, check_seed, resource_limits
from robot_app.config import validate
from robot_app.outputs import atomic_path, check_output_file, check_output_folder, staged_folder

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
sim_app = typer.Typer(
    help="The pybullet simulation: pictures, model photos, rig file, calibration views.", no_args_is_help=True
)


@sim_app.command("show")
def show(
    out: Annotated[Path, typer.Option(help="Folder for the PNGs.")] = Path("out/sim_pictures"),
    seed: Annotated[int, typer.Option(callback=check_seed, help="Scene seed (an integer >= 0).")] = 0,
    target: Annotated[int, typer.Option(help="Target cloth No.1-20.")] = 3,
    occluder: Annotated[bool, typer.Option(help="Cover 45% of the target with blue paper.")] = False,
    distractor: Annotated[int | None, typer.Option(help="A second cloth No.1-20.")] = None,
    realism: RealismOption = None,
    config: ConfigOption = None,
    set_: SetOption = None,
    max_memory_gb: MaxMemoryOption = None,
) -> None:
    """Writes overview.png, stereo.png and catalogue.png of the cell."""
    from robot_app.sim import SceneSettings, load_world_config
    from robot_app.sim.pictures import write_pictures

    check_output_folder(out, key="--out", force=True)
    world = load_world_config(config, _overrides(realism, set_))
    check_world_cameras(world, resource_limits(max_memory_gb, False))
    options = {"target": target, "occluder": occluder, "distractor": distractor}
    scene = validate(SceneSettings, options, "the options --target/--occluder/--distractor")
    with staged_folder(out) as stage:
        written = write_pictures(stage, world, scene, seed)
    for path in written:
        typer.echo(str(out / path.name))


@sim_app.command("model-photo")
def model_photo(
    cloth: Annotated[int, typer.Argument(help="Catalogue cloth No.1-20.")],
    out: Annotated[Path, typer.Option(help="Folder for photo.png, background.png, camera.yaml.")] = Path(
        "out/model_photo"
    ),
    realism: RealismOption = None,
    config: ConfigOption = None,
    set_: SetOption = None,
    max_memory_gb: MaxMemoryOption = None,
) -> None:
    """Photographs a cloth at the Fig. 7 station, for `robot-app model make`."""
    import cv2

    from robot_app.sim import cloth_spec, load_world_config
    from robot_app.sim.station import ModelStation
    from robot_app.vision.camera import save_model_camera

    check_output_folder(out, key="--out", force=True)
    world = load_world_config(config, _overrides(realism, set_))
    check_world_cameras(world, resource_limits(max_memory_gb, False))
    spec = cloth_spec(cloth)
    with ModelStation.for_world(world) as station:
        photo = station.photograph(spec)
    with staged_folder(out) as stage:
        cv2.imwrite(str(stage / "photo.png"), photo.photo_bgr)
        cv2.imwrite(str(stage / "background.png"), photo.background_bgr)
        save_model_camera(photo.model_camera, stage / "camera.yaml")
    typer.echo(str(out))


@sim_app.command("rig")
def rig(
    out: Annotated[Path, typer.Option(help="Stereo rig YAML to write.")] = Path("out/rig.yaml"),
    config: ConfigOption = None,
    set_: SetOption = None,
) -> None:
    """Writes the hand stereo rig file that matches the simulated cameras."""
    from robot_app.sim import World, load_world_config

    check_output_file(out, key="--out", suffixes=(".yaml", ".yml"))
    world_config = load_world_config(config, tuple(set_ or ()))
    with World(world_config) as world, atomic_path(out) as rig_file:
        world.save_rig(rig_file)
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

    Writes left_<n>.png, right_<n>.png, robot_poses.csv (flange in base), board.yaml,
    flat_field/ (8 frames per camera of a uniformly lit card, through the same camera
    model: `calibrate` measures the vignetting from them and divides it out) and
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
