"""Board detection: sub-pixel corners numbered as the board's, and refusals with their reason."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from robot_app.calibration import BoardConfig, BoardDetection, DetectionSettings, detect_board
from robot_app.calibration.views import _check_squares
from robot_app.geometry import make_transform, rotation_about_z
from tests._board_views import render_view, true_rig

BOARD = BoardConfig(rows=7, cols=10, square_size=0.03)
CAMERA = true_rig().right


def _pose(board: BoardConfig, turn: float, tilt: tuple[float, float], depth: float) -> np.ndarray:
    s = board.square_size
    centre = np.array([(board.cols / 2 - 1) * s, (board.rows / 2 - 1) * s, 0.0])
    R = cv2.Rodrigues(np.array([*tilt, 0.0]))[0] @ rotation_about_z(turn)
    return make_transform(R, np.array([0.0, 0.0, depth]) - R @ centre)


def _truth(board: BoardConfig, pose: np.ndarray) -> np.ndarray:
    return CAMERA.project(board.object_points() @ pose[:3, :3].T + pose[:3, 3])


@pytest.mark.parametrize("turn_deg", [0, 90, 180, 270, 35, -150])
def test_corners_are_sub_pixel_and_numbered_as_the_board_whatever_its_turn(turn_deg) -> None:
    pose = _pose(BOARD, np.deg2rad(turn_deg), (0.25, -0.2), 0.55)
    found = detect_board(render_view(BOARD, CAMERA, pose), BOARD)
    assert found.usable, found.reason
    np.testing.assert_array_equal(found.corner_ids, np.arange(54))
    error = np.linalg.norm(found.image_points - _truth(BOARD, pose), axis=1)
    # OpenCV's sector-based detector: 0.05-0.13 px RMS on these views (measured)
    assert np.sqrt(np.mean(error**2)) < 0.2 and error.max() < 0.4, error.max()
    assert found.edge_width_px < 2.5


def test_a_blurred_view_is_refused_with_its_edge_width() -> None:
    image = render_view(BOARD, CAMERA, _pose(BOARD, 0.3, (0.1, 0.1), 0.5))
    sharp = detect_board(image, BOARD)
    blurred = detect_board(cv2.GaussianBlur(image, (0, 0), 2.5), BOARD)
    assert sharp.usable
    assert not blurred.usable and blurred.reason.startswith("too blurred")
    assert blurred.edge_width_px > 4.0 > sharp.edge_width_px
    relaxed = detect_board(
        cv2.GaussianBlur(image, (0, 0), 2.5), BOARD, DetectionSettings(max_edge_width_px=9)
    )
    assert relaxed.usable


def test_no_board_and_another_board_are_not_found() -> None:
    empty = np.full((240, 320, 3), 90, np.uint8)
    assert detect_board(empty, BOARD).reason == "board not found"
    other = BoardConfig(rows=9, cols=12, square_size=0.03)
    image = render_view(other, CAMERA, _pose(other, 0.2, (0.1, 0.0), 0.7))
    assert detect_board(image, other).usable
    assert detect_board(image, BOARD).reason == "board not found"


def test_a_grid_that_is_part_of_a_larger_board_is_refused() -> None:
    # the detector may lock onto part of a board (seen in the cell where a board reached
    # past the image border): take the first 9 x 6 corners of a 12 x 9-square board
    larger = BoardConfig(rows=9, cols=12, square_size=0.03)
    image = render_view(larger, CAMERA, _pose(larger, 0.0, (0.1, 0.05), 0.7))
    whole = detect_board(image, larger)
    grid = whole.image_points.reshape(8, 11, 2)
    for rows, cols in ((slice(0, 6), slice(0, 9)), (slice(1, 7), slice(1, 10))):
        part = BoardDetection(np.arange(54), grid[rows, cols].reshape(-1, 2), whole.edge_width_px)
        checked = _check_squares(part, BOARD, image)
        assert not checked.usable
        assert checked.reason.startswith(("board larger", "board pattern does not fit")), checked.reason
    board = render_view(BOARD, CAMERA, _pose(BOARD, 0.0, (0.1, 0.05), 0.7))
    assert _check_squares(detect_board(board, BOARD), BOARD, board).usable


def test_charuco_corners_carry_their_ids_also_when_partly_hidden() -> None:
    board = BoardConfig(type="charuco", rows=7, cols=10, square_size=0.03, marker_size=0.022)
    pose = _pose(board, 0.4, (0.2, 0.1), 0.55)
    image = render_view(board, CAMERA, pose)
    image[:, :110] = 90  # a third of the board out of sight
    found = detect_board(image, board)
    assert found.usable, found.reason
    assert 10 <= len(found.corner_ids) < 54
    error = np.linalg.norm(found.image_points - _truth(board, pose)[found.corner_ids], axis=1)
    assert error.max() < 0.5, error.max()


def _vignetted(image: np.ndarray, vignetting: float) -> np.ndarray:
    """The image under a radial fall-off: 1 in the middle, 1 - vignetting in the corners."""
    height, width = image.shape[:2]
    u = (np.arange(width) - (width - 1) / 2) / ((width - 1) / 2)
    v = (np.arange(height) - (height - 1) / 2) / ((height - 1) / 2)
    r2 = (u[None, :] ** 2 * width**2 + v[:, None] ** 2 * height**2) / (width**2 + height**2)
    return np.clip(image * (1.0 - vignetting * r2)[..., None] * 1.1, 0, 255).astype(np.uint8)


def test_flattening_the_shading_keeps_corners_as_accurate_under_vignetting() -> None:
    """25 % vignetting makes the detector's corners 0.17 px RMS off on these views, 0.11 px
    without it (measured); detected again in the flattened image they are back to ~0.11 px.
    (Off by default: it shrinks the grid by ~0.035 % where there is no vignetting.)"""
    errors: dict[float, list[float]] = {0.0: [], 0.5: []}
    for turn, tilt, depth in [(0, (0.25, -0.2), 0.45), (35, (-0.3, 0.1), 0.6), (-150, (0.0, 0.35), 0.72)]:
        pose = _pose(BOARD, np.deg2rad(turn), tilt, depth)
        image = _vignetted(render_view(BOARD, CAMERA, pose), 0.25)
        for sigma, found_errors in errors.items():
            found = detect_board(image, BOARD, DetectionSettings(flatten_sigma=sigma))
            assert found.usable, found.reason
            found_errors.append(
                float(np.sqrt(np.mean(np.sum((found.image_points - _truth(BOARD, pose)) ** 2, 1))))
            )
    assert np.mean(errors[0.5]) < 0.13
    assert np.mean(errors[0.5]) < 0.85 * np.mean(errors[0.0])
