"""`robot-app calibrate stereo | hand-eye` on files: the rig file, the reports, and bad input."""

from __future__ import annotations

import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml

from robot_app.calibration import BoardConfig
from robot_app.cli import main
from robot_app.geometry import rotation_angle_between
from robot_app.vision.camera import load_rig
from tests._board_views import true_rig, write_views

BOARD = BoardConfig(rows=7, cols=10, square_size=0.03)
TRUTH = true_rig()
VIEWS = 14


@pytest.fixture(scope="module")
def views(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("cli_views")
    write_views(folder, BOARD, TRUTH, VIEWS, seed=3)
    return folder


def _stereo(views: Path, out: Path, board: Path | None = None, *extra: str) -> int:
    board = board or views / "board.yaml"
    return main(
        ["calibrate", "stereo", "--images", str(views), "--board", str(board), "--out", str(out), *extra]
    )


def _hand_eye(views: Path, rig: Path, poses: Path | None = None, *extra: str) -> int:
    poses = poses or views / "robot_poses.csv"
    args = [
        "--images",
        str(views),
        "--robot-poses",
        str(poses),
        "--rig",
        str(rig),
        "--board",
        str(views / "board.yaml"),
    ]
    return main(["calibrate", "hand-eye", *args, *extra])


def _one_error_line(capsys) -> str:
    err = capsys.readouterr().err
    errors = [line for line in err.splitlines() if line.startswith("error:")]
    assert len(errors) == 1, err
    return errors[0]


def test_stereo_then_hand_eye_write_a_rig_the_recogniser_reads(views, tmp_path, capsys) -> None:
    rig_path = tmp_path / "rig.yaml"
    assert _stereo(views, rig_path) == 0
    out = capsys.readouterr().out
    assert f"used {VIEWS} of {VIEWS} views" in out
    stereo = load_rig(rig_path)
    assert stereo.transform_right_camera_to_hand is None
    assert abs(stereo.baseline - TRUTH.baseline) < 0.5e-3
    report = tmp_path / "rig_stereo_report"
    table = (report / "views.csv").read_text().splitlines()
    assert len(table) == VIEWS + 1 and table[0].startswith("view,left_file,right_file,status,reason")
    assert cv2.imread(str(report / "coverage.png")) is not None
    summary = yaml.safe_load((report / "summary.json").read_text())
    assert summary["reprojection_rms_px"] <= 0.3 and summary["views_used"] == VIEWS

    assert _hand_eye(views, rig_path) == 0
    assert "method" in capsys.readouterr().out
    calibrated = load_rig(rig_path)
    X, X_true = calibrated.transform_right_camera_to_hand, TRUTH.transform_right_camera_to_hand
    assert X is not None and X_true is not None
    assert np.linalg.norm(X[:3, 3] - X_true[:3, 3]) < 1e-3
    assert rotation_angle_between(X[:3, :3], X_true[:3, :3]) < np.deg2rad(0.2)
    # the intrinsics are refined with X from the robot poses: closer to the truth, not far from the stereo's
    for side in ("left", "right"):
        K, K_stereo = getattr(calibrated, side).camera_matrix, getattr(stereo, side).camera_matrix
        np.testing.assert_allclose(K, K_stereo, rtol=5e-3)
    assert "rig refined with X" in rig_path.read_text()
    assert (tmp_path / "rig_hand_eye_report" / "views.csv").is_file()
    assert rig_path.read_text().startswith("# robot-app calibrate hand-eye")


def test_too_few_usable_views_is_bad_input_and_writes_nothing(views, tmp_path, capsys) -> None:
    few = tmp_path / "few"
    few.mkdir()
    for n in range(5):
        for side in ("left", "right"):
            shutil.copy(views / f"{side}_{n:03d}.png", few)
    assert _stereo(few, tmp_path / "rig.yaml", views / "board.yaml") == 2
    line = _one_error_line(capsys)
    assert "too few usable views" in line and "5 of 5, need 10" in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["few"]


def test_a_board_file_that_does_not_match_the_images_is_bad_input(views, tmp_path, capsys) -> None:
    board = tmp_path / "board.yaml"
    board.write_text(yaml.safe_dump({"type": "checkerboard", "rows": 6, "cols": 9, "square_size": 0.03}))
    assert _stereo(views, tmp_path / "rig.yaml", board) == 2
    line = _one_error_line(capsys)
    assert str(board) in line and "found in none" in line
    assert not (tmp_path / "rig.yaml").exists() and not (tmp_path / "rig_stereo_report").exists()


def test_robot_poses_that_do_not_match_the_images_are_bad_input(views, tmp_path, capsys) -> None:
    rig_path = tmp_path / "rig.yaml"
    rig_path.write_text(yaml.safe_dump({**_rig_dict(), "note": None}))
    before = rig_path.read_bytes()
    poses = tmp_path / "poses.csv"
    poses.write_text("\n".join((views / "robot_poses.csv").read_text().splitlines()[:-1]) + "\n")
    assert _hand_eye(views, rig_path, poses) == 2
    line = _one_error_line(capsys)
    assert f"{VIEWS - 1} robot poses" in line and f"{VIEWS} views" in line
    assert rig_path.read_bytes() == before
    assert not (tmp_path / "rig_hand_eye_report").exists()


def _rig_dict() -> dict:
    data = TRUTH.to_dict()
    data.pop("transform_right_camera_to_hand")
    return data


@pytest.mark.parametrize(
    ("case", "expected"),
    [
        ("no_folder", "image folder not found"),
        ("bad_board", "square_size"),
        ("out_is_a_folder", "folder"),
    ],
)
def test_other_bad_input_fails_before_any_work(views, tmp_path, capsys, case, expected) -> None:
    board, images, out = views / "board.yaml", views, tmp_path / "rig.yaml"
    if case == "no_folder":
        images = tmp_path / "nowhere"
    elif case == "bad_board":
        board = tmp_path / "board.yaml"
        board.write_text("rows: 7\ncols: 10\nsquare_size: 30\n")
    else:
        out.mkdir()
    assert _stereo(images, out, board) == 2
    assert expected in _one_error_line(capsys)
    assert not out.is_file() and not (tmp_path / "rig_stereo_report").exists()
