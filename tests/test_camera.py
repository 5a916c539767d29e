"""Contract tests of vision/camera.py: projection against OpenCV, YAML files, validation."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
import yaml

from robot_app.errors import CalibrationError, InputError
from robot_app.geometry import make_transform, rotation_from_rpy
from robot_app.vision.camera import (
    ModelCamera,
    PinholeCamera,
    StereoRig,
    load_model_camera,
    load_rig,
    save_model_camera,
    save_rig,
)

K = np.array([[410.0, 0.0, 315.2], [0.0, 405.5, 241.7], [0.0, 0.0, 1.0]])
DIST = np.array([-0.21, 0.07, 0.0012, -0.0008, -0.01])


def test_projection_matches_cv2_project_points_with_distortion():
    rng = np.random.default_rng(0)
    points = np.column_stack([rng.uniform(-0.2, 0.2, (200, 2)), rng.uniform(0.3, 0.9, 200)])
    camera = PinholeCamera(K, (640, 480), DIST)
    expected, _ = cv2.projectPoints(points, np.zeros(3), np.zeros(3), K, DIST)
    assert np.allclose(camera.project(points), expected.reshape(-1, 2), atol=1e-9)
    assert np.isnan(camera.project([0.0, 0.0, -1.0])).all()  # behind the camera


def test_stereo_projection_matches_cv2_in_both_cameras():
    rng = np.random.default_rng(1)
    left = PinholeCamera(K, (640, 480), DIST)
    right = PinholeCamera(K * [[1.01], [0.99], [1]], (640, 480), DIST * 0.5)
    R, T = rotation_from_rpy(0.01, -0.02, 0.005), np.array([-0.1, 0.002, 0.001])
    rig = StereoRig(left, right, make_transform(R, T))
    pose = make_transform(rotation_from_rpy(0.1, 0.2, 0.3), [0.02, -0.01, 0.6])
    model_points = rng.uniform(-0.1, 0.1, (50, 3)) * [1, 1, 0]
    pix_left, pix_right = rig.project_model(pose, model_points)
    in_right = model_points @ pose[:3, :3].T + pose[:3, 3]
    in_left = (in_right - T) @ R  # X_left = R^T (X_right - T)
    for camera, points, pixels in ((left, in_left, pix_left), (right, in_right, pix_right)):
        expected, _ = cv2.projectPoints(
            points, np.zeros(3), np.zeros(3), camera.camera_matrix, camera.dist_coeffs
        )
        assert np.allclose(pixels, expected.reshape(-1, 2), atol=1e-8)
    batch_left, _ = rig.project_model(np.stack([pose, pose]), model_points)
    assert batch_left.shape == (2, 50, 2) and np.allclose(batch_left[1], pix_left)


def test_from_fov_gives_the_requested_field_of_view():
    camera = PinholeCamera.from_fov((640, 480), np.deg2rad(48))
    edge = camera.project([np.tan(np.deg2rad(24)), 0.0, 1.0])
    assert edge[0] == pytest.approx(640.0) and edge[1] == pytest.approx(240.0)


def test_rig_and_model_camera_yaml_round_trip(tmp_path):
    hand = make_transform(np.eye(3), [0.05, -0.07, 0.06])
    rig = StereoRig(
        PinholeCamera(K, (640, 480), DIST), PinholeCamera(K, (640, 480)),
        make_transform(rotation_from_rpy(0.0, 0.01, 0.0), [-0.1, 0, 0]), hand,
    )  # fmt: skip
    save_rig(rig, tmp_path / "rig.yaml")
    loaded = load_rig(tmp_path / "rig.yaml")
    assert np.allclose(loaded.transform_left_to_right, rig.transform_left_to_right)
    assert np.allclose(loaded.left.dist_coeffs, DIST) and np.allclose(loaded.right.camera_matrix, K)
    assert loaded.transform_right_camera_to_hand is not None
    assert np.allclose(loaded.transform_right_camera_to_hand, hand)
    assert loaded.image_size == (640, 480) and loaded.baseline == pytest.approx(0.1)
    model_camera = ModelCamera(PinholeCamera(K, (640, 480), DIST), 0.4)
    save_model_camera(model_camera, tmp_path / "cam.yaml")
    again = load_model_camera(tmp_path / "cam.yaml")
    assert again.distance == 0.4 and np.allclose(again.camera.camera_matrix, K)


def _write_rig(path, **changes):
    data = {
        "image_size": [640, 480],
        "left": {"camera_matrix": K.tolist(), "dist_coeffs": [0] * 5},
        "right": {"camera_matrix": K.tolist(), "dist_coeffs": [0] * 5},
        "R": np.eye(3).tolist(),
        "T": [-0.1, 0, 0],
    }
    data.update(changes)
    path.write_text(yaml.safe_dump(data))
    return path


def test_bad_rig_files_are_calibration_errors(tmp_path):
    for name, R in (
        ("a.yaml", [[1, 0, 0], [0, 1, 0], [0, 0, -1]]),
        ("b.yaml", [[2, 0, 0], [0, 1, 0], [0, 0, 1]]),
    ):
        with pytest.raises(CalibrationError) as not_rotation:
            load_rig(_write_rig(tmp_path / name, R=R))
        assert (not_rotation.value.path, not_rotation.value.key, not_rotation.value.value) == (
            tmp_path / name,
            "R",
            R,
        )
    path = _write_rig(tmp_path / "c.yaml")
    data = yaml.safe_load(path.read_text())
    del data["T"]
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(CalibrationError) as no_T:
        load_rig(path)
    assert (no_T.value.path, no_T.value.key, no_T.value.has_value) == (path, "T", False)
    with pytest.raises(CalibrationError) as size:
        load_rig(_write_rig(tmp_path / "d.yaml", image_size=[640]))
    assert (size.value.path, size.value.key, size.value.value) == (tmp_path / "d.yaml", "image_size", [640])
    with pytest.raises(CalibrationError) as lens:
        load_rig(_write_rig(tmp_path / "f.yaml", right={"camera_matrix": K.tolist(), "dist_coeffs": [0] * 6}))
    assert (lens.value.path, lens.value.key, lens.value.value) == (
        tmp_path / "f.yaml",
        "right.dist_coeffs",
        [0] * 6,
    )
    (tmp_path / "e.yaml").write_text("[1, 2")
    with pytest.raises(CalibrationError) as not_yaml:
        load_rig(tmp_path / "e.yaml")
    assert (not_yaml.value.path, not_yaml.value.key) == (tmp_path / "e.yaml", None)
    for load in (load_rig, load_model_camera):
        with pytest.raises(InputError) as missing:
            load(tmp_path / "missing.yaml")
        assert missing.value.path == tmp_path / "missing.yaml"
        assert not isinstance(missing.value, CalibrationError)


def test_camera_and_rig_validation():
    with pytest.raises(CalibrationError) as sizes:
        StereoRig(PinholeCamera(K, (640, 480)), PinholeCamera(K, (320, 240)), np.eye(4))
    assert (sizes.value.key, sizes.value.value) == ("image_size", ((640, 480), (320, 240)))
    with pytest.raises(CalibrationError) as matrix:
        PinholeCamera(np.diag([-1.0, 1.0, 1.0]), (640, 480))
    assert (matrix.value.key, matrix.value.value) == ("camera_matrix", np.diag([-1.0, 1.0, 1.0]).tolist())
    with pytest.raises(CalibrationError) as size:
        PinholeCamera(K, (0, 480))
    assert (size.value.key, size.value.value) == ("image_size", (0, 480))
    with pytest.raises(CalibrationError) as lens:
        PinholeCamera(K, (640, 480), np.zeros(6))
    assert (lens.value.key, lens.value.value) == ("dist_coeffs", [0.0] * 6)
    with pytest.raises(CalibrationError) as distance:
        ModelCamera(PinholeCamera(K, (640, 480)), -0.4)
    assert (distance.value.key, distance.value.value) == ("distance", -0.4)
    with pytest.raises(ValueError, match=r"\(\.\.\., 3\)"):
        PinholeCamera(K, (640, 480)).project(np.zeros((4, 2)))
