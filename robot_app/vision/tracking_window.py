"""The tracking window: where a multi-step frame searches, and which pixels it can reach.

Between frames the kept poses move by the camera motion (Sec. II-E); the next frame's GA
searches a window around the best moved pose, `window` in x-y and `depth_window` in
depth (the window moves with the camera, so a descending camera keeps its cloth). A
model in that window, at any yaw and tilt, covers only part of each image: only those
pixels need colour codes (`FitnessEvaluator.update(regions=...)`), which halves a
tracking frame's pixel work for a cloth that fills a third of the image.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from pydantic import Field, field_validator

from robot_app.arrays import FloatArray
from robot_app.config import StrictModel
from robot_app.vision.camera import StereoRig
from robot_app.vision.cloth_model import ClothModel
from robot_app.vision.ga import GASettings, SearchBoundsSettings


class TrackingSettings(StrictModel):
    """Multi-step proposal between frames.

    Attributes:
        ga: the tracking GA (its `generations` are per frame; 24 individuals, one island).
        window: half-width of the x-y search window around the motion-predicted pose [m].
        depth_window: half-width of the depth window [m]; the window moves with the
            camera, so a descending camera keeps its cloth.
        verify_every: verify (and decide) on every n-th tracking frame; between them the
            last verification's appearance is carried over (1: every frame).
        yaw_window_deg: half-width of the yaw window around the motion-predicted pose
            [deg]: a tracked cloth turns little between frames, while the hue fitness
            cannot tell a plain cloth from its half turn, so a GA free in yaw flipped a
            denim rectangle half a turn on the first tracking frame (pick-and-place,
            realistic cell: every frame 180 deg off, the filter rejected them all).
        view_floor: the tracking GA's (min_view_fraction, hidden_penalty) of the search
            fitness's "view" normalisation; None: the search fitness's own. Near the cloth
            only part of it is in view, and the search's floor (a pose with less than 30 %
            of its points in view scores in proportion to them) and its hidden penalty pay
            a pose for bringing more of the model into view: farther and towards the middle
            of the image. A descending camera's tracked pose slid with them, 10 mm off at a
            camera-to-cloth distance of 0.16 m and 31 mm at 0.10 m (scripts/bench_close_range.py);
            the window around the moved pose already keeps the far, squeezed poses out
            that the floor is for, so tracking scores the points in view.
    """

    ga: GASettings = GASettings(population=24, generations=3, islands=1, elite=2)
    window: float = Field(default=0.02, gt=0.0)
    depth_window: float = Field(default=0.03, gt=0.0)
    verify_every: int = Field(default=1, ge=1)
    yaw_window_deg: float = Field(default=30.0, gt=0.0, le=180.0)
    view_floor: tuple[float, float] | None = (0.05, 0.0)

    @field_validator("view_floor")
    @classmethod
    def _fractions(cls, value: tuple[float, float] | None) -> tuple[float, float] | None:
        if value is not None and not (0.0 < value[0] <= 1.0 and 0.0 <= value[1] <= 1.0):
            raise ValueError(
                f"view_floor needs min_view_fraction in (0, 1] and hidden_penalty in [0, 1], got {value}"
            )
        return value


def window_around(
    pose: FloatArray, tracking: TrackingSettings, bounds: SearchBoundsSettings
) -> SearchBoundsSettings:
    """The search window around `pose` ^CR T_M: `tracking.window` in x-y, `depth_window` in
    depth, the tilt and yaw bounds of `bounds`."""
    x, y, z = pose[:3, 3]
    return SearchBoundsSettings(
        x=(x - tracking.window, x + tracking.window),
        y=(y - tracking.window, y + tracking.window),
        z=(max(z - tracking.depth_window, 1e-3), max(z + tracking.depth_window, 2e-3)),
        max_tilt_deg=bounds.max_tilt_deg,
        max_yaw_deg=bounds.max_yaw_deg,
    )


# The 8 corners of a box, as 0 (low) / 1 (high) per axis.
_BOX_CORNERS = np.array(np.meshgrid([0, 1], [0, 1], [0, 1], indexing="ij")).reshape(3, -1).T


def reachable_regions(
    window: SearchBoundsSettings, model: ClothModel, rig: StereoRig
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]:
    """Per image (left, right), the (u0, v0, u1, v1) box, inclusive and inside the image,
    that the model's points can reach with its origin anywhere in `window`, at any yaw and
    tilt (the window grown by the model's radius on every side), a few pixels to spare;
    the whole image when a camera could see the model from behind.

    Only the grown box's 8 corners are projected: a pinhole's u and v are ratios of
    linear functions of the point, so over a box in front of the camera their extremes
    (and the least depth) lie at its corners."""
    low = np.array([window.x[0], window.y[0], window.z[0]]) - model.radius
    high = np.array([window.x[1], window.y[1], window.z[1]]) + model.radius
    points = np.where(_BOX_CORNERS == 1, high, low)  # in Σ_CR
    width, height = rig.image_size
    boxes = []
    for camera, to_camera in ((rig.left, rig.transform_right_to_left), (rig.right, np.eye(4))):
        X = points @ to_camera[:3, :3].T + to_camera[:3, 3]
        if np.any(X[:, 2] <= 1e-3):
            boxes.append(np.array([0, 0, width - 1, height - 1], dtype=np.int64))
            continue
        uv = X[:, :2] / X[:, 2:] @ camera.camera_matrix[:2, :2].T + camera.camera_matrix[:2, 2]
        box = np.array([uv[:, 0].min() - 3, uv[:, 1].min() - 3, uv[:, 0].max() + 4, uv[:, 1].max() + 4])
        boxes.append(
            np.clip(np.floor(box), 0, [width - 1, height - 1, width - 1, height - 1]).astype(np.int64)
        )
    return boxes[0], boxes[1]


__all__ = ["TrackingSettings", "reachable_regions", "window_around"]
