"""The measured flat field: from frames of a lit card, against the cell's vignetting and corners."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml

from robot_app.calibration import (
    BoardConfig,
    DetectionSettings,
    apply_flat_field,
    detect_views,
    find_image_pairs,
    load_flat_field,
    measure_flat_field,
    read_robot_poses,
)
from robot_app.cli import main
from robot_app.geometry import invert_transform, make_transform, rotation_about_z, transform_points
from robot_app.sim.calibration_views import CalibrationViewSettings, capture_calibration_views
from robot_app.sim.config import load_world_config
from robot_app.vision.camera import load_rig
from tests._board_views import true_rig, write_views

SIZE = (320, 240)


def _radial_fall_off(width: int, height: int, vignetting: float) -> np.ndarray:
    """The realistic camera's vignetting (1 in the middle, 1 - vignetting in the corners): the truth."""
    u = (np.arange(width) - (width - 1) / 2) / ((width - 1) / 2)
    v = (np.arange(height) - (height - 1) / 2) / ((height - 1) / 2)
    r2 = (u[None, :] ** 2 * width**2 + v[:, None] ** 2 * height**2) / (width**2 + height**2)
    return 1.0 - vignetting * r2


@pytest.fixture(scope="module")
def cell_views(tmp_path_factory: pytest.TempPathFactory):
    world = load_world_config(None, (f"cameras.image_size=[{SIZE[0]},{SIZE[1]}]",))  # realistic
    assert world.imaging.vignetting > 0
    folder = tmp_path_factory.mktemp("flat") / "views"
    settings = CalibrationViewSettings(views=10, seed=1)
    result = capture_calibration_views(world, settings, folder)
    return world, settings, result


def test_the_flat_field_measured_in_the_cell_is_the_cameras_vignetting(cell_views) -> None:
    world, _, result = cell_views
    flat = load_flat_field(result.folder / "flat_field")
    assert flat.frames == (8, 8) and flat.image_size == SIZE
    truth = _radial_fall_off(*SIZE, world.imaging.vignetting)
    for side in ("left", "right"):
        measured = flat.side(side)
        inner = measured[8:-8, 8:-8] / truth[8:-8, 8:-8]  # the smoothing reaches the border's reflection
        assert np.abs(inner / inner.max() - 1).max() < 0.01
        assert measured.min() == pytest.approx(1 - world.imaging.vignetting, abs=0.02)


def _corner_offsets(world, settings, result, flat) -> tuple[float, float]:
    """Mean radial offset [px] of the found corners from the true projections, and the mean
    scale error of each view's corner grid about its centre [%]."""
    folder: Path = result.folder
    truth = load_rig(folder / "truth" / "rig.yaml")
    pairs = find_image_pairs(folder)
    poses = read_robot_poses(folder / "robot_poses.csv")
    views, _ = detect_views(pairs, settings.board, DetectionSettings(), flat_field=flat)
    base = make_transform(rotation_about_z(world.robot.base_yaw), world.robot.base_xyz)
    X = truth.transform_right_camera_to_hand
    centre = (np.array(SIZE) - 1) / 2
    radial, scales = [], []
    for view in views:
        right = base @ poses[view.pair.index] @ X
        for side, camera in (("right", right), ("left", right @ truth.transform_left_to_right)):
            found = view.side(side)
            if not found.usable:
                continue
            board_in_camera = invert_transform(camera) @ result.transform_board_to_world
            true = getattr(truth, side).project(
                transform_points(board_in_camera, settings.board.object_points()[found.corner_ids])
            )
            away = (true - centre) / np.linalg.norm(true - centre, axis=1, keepdims=True)
            radial.append(np.sum((found.image_points - true) * away, axis=1))
            t, f = true - true.mean(axis=0), found.image_points - found.image_points.mean(axis=0)
            scales.append(np.sum(f * t) / np.sum(t * t) - 1)
    return float(np.concatenate(radial).mean()), 100 * float(np.mean(scales))


def test_dividing_out_the_measured_flat_field_removes_the_corner_bias(cell_views) -> None:
    """Vignetting shrinks the corner grid the detector finds (the board looks farther away:
    -0.025 to -0.045 % on seeds 1-3 of 10 views); with the measured flat field divided out
    it is -0.006 to +0.007 %. (The mean radial offset alone is no measure: -0.005 px raw,
    +0.012 px flat on seed 3, -0.025 / -0.003 px on seed 1.)"""
    world, settings, result = cell_views
    _, scale_raw = _corner_offsets(world, settings, result, None)
    flat = load_flat_field(result.folder / "flat_field")
    _, scale_flat = _corner_offsets(world, settings, result, flat)
    assert scale_raw < -0.015, scale_raw
    assert abs(scale_flat) < 0.5 * abs(scale_raw), (scale_raw, scale_flat)


def test_frames_at_other_gains_and_noise_give_the_same_fall_off() -> None:
    rng = np.random.default_rng(0)
    truth = _radial_fall_off(160, 120, 0.3)
    frames = [
        np.clip(gain * 180 * truth[..., None] + rng.normal(0, 2, (120, 160, 3)), 0, 255).astype(np.uint8)
        for gain in (0.6, 0.9, 1.0, 1.2)
    ]
    measured = measure_flat_field(frames)
    assert np.abs(measured[4:-4, 4:-4] / truth[4:-4, 4:-4] - 1).max() < 0.01
    # dividing it out makes the card even again, without clipping the brightest part
    even = apply_flat_field(frames[2], measured).astype(float)[4:-4, 4:-4, 0]
    assert even.std() / even.mean() < 0.02 and even.max() < 255


# --- the commands: a flat field used by default, and bad flat fields


BOARD = BoardConfig(rows=7, cols=10, square_size=0.03)


@pytest.fixture(scope="module")
def views(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("flat_cli") / "views"
    folder.mkdir()
    write_views(folder, BOARD, true_rig(), 12, seed=5)
    return folder


def _write_card(folder: Path, size: tuple[int, int], level: int, frames: int = 2) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    card = (level * _radial_fall_off(*size, 0.2))[..., None].repeat(3, axis=2).astype(np.uint8)
    for n in range(frames):
        for side in ("left", "right"):
            cv2.imwrite(str(folder / f"{side}_{n:03d}.png"), card)
    return folder


def _stereo(images: Path, out: Path, *extra: str) -> int:
    board = images / "board.yaml"
    args = ["--images", str(images), "--board", str(board), "--out", str(out)]
    return main(["calibrate", "stereo", *args, *extra])


def _one_error_line(capsys) -> str:
    errors = [line for line in capsys.readouterr().err.splitlines() if line.startswith("error:")]
    assert len(errors) == 1, errors
    return errors[0]


def test_the_images_flat_field_folder_is_used_and_named_in_the_rig(views, tmp_path, capsys) -> None:
    out = tmp_path / "rig.yaml"
    assert _stereo(views, out) == 0
    assert "no flat field" in out.read_text()
    flat = _write_card(tmp_path / "card", (320, 240), 200)
    out_flat = tmp_path / "rig_flat.yaml"
    assert _stereo(views, out_flat, "--flat-field", str(flat)) == 0
    assert "divided out before the corners are found" in capsys.readouterr().out
    assert f"flat field {flat}" in out_flat.read_text()
    default_folder = tmp_path / "with_flat"
    default_folder.mkdir()
    for file in views.iterdir():
        (default_folder / file.name).write_bytes(file.read_bytes())
    _write_card(default_folder / "flat_field", (320, 240), 200)
    out_default = tmp_path / "rig_default.yaml"
    assert _stereo(default_folder, out_default) == 0
    assert f"flat field {default_folder / 'flat_field'}" in out_default.read_text()


@pytest.mark.parametrize(
    ("case", "key", "words"),
    [("wrong_size", "--flat-field", "the board images 320x240 px"), ("dark", "--flat-field", "too dark")],
)
def test_a_bad_flat_field_is_bad_input_and_writes_nothing(views, tmp_path, capsys, case, key, words) -> None:
    if case == "wrong_size":
        flat = _write_card(tmp_path / "card", (160, 120), 200)
    else:
        flat = _write_card(tmp_path / "card", (320, 240), 6)
    out = tmp_path / "rig.yaml"
    assert _stereo(views, out, "--flat-field", str(flat)) == 2
    line = _one_error_line(capsys)
    assert words in line and str(flat) in line
    assert not out.exists() and not (tmp_path / "rig_stereo_report").exists()
    rig = tmp_path / "stereo.yaml"
    rig.write_text(load_rig_text())
    before = rig.read_bytes()
    args = ["--images", str(views), "--robot-poses", str(views / "robot_poses.csv"), "--rig", str(rig)]
    args += ["--board", str(views / "board.yaml"), "--flat-field", str(flat)]
    assert main(["calibrate", "hand-eye", *args]) == 2
    assert words in _one_error_line(capsys)
    assert rig.read_bytes() == before and not (tmp_path / "stereo_hand_eye_report").exists()


def load_rig_text() -> str:
    """A stereo rig file (without the hand-eye transform) for the test images' cameras."""
    data = true_rig().to_dict()
    data.pop("transform_right_camera_to_hand")
    return yaml.safe_dump(data)
