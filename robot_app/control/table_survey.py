"""What a clear-table survey saw, on the table: poses in Σ_W, image pixels laid onto the
table plane, the cloth to pick next (the order) and the other cloths as obstacles.

Pure functions of one survey's capture and identification (`vision.identify`); the job
(`TableClearer`) takes the capture and keeps the records.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray
from robot_app.control.cell import StereoCapture
from robot_app.geometry import transform_points
from robot_app.vision import Recognizer
from robot_app.vision.identify import Detection, Identification


def to_world(capture: StereoCapture, transform_model_to_camera: FloatArray) -> FloatArray:
    """(4, 4) a pose seen by the right camera of `capture`, in Σ_W."""
    return np.asarray(capture.transform_right_camera_to_world @ transform_model_to_camera, dtype=float)


@dataclass(frozen=True)
class TablePlane:
    """The table top as the right camera sees it.

    Attributes:
        camera_matrix: (3, 3) the right camera's intrinsics [px].
        table_z: height of the table top in Σ_W [m].
    """

    camera_matrix: FloatArray
    table_z: float

    def _rays(
        self, capture: StereoCapture, u: npt.ArrayLike, v: npt.ArrayLike
    ) -> tuple[FloatArray, FloatArray]:
        """The rays through right-image pixels (u, v) in Σ_W: origin (3, 1), directions (3, N)."""
        u, v = np.asarray(u, dtype=float).ravel(), np.asarray(v, dtype=float).ravel()
        rays = np.linalg.solve(self.camera_matrix, np.stack([u, v, np.ones_like(u)]))
        T = capture.transform_right_camera_to_world
        return T[:3, 3:4], T[:3, :3] @ rays

    def pixels(self, capture: StereoCapture, u: npt.ArrayLike, v: npt.ArrayLike) -> FloatArray:
        """(N, 2) where the rays through right-image pixels (u, v) meet the table plane [m]."""
        origin, directions = self._rays(capture, u, v)
        dz = directions[2]
        scale = np.where(np.abs(dz) > 1e-9, (self.table_z - origin[2]) / np.where(dz == 0, 1.0, dz), 0.0)
        return np.asarray((origin + scale * directions)[:2].T, dtype=float)

    def ahead(self, capture: StereoCapture, u: npt.ArrayLike, v: npt.ArrayLike) -> npt.NDArray[np.bool_]:
        """(N,) True where the ray through right-image pixel (u, v) goes down to the table
        plane (the others never meet it: `pixels` gives no point of the table for them)."""
        origin, directions = self._rays(capture, u, v)
        return np.asarray((origin[2] > self.table_z) & (directions[2] < -1e-9), dtype=bool)

    def point(self, capture: StereoCapture, pixel: tuple[float, float]) -> tuple[float, float]:
        """Where the ray through a right-image pixel meets the table plane, (x, y) [m]."""
        x, y = self.pixels(capture, np.array([pixel[0]]), np.array([pixel[1]]))[0]
        return float(x), float(y)


def choose_target(
    ident: Identification, records: Mapping[str, Mapping[str, object]], untried: Callable[[str], bool]
) -> Detection | None:
    """The cloth to pick next: the most confident one nothing lies on, among those with
    attempts left (`untried`); else the most visible one with attempts left.

    Args:
        ident: the survey's identification.
        records: cloth name -> the job's record ("unconfirmed", ...).
        untried: cloth name -> has it attempts left (`TableLedger.untried`)?
    """

    def eligible(d: Detection) -> bool:
        if not untried(d.name):
            return False
        # a candidate below the recogniser's threshold gets one closer look by the loop
        unconfirmed = bool(records.get(d.name, {}).get("unconfirmed", False))
        return d.found or not unconfirmed

    free = [d for d in ident.free() if eligible(d)]
    if free:
        return free[0]
    rest = [d for d in ident.detections if eligible(d)]
    return max(rest, key=lambda d: d.recognition.visible_fraction) if rest else None


def obstacles_on_table(
    target: Detection,
    ident: Identification,
    capture: StereoCapture,
    recognizers: Mapping[str, Recognizer],
    table: TablePlane,
    step: int,
) -> FloatArray:
    """(M, 2) table points [m] of every cloth the survey saw but `target`: identified
    ones (their whole footprint, hidden parts included) and unknown regions (every
    `step`-th pixel [px])."""
    xy = [
        transform_points(to_world(capture, d.transform_model_to_camera), recognizers[d.name].model.points_in)[
            :, :2
        ]
        for d in ident.detections
        if d.name != target.name
    ]
    for region in ident.unknown:
        v, u = np.nonzero(region.mask[::step, ::step])
        if len(u):
            xy.append(table.pixels(capture, u * step, v * step))
    return np.concatenate(xy) if xy else np.empty((0, 2))


def disk_points(centre_xy: npt.ArrayLike, radius: float, step: float = 0.01) -> FloatArray:
    """(M, 2) points [m] on a grid of `step` [m] filling the disk of `radius` [m] around
    `centre_xy` (the centre alone for radius 0): a cloth known to lie there, unseen."""
    centre = np.asarray(centre_xy, dtype=float).reshape(2)
    n = int(np.floor(radius / step))
    offsets = np.arange(-n, n + 1) * step
    grid = np.stack(np.meshgrid(offsets, offsets), axis=-1).reshape(-1, 2)
    grid = grid[np.hypot(grid[:, 0], grid[:, 1]) <= radius + 1e-12]
    return centre + grid


__all__ = [
    "TablePlane",
    "choose_target",
    "disk_points",
    "obstacles_on_table",
    "to_world",
]
