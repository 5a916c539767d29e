"""Pictures a person can look at: the cell from an overview camera, the stereo pair,
and the catalogue cloths side by side (as the station photographs them)."""

from __future__ import annotations

import os
from pathlib import Path

import cv2
import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray
from robot_app.errors import OutputError
from robot_app.geometry import make_transform
from robot_app.sim.cloths import CATALOGUE
from robot_app.sim.config import SceneSettings, WorldConfig
from robot_app.sim.lighting import render_lit
from robot_app.sim.scene import make_scene
from robot_app.sim.station import ModelStation
from robot_app.sim.world import World
from robot_app.vision.camera import PinholeCamera


def look_at(
    eye: npt.ArrayLike, target: npt.ArrayLike, up: npt.ArrayLike = (0, 0, 1)
) -> npt.NDArray[np.float64]:
    """4x4 OpenCV camera pose at `eye` [m] looking at `target` (image up ~ `up`)."""
    eye, target, up = (np.asarray(v, dtype=float) for v in (eye, target, up))
    z = target - eye
    z /= np.linalg.norm(z)
    x = np.cross(z, up)
    x /= np.linalg.norm(x)
    return make_transform(np.column_stack([x, np.cross(z, x), z]), eye)


def overview_image(world: World, camera: PinholeCamera, pose: FloatArray) -> npt.NDArray[np.uint8]:
    """The cell seen by a free camera, in its light and (if on) the key lamp's shadows."""
    shadows = None
    if world.config.lighting.shadows:
        shadows = world.stereo.shadow_map((camera,), (pose,), size=512)
    light = world.config.lighting
    return render_lit(
        world.client, camera, pose, world.lighting, shadows, light.penumbra, two_sided=light.two_sided
    )


def write_pictures(out: str | Path, config: WorldConfig, scene: SceneSettings, seed: int = 0) -> list[Path]:
    """Writes overview.png, stereo.png and catalogue.png into `out`; returns their paths.

    Raises:
        OutputError: `out` exists and is not a folder, or cannot be written.
    """
    folder = Path(out)
    if folder.exists() and not folder.is_dir():
        raise OutputError(f"{folder} exists and is not a folder", path=folder, expected="a folder")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise OutputError(f"cannot create the folder {folder}: {err.strerror}", path=folder) from err
    paths = []
    with World(config) as world:
        make_scene(world, scene, seed)
        overview = PinholeCamera.from_fov((960, 720), np.deg2rad(60))
        pose = look_at([1.6, 0.9, 1.1], [0.35, -0.15, 0.15])
        paths.append(write_png(folder / "overview.png", overview_image(world, overview, pose)))
        frame = world.stereo.render()
        paths.append(write_png(folder / "stereo.png", np.hstack([frame.left_bgr, frame.right_bgr])))
    tiles = []
    with ModelStation.for_world(config) as station:
        for spec in CATALOGUE:
            photo = cv2.resize(station.photograph(spec).photo_bgr, (320, 240), interpolation=cv2.INTER_AREA)
            white = (255, 255, 255)
            cv2.putText(photo, f"No.{spec.number}", (8, 24), cv2.FONT_HERSHEY_SIMPLEX, 0.7, white, 2)
            tiles.append(photo)
    rows = [np.hstack(tiles[i : i + 5]) for i in range(0, len(tiles), 5)]
    paths.append(write_png(folder / "catalogue.png", np.vstack(rows)))
    return paths


def write_png(path: Path, image: npt.NDArray[np.uint8]) -> Path:
    """Writes a PNG atomically (a temporary name in the same folder, then renamed)."""
    tmp = path.with_name(f".{path.stem}.{os.getpid()}.tmp.png")
    try:
        if not cv2.imwrite(str(tmp), image):
            raise OutputError(f"could not write {path}", path=path)
        os.replace(tmp, path)
    except OSError as err:
        raise OutputError(f"could not write {path}: {err.strerror}", path=path) from err
    finally:
        tmp.unlink(missing_ok=True)
    return path


__all__ = ["look_at", "overview_image", "write_pictures", "write_png"]
