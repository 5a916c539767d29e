"""Detected board views of an image folder: which pairs are usable, and why the others are not.

Both calibrations start here. Every view ends up either with its corners in one or both
images or with one line saying why it was refused (a missing image, a size that differs
from the others, the board not found, too blurred, a board larger than its file says).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Literal

import cv2
import numpy as np

from robot_app.arrays import FloatArray
from robot_app.calibration.board import BoardConfig
from robot_app.calibration.detection import BoardDetection, DetectionSettings, detect_board
from robot_app.calibration.files import ImagePair
from robot_app.calibration.flat_field import FlatField, apply_flat_field, check_flat_field_size
from robot_app.errors import CalibrationError
from robot_app.input_files import read_image

Side = Literal["left", "right"]
BOTH: tuple[Side, ...] = ("left", "right")


@dataclass(frozen=True)
class DetectedView:
    """One image pair after detection.

    Attributes:
        pair: the view's number and files.
        left, right: the board in each image (`usable` False with a reason when not).
    """

    pair: ImagePair
    left: BoardDetection
    right: BoardDetection

    def side(self, side: Side) -> BoardDetection:
        return self.left if side == "left" else self.right

    def usable(self, sides: Sequence[Side] = BOTH) -> bool:
        """True when the board was found in each of `sides`."""
        return all(self.side(s).usable for s in sides)

    def reason(self, sides: Sequence[Side] = BOTH) -> str:
        """Why the view cannot be used in `sides` ('' if it can), e.g. 'left: board not found'."""
        return "; ".join(f"{s}: {self.side(s).reason}" for s in sides if not self.side(s).usable)

    def common_corners(self) -> tuple[np.ndarray, FloatArray, FloatArray]:
        """Corner ids seen in both images and their (N, 2) pixels in left and right."""
        ids, in_left, in_right = np.intersect1d(
            self.left.corner_ids, self.right.corner_ids, assume_unique=True, return_indices=True
        )
        return ids, self.left.image_points[in_left], self.right.image_points[in_right]


def detect_views(
    pairs: Sequence[ImagePair],
    board: BoardConfig,
    settings: DetectionSettings,
    progress: Callable[[int, int], None] | None = None,
    flat_field: FlatField | None = None,
) -> tuple[list[DetectedView], tuple[int, int] | None]:
    """Detects the board in both images of every pair.

    Args:
        pairs: the folder's views.
        board: the board file's board.
        settings: detection limits.
        progress: called with (views done, views).
        flat_field: each camera's measured relative illumination, divided out of its
            images before detection (None: the images as they are).

    Returns:
        The views (in order) and the image size (width, height) [px] of the first
        readable image, None if no image could be read.

    Raises:
        CalibrationError: the first image is not the flat field's size.
    """
    views: list[DetectedView] = []
    size: tuple[int, int] | None = None
    for done, pair in enumerate(pairs, start=1):
        detections: dict[str, BoardDetection] = {}
        for side, path in (("left", pair.left), ("right", pair.right)):
            if path is None:
                detections[side] = BoardDetection.refused("no image")
                continue
            image = read_image(path).bgr
            shape = (image.shape[1], image.shape[0])
            if size is None and flat_field is not None:
                check_flat_field_size(flat_field, shape)
            size = size or shape
            if shape != size:
                detail = f"{shape[0]}x{shape[1]} px, the first image {size[0]}x{size[1]} px"
                detections[side] = BoardDetection.refused(f"image size differs: {detail}")
                continue
            if flat_field is not None:
                image = apply_flat_field(image, flat_field.side(side))
            found = detect_board(image, board, settings)
            if found.usable and board.type == "checkerboard":
                found = _check_squares(found, board, image)
            detections[side] = found
        views.append(DetectedView(pair, detections["left"], detections["right"]))
        if progress is not None:
            progress(done, len(pairs))
    return views, size


def require_views(
    views: Sequence[DetectedView], board: BoardConfig, minimum: int, what: str, sides: Sequence[Side] = BOTH
) -> list[DetectedView]:
    """The views usable in `sides`, or a CalibrationError saying why there are too few (exit 2).

    A board found in no image at all most likely is not the board of the board file:
    the error says so.
    """
    usable = [v for v in views if v.usable(sides)]
    if len(usable) >= minimum:
        return usable
    detections = [v.side(s) for v in views for s in sides if v.side(s).reason != "no image"]
    if detections and all(not d.usable and d.reason.startswith("board") for d in detections):
        raise CalibrationError(
            f"the board file's {board.describe()} was found in none of the {len(views)} views: "
            "does the board file match the board in the images?",
            key="--board",
            value=board.describe(),
            expected="the board that is in the images",
        )
    reasons: dict[str, int] = {}
    for view in views:
        for s in sides:
            if not view.side(s).usable:
                kind = reason_kind(view.side(s).reason)
                reasons[kind] = reasons.get(kind, 0) + 1
    summary = ", ".join(f"{n}x {r}" for r, n in sorted(reasons.items(), key=lambda kv: -kv[1]))
    raise CalibrationError(
        f"too few usable views for {what}: {len(usable)} of {len(views)}, need {minimum}"
        + (f" (images refused: {summary})" if summary else ""),
        key="--images",
        value=len(usable),
        expected=f">= {minimum} usable views",
    )


def reason_kind(reason: str) -> str:
    """The kind of a refusal without its side and numbers: 'left: too blurred: ...' -> 'too blurred'."""
    for side in ("left: ", "right: "):
        reason = reason.removeprefix(side)
    return reason.split(":")[0].split(" (")[0].strip()


def _check_squares(found: BoardDetection, board: BoardConfig, image: np.ndarray) -> BoardDetection:
    """Refuses a checkerboard grid that is not the board file's whole board.

    The detector may lock onto a grid shifted by a square when the board reaches past
    the image border, or onto part of a larger board. So: every square must be in the
    image and have its colour (judged against the inner squares' black and white), and
    the squares one step outside must be the white margin, not more board.
    """
    gray = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY) if image.ndim == 3 else image
    s = board.square_size
    plane = board.object_points()[found.corner_ids][:, :2]
    H, _ = cv2.findHomography(plane, found.image_points)
    if H is None:
        return found
    smooth = cv2.blur(gray, (3, 3))
    h, w = gray.shape

    def grey_at(rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        centres = np.column_stack([(cols - 0.5) * s, (rows - 0.5) * s]).reshape(-1, 1, 2)
        pixels = cv2.perspectiveTransform(centres, H).reshape(-1, 2)
        inside = (pixels[:, 0] >= 0) & (pixels[:, 0] <= w - 1) & (pixels[:, 1] >= 0) & (pixels[:, 1] <= h - 1)
        values = np.full(len(pixels), np.nan)
        u, v = np.rint(pixels[inside]).astype(int).T
        values[inside] = smooth[v, u]
        return values

    i, j = (a.ravel() for a in np.indices((board.rows, board.cols)))
    black = board.square_is_black(i, j)
    grey = grey_at(i, j)
    if not np.all(np.isfinite(grey)):
        return BoardDetection.refused("board partly outside the image", found.edge_width_px)
    inner = (i > 0) & (i < board.rows - 1) & (j > 0) & (j < board.cols - 1)
    threshold = (grey[inner & black].mean() + grey[inner & ~black].mean()) / 2
    if np.mean((grey < threshold) != black) > 0.05:
        return BoardDetection.refused(
            "board pattern does not fit the board file (a grid shifted by a square?)", found.edge_width_px
        )
    sides = {
        "top": (np.full(board.cols, -1), np.arange(board.cols)),
        "bottom": (np.full(board.cols, board.rows), np.arange(board.cols)),
        "left": (np.arange(board.rows), np.full(board.rows, -1)),
        "right": (np.arange(board.rows), np.full(board.rows, board.cols)),
    }
    for rows, cols in sides.values():
        beyond = grey_at(rows, cols)[board.square_is_black(rows, cols)]
        seen = beyond[np.isfinite(beyond)]
        if len(seen) >= 2 and np.mean(seen < threshold) > 0.5:
            return BoardDetection.refused(
                f"board larger than the board file: more than {board.cols}x{board.rows} squares",
                found.edge_width_px,
            )
    return found


__all__ = ["BOTH", "DetectedView", "Side", "detect_views", "reason_kind", "require_views"]
