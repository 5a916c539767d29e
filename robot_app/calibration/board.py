"""The calibration board: a checkerboard or ChArUco board described by a small YAML file.

Board YAML (lengths [m]); `rows` and `cols` count squares, as board generators print them:
```yaml
type: checkerboard     # or charuco
rows: 7                # squares along the board's y axis
cols: 10               # squares along the board's x axis
square_size: 0.030     # side of one square [m], as measured on the printed board
marker_size: 0.022     # charuco only: side of an ArUco marker [m]
dictionary: DICT_4X4_50  # charuco only: an OpenCV ArUco dictionary name
```
Board frame Σ_B: origin at the first inner corner (the corner shared by squares (0, 0),
(0, 1), (1, 0) and (1, 1)), x along the columns, y along the rows, z = x × y into the
board. Square (row i, col j) is black when i + j is even. Inner corner k lies at
(k % (cols - 1), k // (cols - 1)) · square_size, the order OpenCV's checkerboard
detector returns them in. A checkerboard needs one odd and one even count: only then
does a half turn change its look, so every view numbers the corners the same way.
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

import cv2
import numpy as np
import numpy.typing as npt
import yaml
from pydantic import Field, model_validator

from robot_app.arrays import FloatArray
from robot_app.config import StrictModel, load_config
from robot_app.outputs import atomic_write_text

BoardType = Literal["checkerboard", "charuco"]


class BoardConfig(StrictModel):
    """A calibration board file (see the module docstring)."""

    type: BoardType = "checkerboard"
    rows: int = Field(ge=3, le=60, description="squares along the board's y axis")
    cols: int = Field(ge=3, le=60, description="squares along the board's x axis")
    square_size: float = Field(gt=0.0, lt=1.0, description="side of one square [m]")
    marker_size: float | None = Field(None, gt=0.0, lt=1.0, description="charuco marker side [m]")
    dictionary: str = "DICT_4X4_50"

    @model_validator(mode="after")
    def _consistent(self) -> BoardConfig:
        if self.type == "checkerboard" and (self.rows + self.cols) % 2 == 0:
            raise ValueError(
                f"a checkerboard needs one odd and one even square count (got rows={self.rows}, "
                f"cols={self.cols}): with both odd or both even a half-turned board looks the same"
            )
        if self.type == "charuco":
            if self.marker_size is None or self.marker_size >= self.square_size:
                raise ValueError(
                    f"a charuco board needs 0 < marker_size < square_size [m], got {self.marker_size}"
                )
            if not self.dictionary.startswith("DICT_") or not hasattr(cv2.aruco, self.dictionary):
                raise ValueError(f"unknown ArUco dictionary {self.dictionary!r} (e.g. DICT_4X4_50)")
            needed = (self.rows * self.cols) // 2
            if needed > _dictionary_size(self.dictionary):
                raise ValueError(f"{self.dictionary} has fewer than the {needed} markers the board needs")
        return self

    @property
    def inner_corners(self) -> tuple[int, int]:
        """(columns, rows) of inner corners: OpenCV's `patternSize`."""
        return self.cols - 1, self.rows - 1

    @property
    def corner_count(self) -> int:
        return (self.cols - 1) * (self.rows - 1)

    @property
    def size(self) -> tuple[float, float]:
        """Printed extent of the squares along x and y [m] (without a white margin)."""
        return self.cols * self.square_size, self.rows * self.square_size

    def describe(self) -> str:
        """One phrase for messages, e.g. '10x7-square checkerboard of 30.0 mm'."""
        return f"{self.cols}x{self.rows}-square {self.type} of {self.square_size * 1000:.1f} mm"

    def object_points(self) -> FloatArray:
        """(corner_count, 3) inner corners in Σ_B [m], in corner-id order."""
        cols, rows = self.inner_corners
        grid = np.mgrid[0:rows, 0:cols]
        points = np.zeros((rows * cols, 3))
        points[:, 0] = grid[1].ravel() * self.square_size
        points[:, 1] = grid[0].ravel() * self.square_size
        points.setflags(write=False)
        return points

    def square_is_black(self, row: npt.ArrayLike, col: npt.ArrayLike) -> npt.NDArray[np.bool_]:
        """Colour of squares (row, col), counted from the board's corner at (-s, -s)."""
        return (np.asarray(row) + np.asarray(col)) % 2 == 0

    def charuco_board(self) -> cv2.aruco.CharucoBoard:
        """The OpenCV ChArUco board (charuco boards only)."""
        if self.type != "charuco" or self.marker_size is None:
            raise ValueError("charuco_board() needs a board of type charuco")
        dictionary = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, self.dictionary))
        return cv2.aruco.CharucoBoard((self.cols, self.rows), self.square_size, self.marker_size, dictionary)


def _dictionary_size(name: str) -> int:
    dictionary = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, name))
    return int(dictionary.bytesList.shape[0])


def load_board(path: str | Path) -> BoardConfig:
    """Reads a board YAML file; a bad or missing key is a ConfigError naming it (exit 2)."""
    return load_config(BoardConfig, path)


def save_board(board: BoardConfig, path: str | Path) -> Path:
    """Writes the board YAML atomically (only the keys its type uses)."""
    data = board.model_dump()
    if board.type == "checkerboard":
        data.pop("marker_size")
        data.pop("dictionary")
    return atomic_write_text(path, yaml.safe_dump(data, sort_keys=False))


def board_image(
    board: BoardConfig, pixels_per_square: int = 60, margin_squares: float = 1.0
) -> npt.NDArray[np.uint8]:
    """A printable grey image of the board with a white margin (for a printer or a test).

    Square (i, j) covers pixels [m + j p, m + (j + 1) p) x [m + i p, m + (i + 1) p) where p
    is `pixels_per_square` and m the margin, so inner corner (r, c) sits at pixel
    (m + (c + 1) p - 0.5, m + (r + 1) p - 0.5) in OpenCV's pixel-centre convention.
    """
    if pixels_per_square < 4:
        raise ValueError(f"pixels_per_square must be >= 4, got {pixels_per_square}")
    p = int(pixels_per_square)
    m = round(margin_squares * p)
    width, height = board.cols * p, board.rows * p
    if board.type == "charuco":
        squares = board.charuco_board().generateImage((width, height), marginSize=0, borderBits=1)
    else:
        rows, cols = np.indices((board.rows, board.cols))
        black = board.square_is_black(rows, cols)
        squares = np.where(np.kron(black, np.ones((p, p), bool)), 0, 255).astype(np.uint8)
    image = np.full((height + 2 * m, width + 2 * m), 255, np.uint8)
    image[m : m + height, m : m + width] = squares
    return image


__all__ = ["BoardConfig", "BoardType", "board_image", "load_board", "save_board"]
