"""Finding the board's inner corners in one image, or saying why not.

Checkerboards go through OpenCV's sector-based detector (`findChessboardCornersSB`, sub-
pixel accurate by itself), then the corner order is made the board's own: OpenCV may
return the grid mirrored or half-turned, and a calibration that mixes orders mixes up the
board frame between views.

Brightness that varies across a corner (vignetting, a lamp from the side) moves the
detector's corners: through the realistic camera model at 320x240 (25 % vignetting) the
hand-eye X came out 0.5-1.1 mm off along the optical axis. The remedy a real rig uses is a
measured flat field divided out of the images before they get here
(`robot_app.calibration.flat_field`, what `robot-app calibrate` does when it has one).
`flatten_sigma` > 0 is an older, image-only alternative: it detects a found board a
second time in the image divided by its local mean (a Gaussian of that many corner
spacings; 0.4-0.6 measured as good, 1.5 no better than none), which evens out the black
and white levels around each corner (the first detection stays if the second fails). It is off by
default: without vignetting it shrinks the corner grid by ~0.035 % (measured on the
anti-aliased test views), enough to move a calibrated lens model 1.1 px at the image
edge. That shrink (~0.2 mm of depth at 0.6 m) may be part of why it helps in the cell:
it can offset the vignetting's bias as well as remove it. Measure with
scripts/bench_calibration.py --flatten-sigma 0.5.
ChArUco corners carry their ids.
A view whose edges are wider than `max_edge_width_px` (10-90 % rise) is rejected as too
blurred.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt
from pydantic import Field

from robot_app.arrays import FloatArray, ImageBGR
from robot_app.calibration.board import BoardConfig
from robot_app.config import StrictModel

IntArray = npt.NDArray[np.int64]


class DetectionSettings(StrictModel):
    """How corners are found and which views are refused."""

    max_edge_width_px: float = Field(
        4.0, gt=0.0, description="refuse a view whose edges rise over more pixels than this (blur)"
    )
    min_charuco_corners: int = Field(8, ge=4, description="fewest ChArUco corners a view may have")
    flatten_sigma: float = Field(
        0.0,
        ge=0.0,
        le=5.0,
        description="checkerboards: detect again in the image over its local mean, a Gaussian of "
        "this many corner spacings (0: off)",
    )


@dataclass(frozen=True)
class BoardDetection:
    """The board in one image, or the reason it is not usable.

    Attributes:
        corner_ids: (N,) indices into `BoardConfig.object_points()`.
        image_points: (N, 2) sub-pixel corner positions [px].
        edge_width_px: median 10-90 % edge rise around the corners [px] (NaN if not found).
        reason: empty for a usable view, else why it is refused.
    """

    corner_ids: IntArray
    image_points: FloatArray
    edge_width_px: float
    reason: str = ""

    @property
    def usable(self) -> bool:
        return not self.reason

    @classmethod
    def refused(cls, reason: str, edge_width_px: float = float("nan")) -> BoardDetection:
        return cls(np.zeros(0, np.int64), np.zeros((0, 2)), edge_width_px, reason)


def detect_board(
    image: ImageBGR, board: BoardConfig, settings: DetectionSettings | None = None
) -> BoardDetection:
    """Finds the board's inner corners in a BGR (or grey) image."""
    s = settings or DetectionSettings()
    array = np.asarray(image)
    gray = np.asarray(cv2.cvtColor(array, cv2.COLOR_BGR2GRAY) if array.ndim == 3 else array, dtype=np.uint8)
    if board.type == "charuco":
        ids, points = _charuco_corners(gray, board)
        if len(ids) < s.min_charuco_corners:
            seen = f"{len(ids)} ChArUco corners" if len(ids) else "no ChArUco corners"
            return BoardDetection.refused(f"board not found ({seen}, need {s.min_charuco_corners})")
    else:
        # without CALIB_CB_ACCURACY: on tilted boards in the simulator it moved corners so
        # that focal lengths came out 0.15 % long on average (0.05 % without it)
        flags = cv2.CALIB_CB_EXHAUSTIVE | cv2.CALIB_CB_NORMALIZE_IMAGE
        found, corners = cv2.findChessboardCornersSB(gray, board.inner_corners, flags=flags)
        if not found:
            return BoardDetection.refused("board not found")
        if s.flatten_sigma > 0:
            spacing = _corner_spacing(np.asarray(corners, dtype=float).reshape(-1, 2))
            flat = flatten_shading(gray, s.flatten_sigma * spacing)
            again, flat_corners = cv2.findChessboardCornersSB(flat, board.inner_corners, flags=flags)
            if again:
                corners = flat_corners
        points = _board_order(np.asarray(corners, dtype=float).reshape(-1, 2), board, gray)
        ids = np.arange(board.corner_count, dtype=np.int64)
    width = edge_width(gray, points)
    if not width <= s.max_edge_width_px:
        return BoardDetection.refused(
            f"too blurred: edges rise over {width:.1f} px (limit {s.max_edge_width_px:.1f} px)", width
        )
    points.setflags(write=False)
    ids.setflags(write=False)
    return BoardDetection(ids, points, width)


def flatten_shading(gray: npt.NDArray[np.uint8], sigma_px: float) -> npt.NDArray[np.uint8]:
    """The grey image divided by its local mean (Gaussian of `sigma_px`), mid grey 128."""
    g = gray.astype(np.float32)
    mean = cv2.GaussianBlur(g, (0, 0), max(sigma_px, 0.5))
    return np.clip(128.0 * g / np.maximum(mean, 1.0), 0, 255).astype(np.uint8)


def _corner_spacing(points: FloatArray) -> float:
    """Median distance from a corner to its nearest neighbour [px]."""
    d = np.linalg.norm(points[:, None] - points[None], axis=2)
    np.fill_diagonal(d, np.inf)
    return float(np.median(d.min(axis=1)))


def _charuco_corners(gray: npt.NDArray[np.uint8], board: BoardConfig) -> tuple[IntArray, FloatArray]:
    detector = cv2.aruco.CharucoDetector(board.charuco_board())
    corners, ids, _, _ = detector.detectBoard(gray)
    if ids is None or corners is None:
        return np.zeros(0, np.int64), np.zeros((0, 2))
    return np.asarray(ids, np.int64).reshape(-1), np.asarray(corners, float).reshape(-1, 2)


def _board_order(points: FloatArray, board: BoardConfig, gray: npt.NDArray[np.uint8]) -> FloatArray:
    """Reorders OpenCV's corner grid so that corner k is the board's corner k (module docstring).

    A board seen from its front turns its x axis into its y axis the way the image's x
    turns into y; a mirrored grid does the opposite. A half turn swaps the colours of
    the inner squares (one odd, one even square count), which the image shows.
    """
    cols, rows = board.inner_corners
    grid = points.reshape(rows, cols, 2)
    along_x, along_y = grid[0, -1] - grid[0, 0], grid[-1, 0] - grid[0, 0]
    if along_x[0] * along_y[1] - along_x[1] * along_y[0] < 0:
        grid = grid[:, ::-1]
    # squares (i, j), 1 <= i <= rows - 1, 1 <= j <= cols - 1 (board counts), between four corners
    centres = (grid[:-1, :-1] + grid[:-1, 1:] + grid[1:, :-1] + grid[1:, 1:]) / 4
    i, j = np.indices(centres.shape[:2]) + 1
    black = board.square_is_black(i, j)
    values = _sample(gray, centres.reshape(-1, 2)).reshape(black.shape)
    if values[black].mean() > values[~black].mean():
        grid = grid[::-1, ::-1]
    return np.ascontiguousarray(grid.reshape(-1, 2))


def _sample(gray: npt.NDArray[np.uint8], points: FloatArray) -> FloatArray:
    """Grey values (3x3 mean) at pixel positions (nearest pixel, clipped to the image)."""
    smooth = cv2.blur(gray, (3, 3))
    h, w = gray.shape
    u = np.clip(np.rint(points[:, 0]).astype(int), 0, w - 1)
    v = np.clip(np.rint(points[:, 1]).astype(int), 0, h - 1)
    return np.asarray(smooth[v, u], dtype=float)


def edge_width(gray: npt.NDArray[np.uint8], points: FloatArray) -> float:
    """Median 10-90 % rise [px] of the board's edges around the given corners.

    A step from dark to light blurred by a Gaussian of σ px rises over about 2.56 σ; its
    steepest gradient is contrast / (σ √(2π)). So the rise is ~1.02 · contrast / steepest
    gradient, measured in a window of a third of the corner spacing around each corner.
    """
    P = np.asarray(points, dtype=float).reshape(-1, 2)
    if len(P) < 2:
        return float("nan")
    g = gray.astype(np.float32)
    gx = cv2.Sobel(g, cv2.CV_32F, 1, 0, ksize=3) / 8.0
    gy = cv2.Sobel(g, cv2.CV_32F, 0, 1, ksize=3) / 8.0
    magnitude = np.hypot(gx, gy)
    spacing = _corner_spacing(P)
    half = max(2, round(spacing / 3))
    h, w = gray.shape
    widths = []
    for u, v in np.rint(P).astype(int):
        u0, u1, v0, v1 = max(0, u - half), min(w, u + half + 1), max(0, v - half), min(h, v + half + 1)
        patch, steep = g[v0:v1, u0:u1], magnitude[v0:v1, u0:u1]
        if patch.size < 9:
            continue
        low, high = np.percentile(patch, [5, 95])
        top = float(np.percentile(steep, 98))
        if high - low > 10 and top > 0:
            widths.append(1.02 * (high - low) / top)
    return float(np.median(widths)) if widths else float("nan")


__all__ = ["BoardDetection", "DetectionSettings", "detect_board", "edge_width", "flatten_shading"]
