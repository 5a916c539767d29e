"""The recognition bench's rig and catalogue models, shared by the vision tests (as
`scripts/bench_recognition.py` sets them up): 640x480 cameras of 48° field of view, 0.1 m
apart; model photos taken from 0.40 m; models made once per process."""

from __future__ import annotations

import numpy as np

from robot_app.geometry import make_transform, rotation_from_rpy
from robot_app.vision.camera import ModelCamera, PinholeCamera, StereoRig
from robot_app.vision.cloth_model import ClothModel
from robot_app.vision.photo_model import make_model
from robot_app.vision.synthetic import render_model_photo
from robot_app.vision.synthetic_prints import extended_cloth

CAMERA = PinholeCamera.from_fov((640, 480), np.deg2rad(48))
RIG = StereoRig(CAMERA, CAMERA, make_transform(np.eye(3), [-0.1, 0.0, 0.0]))
MODEL_CAMERA = ModelCamera(CAMERA, 0.40)
_MODELS: dict[int, ClothModel] = {}


def catalogue_model(index: int) -> ClothModel:
    """The photo model of the extended catalogue's cloth `index` (made once)."""
    if index not in _MODELS:
        cloth = extended_cloth(index)
        photo, background = render_model_photo(cloth, MODEL_CAMERA)
        _MODELS[index] = make_model(photo, MODEL_CAMERA, background, name=cloth.name)
    return _MODELS[index]


def bench_flat_pose(rng: np.random.Generator, model: ClothModel) -> np.ndarray:
    """(4, 4) ^CR T_M drawn as the bench's `random_pose` draws a flat scene's: the whole cloth
    inside the view, tilted up to 10°, any yaw, 0.58 ± 0.03 m from the cameras."""
    radius = 0.5 * float(np.hypot(*model.extent))
    half = (max(0.255 - radius, 0.0), max(0.195 - radius, 0.0))
    tilt, direction = np.deg2rad(10.0) * np.sqrt(rng.uniform()), rng.uniform(0, 2 * np.pi)
    R = rotation_from_rpy(tilt * np.cos(direction), tilt * np.sin(direction), rng.uniform(-np.pi, np.pi))
    t = [rng.uniform(-half[0], half[0]), rng.uniform(-half[1], half[1]), 0.58 + rng.uniform(-0.03, 0.03)]
    return make_transform(R, t)
