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
from robot_app.vision.plane_search import PlaneSearchSettings, onto_plane, poses_on_plane, search_in_plane
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
    for key, value in (("smoothing", 0), ("min_samples", 3)):
        with pytest.raises(ConfigError) as bad:
            validate(DepthCheckSettings, {key: value})
        assert (bad.value.key, bad.value.value) == (key, value)


def test_the_plane_fit_finds_depth_and_tilt_from_a_pose_far_off_both() -> None:
    left, right = render_stereo_pair(
        RIG, [(extended_cloth(0), POSE)], rng=np.random.default_rng(3), camera=CAMERA_REALISM
    )
    depth = StereoDepth(model(0), RIG, DepthCheckSettings())
    depth.update(left, right)
    wrong = along_ray(POSE, 0.04)
    wrong[:3, :3] = rotation_from_rpy(0.25, 0.1, 0.7)  # tilted 15° more than the cloth
    plane = depth.fit_plane(wrong)
    assert plane is not None and plane.trusted and plane.correlation > plane.correlation_at_pose + 0.2
    normal = POSE[:3, 2]
    assert np.degrees(np.arccos(np.clip(plane.normal @ normal, -1, 1))) < 2.0
    assert plane.distance == pytest.approx(normal @ POSE[:3, 3], abs=0.002)


def test_poses_on_a_plane_stay_on_it_and_keep_its_normal() -> None:
    normal = rotation_from_rpy(0.1, -0.05, 0.0)[:, 2]
    base = onto_plane(POSE, normal, 0.57)
    assert base[:3, 2] == pytest.approx(normal) and normal @ base[:3, 3] == pytest.approx(0.57)
    # the origin stays on the right camera's ray through it
    ray = POSE[:3, 3] / np.linalg.norm(POSE[:3, 3])
    assert base[:3, 3] / np.linalg.norm(base[:3, 3]) == pytest.approx(ray)
    moved_poses = poses_on_plane(base, np.array([[0.01, -0.02], [0.0, 0.0]]), np.array([0.3, np.pi]))
    for T in moved_poses:
        assert T[:3, 2] == pytest.approx(normal) and normal @ T[:3, 3] == pytest.approx(0.57)
        np.testing.assert_allclose(T[:3, :3].T @ T[:3, :3], np.eye(3), atol=1e-12)


def test_the_plane_search_finds_the_cloth_from_a_pose_on_its_plane_but_off_by_cm() -> None:
    index = 16  # a photographic print
    left, right = render_stereo_pair(RIG, [(extended_cloth(index), POSE)], rng=np.random.default_rng(4))
    recognizer = Recognizer(model(index), RIG)
    recognizer.recognize(left, right, seed=0)  # takes the pair
    start = poses_on_plane(POSE, np.array([[0.02, -0.015]]), np.array([np.deg2rad(9.0)]))[0]
    p = recognizer.proposer
    found = search_in_plane(
        start, p.fitness(4), p.fitness(), p.fitness(subpixel=True), PlaneSearchSettings(), recognizer._logits
    )
    error = pose_error(found[0], POSE, model(index).symmetry_angles)
    assert max(abs(error.x_mm), abs(error.y_mm)) < 1.0 and abs(error.yaw_deg) < 1.0


def test_peak_shift_finds_a_parabolas_vertex_between_samples() -> None:
    from robot_app.vision.stereo_depth import peak_shift

    step = 0.002
    x = np.arange(-3, 4) * step
    scores = 1.0 - (x - 0.0007) ** 2 * 1e4
    j = int(np.argmax(scores))
    assert x[j] + peak_shift(scores, j, step) == pytest.approx(0.0007, abs=1e-9)
    assert peak_shift(scores, 0, step) == 0.0  # at an end: no neighbour on one side
    assert peak_shift([0.0, 0.5, 1.0], 1, step) == 0.0  # a straight line does not bend down
