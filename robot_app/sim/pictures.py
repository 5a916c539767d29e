"""Pictures a person can look at: the cell from an overview camera, the stereo pair,
and the 12 catalogue cloths side by side (as the station photographs them)."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import numpy.typing as npt

from robot_app.geometry import make_transform
from robot_app.sim.cameras import render_bgr
from robot_app.sim.cloths import CATALOGUE
from robot_app.sim.config import SceneSettings, WorldConfig
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


def write_pictures(out: str | Path, config: WorldConfig, scene: SceneSettings, seed: int = 0) -> list[Path]:
    """Writes overview.png, stereo.png and catalogue.png into `out`; returns their paths."""
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    with World(config) as world:
        make_scene(world, scene, seed)
        overview = PinholeCamera.from_fov((960, 720), np.deg2rad(60))
        pose = look_at([1.6, 0.9, 1.1], [0.35, -0.15, 0.15])
        image = render_bgr(world.client, overview, pose, lighting=world.stereo.lighting)
        paths.append(folder / "overview.png")
        cv2.imwrite(str(paths[-1]), image)
        frame = world.stereo.render()
        paths.append(folder / "stereo.png")
        cv2.imwrite(str(paths[-1]), np.hstack([frame.left_bgr, frame.right_bgr]))
    tiles = []
    with ModelStation(config.station, config.cloth, config.range.sheet_rgb) as station:
        for spec in CATALOGUE:
            photo = cv2.resize(station.photograph(spec).photo_bgr, (320, 240), interpolation=cv2.INTER_AREA)
            white = (255, 255, 255)
            cv2.putText(photo, f"No.{spec.number}", (8, 24), cv2.FONT_HERSHEY_SIMPLEX, 0.7, white, 2)
            tiles.append(photo)
    rows = [np.hstack(tiles[i : i + 4]) for i in range(0, len(tiles), 4)]
    paths.append(folder / "catalogue.png")
    cv2.imwrite(str(paths[-1]), np.vstack(rows))
    return paths


__all__ = ["look_at", "write_pictures"]
