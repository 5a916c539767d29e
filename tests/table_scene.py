"""The small synthetic stereo rig and model station the clear-table unit tests share, and a
recogniser of a catalogue cloth photographed at that station."""

from __future__ import annotations

import numpy as np

from robot_app.geometry import make_transform
from robot_app.vision import ModelCamera, PinholeCamera, Recognizer, StereoRig, make_model
from robot_app.vision.synthetic import render_model_photo
from robot_app.vision.synthetic_catalogue import synthetic_cloth

CAMERA = PinholeCamera.from_fov((320, 240), np.deg2rad(48))
RIG = StereoRig(CAMERA, CAMERA, make_transform(np.eye(3), [-0.1, 0.0, 0.0]))
STATION = ModelCamera(PinholeCamera.from_fov((480, 360), np.deg2rad(48)), 0.40)


def recognizer(index: int, name: str) -> Recognizer:
    """A recogniser of synthetic catalogue cloth `index`, its model made at STATION."""
    photo, background = render_model_photo(synthetic_cloth(index), STATION, rng=np.random.default_rng(index))
    return Recognizer(make_model(photo, STATION, background, name=name), RIG)
