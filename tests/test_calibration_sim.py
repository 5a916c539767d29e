"""The whole procedure in the simulated cell: board views, stereo and hand-eye against the URDF."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from robot_app.calibration import (
    DetectionSettings,
    calibrate_hand_eye,
    calibrate_stereo,
    detect_views,
    find_image_pairs,
    load_board,
    match_robot_poses,
    read_robot_poses,
)
from robot_app.cli import main
from robot_app.geometry import invert_transform, rotation_angle_between, transform_points
from robot_app.sim.calibration_views import CalibrationViewSettings, capture_calibration_views
from robot_app.sim.config import CameraSettings, WorldConfig
from robot_app.vision.camera import load_rig


@pytest.fixture(scope="module")
def capture(tmp_path_factory: pytest.TempPathFactory):
    folder = tmp_path_factory.mktemp("sim_views") / "views"
    settings = CalibrationViewSettings(views=30, seed=0)
    result = capture_calibration_views(WorldConfig(), settings, folder)  # 640 x 480, the world's default
    views, size = detect_views(find_image_pairs(folder), settings.board, DetectionSettings())
    return result, views, size, settings


def test_the_capture_writes_what_a_real_rig_would_give(capture) -> None:
    result, views, size, settings = capture
    folder: Path = result.folder
    assert result.count == 30 and size == (640, 480)
    assert len(list(folder.glob("left_*.png"))) == 30 and len(list(folder.glob("right_*.png"))) == 30
    assert load_board(folder / "board.yaml") == settings.board
    poses = read_robot_poses(folder / "robot_poses.csv")
    np.testing.assert_allclose(
        np.array([poses[i] for i in range(30)]), result.transforms_flange_to_base, atol=1e-8
    )
    assert sum(v.usable() for v in views) >= 0.75 * 30  # the rest show the board to one camera
    assert all(v.usable(("left",)) or v.usable(("right",)) for v in views)


def test_rendered_corners_land_where_the_true_rig_projects_them(capture) -> None:
    # the renderer and the rig file agree to a small fraction of a pixel (no half-pixel shift)
    result, views, _, settings = capture
    truth = load_rig(result.folder / "truth" / "rig.yaml")
    X = truth.transform_right_camera_to_hand
    assert X is not None
    offsets = []
    for view, flange in zip(views, result.transforms_flange_to_base, strict=True):
        right_to_world = flange @ X
        for side, camera_to_world in (
            ("right", right_to_world),
            ("left", right_to_world @ truth.transform_left_to_right),
        ):
            found = view.side(side)
            if not found.usable:
                continue
            board_in_camera = invert_transform(camera_to_world) @ result.transform_board_to_world
            points = transform_points(board_in_camera, settings.board.object_points()[found.corner_ids])
            offsets.append(found.image_points - getattr(truth, side).project(points))
    error = np.concatenate(offsets)
    assert np.all(np.abs(error.mean(axis=0)) < 0.03), error.mean(axis=0)
    assert np.sqrt(np.mean(np.sum(error**2, axis=1))) < 0.15


def test_calibration_from_the_cell_meets_the_issue_figures(capture) -> None:
    result, views, size, settings = capture
    truth = load_rig(result.folder / "truth" / "rig.yaml")
    stereo = calibrate_stereo(views, settings.board, size)
    assert stereo.rms_px <= 0.3
    for side in ("left", "right"):
        K, K_true = getattr(stereo.rig, side).camera_matrix, getattr(truth, side).camera_matrix
        assert abs(K[0, 0] / K_true[0, 0] - 1) <= 0.005 and abs(K[1, 1] / K_true[1, 1] - 1) <= 0.005
    assert abs(stereo.rig.baseline - truth.baseline) <= 0.5e-3
    poses = match_robot_poses(
        find_image_pairs(result.folder), read_robot_poses(result.folder / "robot_poses.csv")
    )
    hand_eye = calibrate_hand_eye(views, poses, stereo.rig, settings.board)
    X, X_true = hand_eye.transform_right_camera_to_hand, truth.transform_right_camera_to_hand
    assert X_true is not None
    assert np.linalg.norm(X[:3, 3] - X_true[:3, 3]) <= 1e-3
    assert rotation_angle_between(X[:3, :3], X_true[:3, :3]) <= np.deg2rad(0.2)
    board = hand_eye.transform_board_to_base
    assert np.linalg.norm(board[:3, 3] - result.transform_board_to_world[:3, 3]) < 2e-3


def test_the_sim_command_writes_a_folder_and_refuses_a_full_one(tmp_path, capsys) -> None:
    out = tmp_path / "views"
    size = ["--set", "cameras.image_size=[320,240]"]
    assert main(["sim", "calibration-views", "--out", str(out), "--views", "4", *size]) == 0
    assert "robot-app calibrate stereo" in capsys.readouterr().out
    assert {p.name for p in out.iterdir()} >= {"board.yaml", "robot_poses.csv", "truth", "left_003.png"}
    assert main(["sim", "calibration-views", "--out", str(out), "--views", "4", *size]) == 2
    assert "must be a new or empty folder" in capsys.readouterr().err


def test_camera_settings_reach_the_capture(tmp_path) -> None:
    world = WorldConfig(cameras=CameraSettings(image_size=(160, 120), hfov_deg=52.0))
    result = capture_calibration_views(world, CalibrationViewSettings(views=2), tmp_path / "v")
    rig = load_rig(result.folder / "truth" / "rig.yaml")
    assert rig.image_size == (160, 120)
    assert rig.right.camera_matrix[0, 0] == pytest.approx(80 / np.tan(np.deg2rad(26)))
