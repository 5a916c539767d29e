"""Board files: validation of each key, round trip, corner numbering, the printable image."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from robot_app.calibration import BoardConfig, board_image, load_board, save_board
from robot_app.errors import ConfigError


def test_board_file_round_trip_and_geometry(tmp_path) -> None:
    board = BoardConfig(rows=7, cols=10, square_size=0.03)
    loaded = load_board(save_board(board, tmp_path / "board.yaml"))
    assert loaded == board
    assert set(yaml.safe_load((tmp_path / "board.yaml").read_text())) == {
        "type",
        "rows",
        "cols",
        "square_size",
    }
    points = loaded.object_points()
    assert points.shape == (54, 3) and loaded.inner_corners == (9, 6)
    np.testing.assert_allclose(points[1] - points[0], [0.03, 0, 0])  # along a row: board x
    np.testing.assert_allclose(points[9] - points[0], [0, 0.03, 0])  # next row: board y
    assert not points.flags.writeable


@pytest.mark.parametrize(
    ("data", "key"),
    [
        ({"rows": 7, "cols": 9, "square_size": 0.03}, "<top level>"),  # both odd: half turn ambiguous
        ({"rows": 8, "cols": 10, "square_size": 0.03}, "<top level>"),  # both even
        ({"rows": 2, "cols": 9, "square_size": 0.03}, "rows"),
        ({"rows": 7, "cols": 10, "square_size": -0.03}, "square_size"),
        ({"rows": 7, "cols": 10, "square_size": 30}, "square_size"),  # millimetres, not metres
        ({"rows": 7, "cols": 10}, "square_size"),
        ({"rows": 7, "cols": 10, "square_size": 0.03, "colour": "red"}, "colour"),
        ({"type": "charuco", "rows": 7, "cols": 10, "square_size": 0.03, "marker_size": 0.04}, "<top level>"),
        ({"type": "april", "rows": 7, "cols": 10, "square_size": 0.03}, "type"),
    ],
)
def test_a_bad_board_file_names_its_key(tmp_path, data, key) -> None:
    path = tmp_path / "board.yaml"
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(ConfigError) as caught:
        load_board(path)
    assert caught.value.key == key
    assert caught.value.path == path
    assert caught.value.exit_code == 2


def test_board_image_puts_the_inner_corners_where_its_docstring_says() -> None:
    board = BoardConfig(rows=5, cols=6, square_size=0.02)
    p = 20
    image = board_image(board, p, 1.0).astype(int)
    assert image.shape == ((5 + 2) * p, (6 + 2) * p)
    # square (0, 0) is black, (0, 1) white, the margin white
    assert image[p + p // 2, p + p // 2] == 0 and image[p + p // 2, 2 * p + p // 2] == 255
    assert image[p // 2, p // 2] == 255
    # inner corner (0, 0) at pixel (m + p - 0.5, m + p - 0.5): the four pixels around it alternate
    c = 2 * p
    assert image[c - 1, c - 1] == 0 and image[c, c] == 0 and image[c - 1, c] == 255 and image[c, c - 1] == 255


def test_charuco_board_has_its_markers() -> None:
    board = BoardConfig(type="charuco", rows=5, cols=7, square_size=0.04, marker_size=0.03)
    assert board.charuco_board().getChessboardCorners().shape == (24, 3)
    image = board_image(board, 40)
    assert image.shape == (7 * 40, 9 * 40)
    assert 0.3 < np.mean(image < 128) < 0.7
