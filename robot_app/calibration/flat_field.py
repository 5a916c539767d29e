"""A measured flat field: each camera's relative illumination, divided out before detection.

A lens darkens the edges of its image (vignetting: 25 % in the corners of the realistic
cell's cameras) and the brightness gradient it lays across each corner moves the corners
OpenCV's detector finds: through the realistic camera model at 320x240 the hand-eye X came
out 0.5-1.1 mm off along the optical axis. A real rig measures that fall-off once: the
camera looks into a uniformly lit white card or a diffuser over the lens, a few frames are
averaged, and every later image is divided by the result.

Flat-field folder: `left_<n>.png` and `right_<n>.png` frames of the uniform card (any
number of each, the same naming as the board images; a view's board folder may hold it as
its subfolder `flat_field/`, which `robot-app calibrate` then uses by default). Each frame
is divided by its own mean (an auto-exposing camera changes its gain between frames), the
frames are averaged, turned grey as the detector sees them, smoothed with a Gaussian of
`SMOOTH_FRACTION` of the image width (the fall-off is smooth; what is left of the noise is
not) and scaled to 1 at its brightest. No dark frame is subtracted (the simulated cameras
have no black level; a real one with an offset should subtract its dark frame first).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray, ImageBGR
from robot_app.calibration.files import find_image_pairs
from robot_app.errors import CalibrationError, InputError
from robot_app.input_files import read_image

FLAT_FIELD_FOLDER = "flat_field"
"""The board folder's subfolder `robot-app calibrate` and `sim calibration-views` use."""
SMOOTH_FRACTION = 0.01
"""Gaussian sigma of the smoothing, as a fraction of the image width."""
MIN_LEVEL_DN = 20.0
"""A flat-field frame's mean must reach this grey level [DN] (else: the card was not lit)."""
MIN_RELATIVE = 0.2
"""The measured fall-off may reach down to this fraction of the brightest part, no lower."""


@dataclass(frozen=True)
class FlatField:
    """Both cameras' relative illumination, measured from frames of a uniform card.

    Attributes:
        left, right: (H, W) relative illumination, 1 at the brightest [0-1].
        frames: frames averaged per camera (left, right).
        folder: where the frames came from.
    """

    left: FloatArray
    right: FloatArray
    frames: tuple[int, int]
    folder: Path

    @property
    def image_size(self) -> tuple[int, int]:
        """(width, height) [px]."""
        return (self.left.shape[1], self.left.shape[0])

    def side(self, side: str) -> FloatArray:
        return self.left if side == "left" else self.right

    def describe(self) -> str:
        """E.g. 'flat field views/flat_field (8 + 8 frames; darkest 74 %, 75 %)'."""
        low = ", ".join(f"{100 * float(f.min()):.0f} %" for f in (self.left, self.right))
        return f"flat field {self.folder} ({self.frames[0]} + {self.frames[1]} frames; darkest {low})"


def measure_flat_field(frames: list[ImageBGR]) -> FloatArray:
    """The relative illumination of one camera from frames of a uniform card.

    Raises:
        ValueError: no frames, or frames of different sizes (the loader checks both first).
    """
    if not frames:
        raise ValueError("measure_flat_field needs at least one frame")
    total = np.zeros(np.asarray(frames[0]).shape[:2])
    for frame in frames:
        grey = _grey(frame)
        total += grey / max(float(grey.mean()), 1e-6)
    mean = (total / len(frames)).astype(np.float32)
    sigma = max(1.0, SMOOTH_FRACTION * mean.shape[1])
    smooth = cv2.GaussianBlur(mean, (0, 0), sigma, borderType=cv2.BORDER_REFLECT)
    return np.asarray(smooth / float(smooth.max()), dtype=float)


def load_flat_field(folder: str | Path, key: str = "--flat-field") -> FlatField:
    """Reads and measures a flat-field folder (module docstring).

    Raises:
        InputError: the folder does not exist or holds no left_/right_ frames.
        CalibrationError: a camera has no frame, frames of different sizes, a frame too dark
            to be a lit card, or a fall-off so deep that the frames cannot be of a uniform card.
    """
    root = Path(folder)
    try:
        pairs = find_image_pairs(root)
    except InputError as err:
        raise InputError(f"{key} {err.message}", path=root, key=key) from err
    measured: dict[str, FloatArray] = {}
    counts: dict[str, int] = {}
    size: tuple[int, int] | None = None
    for side in ("left", "right"):
        paths = [p for pair in pairs if (p := getattr(pair, side)) is not None]
        if not paths:
            raise CalibrationError(
                f"{key} {root}: no {side}_<n> frame (a flat field needs both cameras)", path=root, key=key
            )
        frames = []
        for path in paths:
            image = read_image(path).bgr
            shape = (image.shape[1], image.shape[0])
            size = size or shape
            if shape != size:
                raise CalibrationError(
                    f"{key} {path}: {shape[0]}x{shape[1]} px, the other frames {size[0]}x{size[1]} px",
                    path=path,
                    key=key,
                    value=list(shape),
                )
            level = float(_grey(image).mean())
            if level < MIN_LEVEL_DN:
                raise CalibrationError(
                    f"{key} {path}: mean grey level {level:.1f}, too dark for a lit card (need >= "
                    f"{MIN_LEVEL_DN:.0f})",
                    path=path,
                    key=key,
                    value=level,
                    expected=f">= {MIN_LEVEL_DN:.0f}",
                )
            frames.append(image)
        flat = measure_flat_field(frames)
        if float(flat.min()) < MIN_RELATIVE:
            raise CalibrationError(
                f"{key} {root}: the {side} frames fall to {100 * float(flat.min()):.0f} % of their "
                f"brightest part (limit {100 * MIN_RELATIVE:.0f} %): not a uniformly lit card",
                path=root,
                key=key,
                value=float(flat.min()),
                expected=f">= {MIN_RELATIVE}",
            )
        measured[side], counts[side] = flat, len(frames)
    return FlatField(measured["left"], measured["right"], (counts["left"], counts["right"]), root)


def check_flat_field_size(
    flat: FlatField, image_size: tuple[int, int] | None, key: str = "--flat-field"
) -> None:
    """Raises CalibrationError if the board images are not the flat field's size."""
    if image_size is not None and image_size != flat.image_size:
        w, h = flat.image_size
        raise CalibrationError(
            f"{key} {flat.folder}: the flat field is {w}x{h} px, the board images "
            f"{image_size[0]}x{image_size[1]} px",
            path=flat.folder,
            key=key,
            value=[w, h],
            expected=f"{image_size[0]}x{image_size[1]} px",
        )


def apply_flat_field(image: ImageBGR, relative: FloatArray) -> ImageBGR:
    """The image divided by the relative illumination (scaled down only if it would clip)."""
    corrected = np.asarray(image, dtype=np.float32)
    scale = (1.0 / relative).astype(np.float32)
    corrected = corrected * (scale[..., None] if corrected.ndim == 3 else scale)
    top = float(corrected.max())
    if top > 255.0:
        corrected *= np.float32(255.0 / top)
    return np.clip(np.rint(corrected), 0, 255).astype(np.uint8)


def flat_field_for(images: str | Path, given: str | Path | None) -> Path | None:
    """The flat-field folder to use: `given`, else the images' `flat_field/` if it exists."""
    if given is not None:
        return Path(given)
    default = Path(images) / FLAT_FIELD_FOLDER
    return default if default.is_dir() else None


def _grey(image: ImageBGR) -> npt.NDArray[np.float64]:
    array = np.asarray(image)
    grey = cv2.cvtColor(array, cv2.COLOR_BGR2GRAY) if array.ndim == 3 else array
    return np.asarray(grey, dtype=np.float64)


__all__ = [
    "FLAT_FIELD_FOLDER",
    "FlatField",
    "apply_flat_field",
    "check_flat_field_size",
    "flat_field_for",
    "load_flat_field",
    "measure_flat_field",
]
