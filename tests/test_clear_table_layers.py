"""Where the target lies over something, by the survey's stereo pair (`control.table_layers`):
a synthetic pair (numpy renderer) of a cloth whose one end lies on the table and whose other
end is raised, as over another cloth; the truth is the rendered plane's height."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from robot_app.control.grasp_point import PileGraspSettings, choose_pile_grasp, points_in_mask
from robot_app.control.table_layers import LayerSettings, grid_points, layer_map
from robot_app.control.table_surface import SurfaceSettings
from robot_app.geometry import make_transform, rotation_about_z, transform_points
from robot_app.vision import Recognition
from robot_app.vision.identify import IdentifySettings, resolve
from robot_app.vision.synthetic import render_stereo_pair
from robot_app.vision.synthetic_catalogue import synthetic_cloth
from tests.table_scene import RIG, recognizer

# the right camera 0.6 m above the table (z = 0), looking straight down
CAMERA_TO_WORLD = make_transform(np.diag([1.0, -1.0, -1.0]), [0.5, 0.0, 0.6])
TILT = 0.25  # rad about the model's y axis: one end 30 mm higher than the other


def _tilted() -> np.ndarray:
    c, s = np.cos(TILT), np.sin(TILT)
    about_y = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
    # in the camera frame (z down to the table): the model's origin 30 mm above the table
    return make_transform(rotation_about_z(0.3) @ about_y, [0.0, 0.01, 0.57])


@pytest.fixture(scope="module")
def scene():
    pose_in_camera = _tilted()
    rng = np.random.default_rng(5)
    left, right = render_stereo_pair(RIG, [(synthetic_cloth(10), pose_in_camera)], rng=rng)
    r = recognizer(10, "tilted")
    found = Recognition(True, 0.9, pose_in_camera, 0, 0, 0.0, confidence=0.95, visible_fraction=1.0)
    seen = {"tilted": found}
    ident = resolve({"tilted": r}, seen, right, IdentifySettings())
    capture = SimpleNamespace(left_bgr=left, right_bgr=right, transform_right_camera_to_world=CAMERA_TO_WORLD)
    return r, ident.detections[0], capture, CAMERA_TO_WORLD @ pose_in_camera


def test_the_raised_part_is_where_the_surface_truly_lies_higher(scene) -> None:
    r, detection, capture, pose = scene
    seen = points_in_mask(r.model.points_in, detection.transform_model_to_camera, RIG.right.camera_matrix,
                          detection.explained)  # fmt: skip
    points = transform_points(pose, r.model.points_in[seen])
    settings = LayerSettings()
    layers = layer_map(capture, RIG, r.model, r.settings.depth, detection.explained, points, 0.0, settings,
                       SurfaceSettings())  # fmt: skip
    assert layers.trusted >= 0.8 * len(layers.points)
    truth = layers.points[:, 2]  # the grid points lie on the rendered plane
    measured = np.isfinite(layers.heights)
    assert np.abs(layers.heights[measured] - truth[measured]).max() < 0.004
    low = float(np.sort(truth[measured])[settings.low_points - 1])
    assert layers.limit == pytest.approx(max(settings.single, low + settings.step), abs=0.003)
    raised = {tuple(p) for p in np.round(layers.raised, 6)}
    for point, z, ok in zip(layers.points, truth, measured, strict=True):
        if not ok or abs(z - layers.limit) < 0.003:
            continue  # within the measurement's error of the limit: either
        assert (tuple(np.round(point[:2], 6)) in raised) == (z > layers.limit)
    assert 0 < len(raised) < len(layers.points)


def test_the_pile_grasp_kept_off_the_raised_part_lands_where_the_cloth_lies_low(scene) -> None:
    r, detection, capture, pose = scene
    seen = points_in_mask(r.model.points_in, detection.transform_model_to_camera, RIG.right.camera_matrix,
                          detection.explained)  # fmt: skip
    points = transform_points(pose, r.model.points_in[seen])
    layers = layer_map(capture, RIG, r.model, r.settings.depth, detection.explained, points, 0.0,
                       LayerSettings(), SurfaceSettings())  # fmt: skip
    alone = choose_pile_grasp(r.model, pose, seen, np.empty((0, 2)), PileGraspSettings())
    kept = choose_pile_grasp(r.model, pose, seen, layers.raised, PileGraspSettings())
    assert alone is not None and kept is not None
    # the deepest point inside the cloth's edge lies in the middle, over the raised part's
    # edge; kept off that part, the grasp moves down the slope, clear of it
    assert kept.point_world[2] < layers.limit - 0.005
    assert kept.point_world[2] < alone.point_world[2] - 0.005
    assert kept.clearance >= 0.02


def test_grid_points_keep_one_point_per_square_nearest_its_centre() -> None:
    points = np.array([[0.001, 0.001, 0.0], [0.007, 0.008, 1.0], [0.016, 0.001, 2.0], [0.024, 0.009, 3.0]])
    kept = grid_points(points, 0.015)
    assert sorted(kept[:, 2]) == [1.0, 3.0]
    assert grid_points(np.empty((0, 3)), 0.015).shape == (0, 3)
