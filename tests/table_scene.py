"""The small synthetic stereo rig and model station the clear-table unit tests share, a
recogniser of a catalogue cloth photographed at that station, and a capture of set images."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from robot_app.geometry import make_transform
from robot_app.vision import ModelCamera, PinholeCamera, Recognizer, StereoRig, make_model
from robot_app.vision.synthetic import render_model_photo
from robot_app.vision.synthetic_catalogue import synthetic_cloth

CAMERA = PinholeCamera.from_fov((320, 240), np.deg2rad(48))
RIG = StereoRig(CAMERA, CAMERA, make_transform(np.eye(3), [-0.1, 0.0, 0.0]))
STATION = ModelCamera(PinholeCamera.from_fov((480, 360), np.deg2rad(48)), 0.40)


@dataclass(frozen=True)
class Capture:
    """A `StereoCapture` of set images, taken with the right camera at a set pose."""

    right_bgr: npt.NDArray[np.uint8]
    left_bgr: npt.NDArray[np.uint8]
    transform_right_camera_to_world: np.ndarray
    time: float = 0.0
    available_time: float = 0.0
    dropped: bool = False


def recognizer(index: int, name: str) -> Recognizer:
    """A recogniser of synthetic catalogue cloth `index`, its model made at STATION."""
    photo, background = render_model_photo(synthetic_cloth(index), STATION, rng=np.random.default_rng(index))
    return Recognizer(make_model(photo, STATION, background, name=name), RIG)


def ray_cast_table_xy(camera: PinholeCamera, transform: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(x, y) [m] where each pixel's ray of `camera` (its pose in Σ_W: `transform`) meets the
    table plane z = 0, cast pixel by pixel (independent of `TablePlane`, which tests use it on)."""
    w, h = camera.image_size
    u, v = np.meshgrid(np.arange(w) + 0.0, np.arange(h) + 0.0)
    K = camera.camera_matrix
    rays = np.stack([(u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1], np.ones_like(u)], axis=-1)
    rays = rays @ transform[:3, :3].T
    t = -transform[2, 3] / rays[..., 2]
    return transform[0, 3] + t * rays[..., 0], transform[1, 3] + t * rays[..., 1]
