"""The tracking window's reachable image regions: every pixel a model in the window can
cover lies in them, and projecting the grown window's 8 corners gives the boxes of the
64 points (a cube of the model's radius around each window corner) projected before."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from robot_app.geometry import make_transform, rotation_from_rpy
from robot_app.vision.camera import PinholeCamera, StereoRig
from robot_app.vision.cloth_model import ClothModel
from robot_app.vision.ga import SearchBoundsSettings
from robot_app.vision.tracking_window import reachable_regions

CAMERA = PinholeCamera.from_fov((320, 240), np.deg2rad(48))
RIG = StereoRig(CAMERA, CAMERA, make_transform(np.eye(3), [-0.1, 0.0, 0.0]))


def _model(rng: np.random.Generator) -> ClothModel:
    inside = np.column_stack([rng.uniform(-0.06, 0.06, (80, 2)), np.zeros(80)])
    outside = np.column_stack([rng.uniform(-0.09, 0.09, (40, 2)), np.zeros(40)])
    return ClothModel("m", inside, np.full(80, 20, np.uint16), outside, 85.0, np.zeros(3), (0.12, 0.12))


def _window(rng: np.random.Generator) -> SearchBoundsSettings:
    x, y, z = rng.uniform(-0.2, 0.2), rng.uniform(-0.15, 0.15), rng.uniform(0.03, 0.7)
    half, depth = rng.uniform(0.005, 0.04), rng.uniform(0.005, 0.05)
    z_range = (max(z - depth, 1e-3), z + depth)
    return SearchBoundsSettings(x=(x - half, x + half), y=(y - half, y + half), z=z_range)


def _boxes_of_64_points(
    window: SearchBoundsSettings, model: ClothModel, rig: StereoRig
) -> list[npt.NDArray[np.int64]]:
    """The earlier projection: a cube of the model's radius around each of the window's 8 corners."""
    radius = float(np.max(np.linalg.norm(np.vstack([model.points_in, model.points_out]), axis=1)))
    corners = np.array(np.meshgrid(window.x, window.y, window.z, indexing="ij")).reshape(3, -1).T
    cube = np.array(np.meshgrid(*[(-radius, radius)] * 3, indexing="ij")).reshape(3, -1).T
    points = (corners[:, None, :] + cube[None, :, :]).reshape(-1, 3)
    width, height = rig.image_size
    boxes = []
    for camera, to_camera in ((rig.left, rig.transform_right_to_left), (rig.right, np.eye(4))):
        X = points @ to_camera[:3, :3].T + to_camera[:3, 3]
        if np.any(X[:, 2] <= 1e-3):
            boxes.append(np.array([0, 0, width - 1, height - 1], dtype=np.int64))
            continue
        uv = X[:, :2] / X[:, 2:] @ camera.camera_matrix[:2, :2].T + camera.camera_matrix[:2, 2]
        box = np.array([uv[:, 0].min() - 3, uv[:, 1].min() - 3, uv[:, 0].max() + 4, uv[:, 1].max() + 4])
        boxes.append(np.clip(np.floor(box), 0, [width - 1, height - 1] * 2).astype(np.int64))
    return boxes


def test_the_model_in_the_window_stays_in_the_regions_at_any_yaw_and_tilt() -> None:
    rng = np.random.default_rng(3)
    width, height = RIG.image_size
    whole = 0
    for _ in range(60):
        model, window = _model(rng), _window(rng)
        regions = reachable_regions(window, model, RIG)
        whole += all(np.array_equal(box, [0, 0, width - 1, height - 1]) for box in regions)
        points = np.vstack([model.points_in, model.points_out])
        for _ in range(20):
            origin = [rng.uniform(*window.x), rng.uniform(*window.y), rng.uniform(*window.z)]
            pose = make_transform(rotation_from_rpy(*rng.uniform(-np.pi, np.pi, 3)), origin)
            in_right = points @ pose[:3, :3].T + pose[:3, 3]
            for camera, to_camera, box in (
                (RIG.left, RIG.transform_right_to_left, regions[0]),
                (RIG.right, np.eye(4), regions[1]),
            ):
                X = in_right @ to_camera[:3, :3].T + to_camera[:3, 3]
                X = X[X[:, 2] > 1e-3]
                uv = X[:, :2] / X[:, 2:] @ camera.camera_matrix[:2, :2].T + camera.camera_matrix[:2, 2]
                seen = (uv[:, 0] >= 0) & (uv[:, 0] <= width - 1) & (uv[:, 1] >= 0) & (uv[:, 1] <= height - 1)
                u, v = uv[seen].T
                assert np.all((u >= box[0]) & (u <= box[2]) & (v >= box[1]) & (v <= box[3]))
    assert 0 < whole < 60  # some windows so close that a camera could see a model from behind


def test_the_corners_of_the_grown_window_give_the_boxes_of_all_64_points() -> None:
    rng = np.random.default_rng(4)
    for _ in range(300):
        model, window = _model(rng), _window(rng)
        boxes = reachable_regions(window, model, RIG)
        for box, expected in zip(boxes, _boxes_of_64_points(window, model, RIG), strict=True):
            np.testing.assert_array_equal(box, expected)


def test_the_model_radius_is_its_farthest_point() -> None:
    model = _model(np.random.default_rng(5))
    distances = np.linalg.norm(np.vstack([model.points_in, model.points_out]), axis=1)
    assert model.radius == distances.max() and model.radius == model.radius  # cached: the same value
