"""The stereo depth check: the pose plane's depth from the pair alone, not from the model's size."""

from __future__ import annotations

import numpy as np
import pytest

from robot_app.config import validate
from robot_app.errors import ConfigError
from robot_app.geometry import make_transform, pose_error, rotation_from_rpy
from robot_app.vision.camera import ModelCamera, PinholeCamera, StereoRig
from robot_app.vision.cloth_model import ClothModel
from robot_app.vision.photo_model import make_model
from robot_app.vision.poses import moved
from robot_app.vision.recognizer import RecognitionSettings, Recognizer
from robot_app.vision.stereo_depth import DepthCheckSettings, StereoDepth
from robot_app.vision.synthetic import render_model_photo, render_stereo_pair
from robot_app.vision.synthetic_camera import CameraRealism
from robot_app.vision.synthetic_prints import extended_cloth

CAMERA = PinholeCamera.from_fov((640, 480), np.deg2rad(48))
RIG = StereoRig(CAMERA, CAMERA, make_transform(np.eye(3), [-0.1, 0.0, 0.0]))
MODEL_CAMERA = ModelCamera(CAMERA, 0.40)
POSE = make_transform(rotation_from_rpy(0.05, -0.04, 0.7), [0.03, -0.02, 0.585])
CAMERA_REALISM = CameraRealism(gain=0.8, white_balance=(1.05, 0.95, 1.1), shading=0.2, noise_sigma=6.0,
                               blur_sigma=1.0, jpeg_quality=75)  # fmt: skip
_MODELS: dict[int, ClothModel] = {}


def model(index: int) -> ClothModel:
    if index not in _MODELS:
        photo, background = render_model_photo(extended_cloth(index), MODEL_CAMERA)
        _MODELS[index] = make_model(photo, MODEL_CAMERA, background)
    return _MODELS[index]


def along_ray(pose: np.ndarray, offset: float) -> np.ndarray:
    return moved(pose, [0.0, 0.0, offset, 0.0, 0.0, 0.0])


@pytest.mark.parametrize("index", [0, 16])  # a plain red rectangle (edges only), a photographic print
@pytest.mark.parametrize("offset", [-0.03, -0.006, 0.0, 0.005, 0.045])
def test_the_sweep_finds_the_true_depth_from_a_pose_at_the_wrong_one(index: int, offset: float) -> None:
    left, right = render_stereo_pair(
        RIG, [(extended_cloth(index), POSE)], rng=np.random.default_rng(1), camera=CAMERA_REALISM
    )
    depth = StereoDepth(model(index), RIG, DepthCheckSettings())
    depth.update(left, right)
    measured = depth.measure(along_ray(POSE, offset))  # the model's size says nothing here
    assert measured.trusted and measured.samples >= DepthCheckSettings().min_samples
    assert measured.offset == pytest.approx(-offset, abs=0.0008)
    assert measured.correlation > 0.9


def test_too_few_edge_pixels_are_not_trusted_and_no_pair_is_a_programming_error() -> None:
    depth = StereoDepth(model(0), RIG, DepthCheckSettings())
    with pytest.raises(RuntimeError, match="update"):
        depth.measure(POSE)
    sheet = np.full((480, 640, 3), (60, 150, 45), np.uint8)  # the green sheet alone: no edge
    depth.update(sheet, sheet)
    measured = depth.measure(POSE)
    assert not measured.trusted and np.isnan(measured.offset)


def test_the_recognizer_takes_a_trusted_depth_and_reports_the_offset() -> None:
    left, right = render_stereo_pair(
        RIG, [(extended_cloth(16), POSE)], rng=np.random.default_rng(2), camera=CAMERA_REALISM
    )
    on = Recognizer(model(16), RIG).recognize(left, right, seed=1)
    off = Recognizer(model(16), RIG, validate(RecognitionSettings, {"depth": {"enabled": False}})).recognize(
        left, right, seed=1
    )
    assert np.isfinite(on.depth_offset) and np.isnan(off.depth_offset)
    error_on = pose_error(on.transform_model_to_camera, POSE, model(16).symmetry_angles)
    error_off = pose_error(off.transform_model_to_camera, POSE, model(16).symmetry_angles)
    assert abs(error_on.z_mm) <= 1.0
    # the hue search alone and the moved pose differ by the offset along the ray
    assert (
        off.transform_model_to_camera[2, 3] + on.depth_offset
        == pytest.approx(on.transform_model_to_camera[2, 3], abs=1e-6)
        or abs(on.depth_offset) > DepthCheckSettings().adopt_within
    )
    assert abs(error_on.z_mm) <= abs(error_off.z_mm) + 0.5


def test_settings_are_checked() -> None:
    with pytest.raises(ConfigError, match="smoothing"):
        validate(DepthCheckSettings, {"smoothing": 0})
    with pytest.raises(ConfigError, match="min_samples"):
        validate(DepthCheckSettings, {"min_samples": 3})
