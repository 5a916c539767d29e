"""Pixel codes: each pixel of a hand image as the colour code the fitness scores it by.

A code is the pixel's hue (HSV_FULL, 0-255) or, without a meaningful hue, its tone DARK or
LIGHT (`robot_app.vision.hue`). Codes come from one look-up table of every BGR colour
(`colour_table`, built once per process from OpenCV's own conversion, so the codes are
those of `hue.to_hsv`), after the scene's exposure gains (`exposure.py`). The compiled
pass is `fitness_kernels.bgr_codes`; the code array is framed by `OFF_IMAGE` pixels so that
the scoring kernels need no bounds test.
"""

from __future__ import annotations

import functools
import os
from pathlib import Path

import cv2
import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray
from robot_app.errors import InputError
from robot_app.vision.camera import PinholeCamera
from robot_app.vision.exposure import Shading
from robot_app.vision.fitness_kernels import (
    bgr_codes,
    bgr_codes_shaded,
    every_colour,
    gain_levels,
    hsv_codes,
    shaded_levels,
)
from robot_app.vision.fitness_scores import OFF_IMAGE
from robot_app.vision.hue import DARK, LIGHT, to_hsv


def pixel_codes(
    image: npt.NDArray[np.uint8],
    camera: PinholeCamera,
    thresholds: tuple[int, int, int],
    gains: FloatArray,
    spans: npt.NDArray[np.int64],
    shading: Shading | None = None,
) -> npt.NDArray[np.uint16]:
    """The framed pixel codes of one image (undistorted first if `camera` has distortion).

    Args:
        image: (H, W, 3) uint8 BGR, the camera's size.
        camera: its camera.
        thresholds: (min_saturation, min_value, value_split) of `FitnessSettings`.
        gains: (3,) exposure gains of b, g, r (`exposure.sheet_gains`).
        spans: (H, 2) int64, per row the first and last column inclusive (`box_spans` of a
            box; empty where the last is below the first): only pixels there get a code,
            the others `OFF_IMAGE`.
    """
    if camera.has_distortion:
        K = camera.camera_matrix
        image = np.asarray(cv2.undistort(image, K, camera.dist_coeffs, None, K), dtype=np.uint8)
    table = colour_table(*thresholds)
    spans = np.ascontiguousarray(spans, dtype=np.int64)
    if spans.shape != (image.shape[0], 2):
        raise ValueError(f"spans must be ({image.shape[0]}, 2), one per image row, got {spans.shape}")
    gains = np.asarray(gains, dtype=np.float64)
    if shading is None:
        return bgr_codes(np.ascontiguousarray(image), table, OFF_IMAGE, _gain_levels(gains.tobytes()), spans)
    levels = shaded_levels(gains, shading.factors)
    return bgr_codes_shaded(
        np.ascontiguousarray(image), table, OFF_IMAGE, levels, shading.index, shading.block, spans
    )


def box_spans(box: npt.ArrayLike, height: int) -> npt.NDArray[np.int64]:
    """(height, 2) int64 row spans of the (u0, v0, u1, v1) box, inclusive (rows outside it
    empty: (0, -1)); columns are clipped by the kernels, rows here."""
    u0, v0, u1, v1 = (int(x) for x in np.asarray(box).ravel())
    spans = np.zeros((height, 2), dtype=np.int64)
    spans[:, 1] = -1
    rows = slice(max(v0, 0), max(min(v1, height - 1) + 1, 0))
    spans[rows, 0], spans[rows, 1] = u0, u1
    return spans


@functools.lru_cache(maxsize=64)
def _gain_levels(gains: bytes) -> npt.NDArray[np.uint8]:
    """`gain_levels` of the (3,) float64 gains given as their bytes, cached: gains are the
    model sheet's colour over the scene sheet's integer medians, so a tracking run sees the
    same few again and again (12 numpy calls saved a frame and image). Only `bgr_codes`
    reads the array (left writable: a read-only one is another type to the compiled kernel)."""
    return gain_levels(np.frombuffer(gains, dtype=np.float64))


@functools.lru_cache(maxsize=4)
def colour_table(min_saturation: int, min_value: int, value_split: int) -> npt.NDArray[np.uint16]:
    """(2^24,) read-only: the pixel code (`hue.colour_codes` of `hue.to_hsv`) of every BGR
    colour, at index b << 16 | g << 8 | r; built from OpenCV's own conversion of an image
    of all colours (0.2-0.4 s, 32 MB), once per thresholds and OpenCV version: the table
    is kept in the per-user cache folder (`cache_dir`) and read from there by later
    processes (about 0.02 s: a batch's first result comes that much sooner)."""
    name = f"colour_table_s{min_saturation}_v{min_value}_split{value_split}_cv{cv2.__version__}.npy"
    folder = cache_dir()
    path = None if folder is None else folder / name
    if path is not None and path.is_file():
        try:
            cached = np.load(path, allow_pickle=False)
            if cached.shape == (1 << 24,) and cached.dtype == np.uint16:
                cached.setflags(write=False)
                return np.asarray(cached)
        except (OSError, ValueError):
            pass  # unreadable or truncated: built again below
    hsv = to_hsv(every_colour())
    framed = hsv_codes(hsv, min_saturation, min_value, value_split, DARK, LIGHT, OFF_IMAGE)
    table = np.ascontiguousarray(framed.reshape(4096 + 3, 4096 + 3)[1:-2, 1:-2]).ravel()
    table.setflags(write=False)
    if path is not None:
        temporary = path.with_name(f".{name}.{os.getpid()}.partial")
        try:
            with temporary.open("wb") as file:
                np.save(file, table)
            os.replace(temporary, path)
        except OSError:
            temporary.unlink(missing_ok=True)  # a read-only cache: build it each time
    return table


def cache_dir() -> Path | None:
    """The per-user folder of vision's cached tables: `ROBOT_APP_CACHE` if set, else
    `$XDG_CACHE_HOME/robot_app/vision` (default `~/.cache/robot_app/vision`); None if it
    cannot be made."""
    root = os.environ.get("ROBOT_APP_CACHE")
    if root:
        folder = Path(root)
    else:
        base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
        folder = Path(base) / "robot_app" / "vision"
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError:
        return None
    return folder


def checked_image(image: npt.ArrayLike, camera: PinholeCamera, side: str) -> npt.NDArray[np.uint8]:
    """`image` as an (H, W, 3) uint8 array of `camera`'s size.

    Raises:
        InputError: another type or size; `key` is `side`, `value` the image's (shape,
            dtype) or its (width, height) [px].
    """
    array = np.asarray(image)
    width, height = camera.image_size
    if array.ndim != 3 or array.shape[2] != 3 or array.dtype != np.uint8:
        raise InputError(
            f"{side} image must be an (H, W, 3) uint8 BGR image, got {array.shape} {array.dtype}",
            key=side,
            value=(array.shape, str(array.dtype)),
            expected="an (H, W, 3) uint8 BGR image",
        )
    if array.shape[:2] != (height, width):
        raise InputError(
            f"{side} image is {array.shape[1]}x{array.shape[0]} px but the rig expects {width}x{height} px",
            key=side,
            value=(array.shape[1], array.shape[0]),
            expected=f"{width}x{height} px, the rig's image size",
        )
    return array


__all__ = ["box_spans", "cache_dir", "checked_image", "colour_table", "pixel_codes"]
