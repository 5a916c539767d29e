"""Recognition: pure numpy/OpenCV, never imports pybullet."""

from robot_app.vision.camera import (
    ModelCamera,
    PinholeCamera,
    StereoRig,
    load_model_camera,
    load_rig,
    save_model_camera,
    save_rig,
)
from robot_app.vision.hue import circular_mean_hue, hue_distance, to_hsv, to_hue

__all__ = [
    "ModelCamera",
    "PinholeCamera",
    "StereoRig",
    "circular_mean_hue",
    "hue_distance",
    "load_model_camera",
    "load_rig",
    "save_model_camera",
    "save_rig",
    "to_hsv",
    "to_hue",
]
