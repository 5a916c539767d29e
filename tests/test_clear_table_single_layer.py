"""The pile grasp moved to where the target lies on no other cloth (`table_surface.
single_layer_grasp`): a synthetic pair (numpy renderer) of a cloth draped over another, as a
tilted plane whose height at every point is known (the ground truth)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from robot_app.control.grasp_point import PileGraspSettings, choose_pile_grasp, points_in_mask
from robot_app.control.table_surface import SurfaceSettings, single_layer_grasp
from robot_app.geometry import make_transform, rotation_about_z
from robot_app.vision import ModelCamera, PinholeCamera, Recognition, Recognizer, StereoRig, make_model
from robot_app.vision.identify import IdentifySettings, resolve
from robot_app.vision.synthetic import render_model_photo, render_stereo_pair
from robot_app.vision.synthetic_catalogue import synthetic_cloth

CAMERA = PinholeCamera.from_fov((320, 240), np.deg2rad(48))
RIG = StereoRig(CAMERA, CAMERA, make_transform(np.eye(3), [-0.1, 0.0, 0.0]))
STATION = ModelCamera(PinholeCamera.from_fov((480, 360), np.deg2rad(48)), 0.40)
CAMERA_TO_WORLD = make_transform(np.diag([1.0, -1.0, -1.0]), [0.5, 0.0, 0.6])  # 0.6 m above, looking down
SLOPE = -0.16  # the draped cloth falls 16 mm per 100 mm along its x_M
# in Σ_CR: z_C = 0.576 - SLOPE * x_M, i.e. the height above the table 24 mm + SLOPE * x_M
_TILT = np.array([[np.sqrt(1 - SLOPE**2), 0.0, SLOPE], [0.0, 1.0, 0.0], [-SLOPE, 0.0, np.sqrt(1 - SLOPE**2)]])
DRAPED = make_transform(_TILT @ rotation_about_z(0.1), [0.0, 0.02, 0.576])
FLAT = make_transform(rotation_about_z(-0.3), [0.0, 0.02, 0.592])  # 8 mm: one layer on the table


def _scene(pose: np.ndarray):
    left, right = render_stereo_pair(RIG, [(synthetic_cloth(10), pose)], rng=np.random.default_rng(5))
    photo, background = render_model_photo(synthetic_cloth(10), STATION, rng=np.random.default_rng(10))
    recognizer = Recognizer(make_model(photo, STATION, background, name="top"), RIG)
    seen = {"top": Recognition(True, 0.9, pose, 0, 0, 0.0, confidence=0.95, visible_fraction=1.0)}
    detection = resolve({"top": recognizer}, seen, right, IdentifySettings()).detections[0]
    capture = SimpleNamespace(left_bgr=left, right_bgr=right, transform_right_camera_to_world=CAMERA_TO_WORLD)
    return recognizer, detection, capture


def _true_height(pose: np.ndarray, point_model: np.ndarray) -> float:
    return float((CAMERA_TO_WORLD @ pose @ np.append(point_model[:2], [0.0, 1.0]))[2])


def _first(recognizer: Recognizer, detection, pile: PileGraspSettings):
    pose_world = CAMERA_TO_WORLD @ detection.transform_model_to_camera
    model = recognizer.model
    seen = points_in_mask(
        model.points_in, detection.transform_model_to_camera, CAMERA.camera_matrix, detection.explained
    )
    return pose_world, choose_pile_grasp(model, pose_world, seen, np.empty((0, 2)), pile)


def test_a_draped_cloth_is_grasped_where_it_lies_on_the_table() -> None:
    recognizer, detection, capture = _scene(DRAPED)
    pile = PileGraspSettings(reach=0.035)
    pose_world, first = _first(recognizer, detection, pile)
    assert first is not None
    first_height = _true_height(DRAPED, first.point_model)
    settings = SurfaceSettings(single_layer=0.016)
    assert first_height > settings.single_layer  # the deepest point lies on the other cloth
    moved, note = single_layer_grasp(
        capture, RIG, recognizer, detection, pose_world, np.empty((0, 2)), first, 0.0, settings, pile
    )
    assert moved is not None and moved is not first and note.startswith("grasp moved to a single layer")
    height = _true_height(DRAPED, moved.point_model)
    assert height < first_height - settings.layer_gain
    assert height < 0.024  # on the low half, where nothing lies under it (x_M > 0)
    assert moved.edge_gap >= pile.min_edge_gap - 1e-9  # still well on the cloth
    off, _ = single_layer_grasp(
        capture, RIG, recognizer, detection, pose_world, np.empty((0, 2)), first, 0.0, SurfaceSettings(), pile
    )
    assert off is first  # single_layer 0: the check is off


def test_a_cloth_lying_flat_on_the_table_keeps_its_grasp() -> None:
    recognizer, detection, capture = _scene(FLAT)
    pile = PileGraspSettings(reach=0.035)
    pose_world, first = _first(recognizer, detection, pile)
    assert first is not None and _true_height(FLAT, first.point_model) == pytest.approx(0.008)
    kept, note = single_layer_grasp(
        capture, RIG, recognizer, detection, pose_world, np.empty((0, 2)), first, 0.0,
        SurfaceSettings(single_layer=0.016), pile,
    )  # fmt: skip
    assert kept is first and note == ""
