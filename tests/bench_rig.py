"""The recognition bench's rig and catalogue models, shared by the vision tests (as
`scripts/bench_recognition.py` sets them up): 640x480 cameras of 48° field of view, 0.1 m
apart; model photos taken from 0.40 m; models made once per process."""

from __future__ import annotations

import numpy as np

from robot_app.geometry import make_transform
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
