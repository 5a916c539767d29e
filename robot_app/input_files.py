"""Input files: a missing file, a folder and an unreadable file told apart; images read safely.

`require_input_file` is the one check every loader makes first. `inspect_image` reads
only an image's header (PNG by hand, other formats with Pillow), so a 100 000 x 100 000
PNG of a few kilobytes is refused by its size before anything is decoded; `read_image`
then decodes it with OpenCV, with libpng's and OpenCV's own warnings kept off the
terminal, and says whether it is grayscale (no hue for the fitness to use).
"""

from __future__ import annotations

import os
import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from robot_app.console import native_output_silenced
from robot_app.errors import InputError
from robot_app.resources import BYTES_PER_IMAGE_PIXEL, ResourceLimits

GRAYSCALE_MODES = frozenset({"1", "L", "LA", "La", "I", "I;16", "I;16B", "I;16L", "I;16N", "F"})
"""Pillow image modes without colour."""


def require_input_file(path: str | Path, what: str, *, key: str | None = None) -> Path:
    """Returns `path` if it is a readable file; else an `InputError` saying what it is instead.

    Args:
        path: the file.
        what: what it should be, for the message ('image', 'stereo rig', 'cloth model').
        key: the option or config key that named it.
    """
    file = Path(path)
    if file.is_dir():
        raise InputError(
            f"{what} file {file} is a folder, not a file",
            path=file,
            key=key,
            expected=f"{_article(what)} {what} file",
        )
    if not file.exists():
        raise InputError(
            f"{what} file not found: {file}", path=file, key=key, expected=f"{_article(what)} {what} file"
        )
    if not file.is_file():
        raise InputError(
            f"{what} file {file} is not a regular file",
            path=file,
            key=key,
            expected=f"{_article(what)} {what} file",
        )
    if not os.access(file, os.R_OK):
        raise InputError(f"{what} file {file} is not readable (permission denied)", path=file, key=key)
    return file


@dataclass(frozen=True)
class ImageInfo:
    """What an image file's header says.

    Attributes:
        path: the file.
        width, height: size [px].
        mode: Pillow's mode ('RGB', 'L', 'RGBA', 'P', 'I;16', ...).
        format: file format ('PNG', 'JPEG', ...).
    """

    path: Path
    width: int
    height: int
    mode: str
    format: str

    @property
    def pixels(self) -> int:
        return self.width * self.height

    @property
    def grayscale(self) -> bool:
        """The file stores no colour (a palette image is only known after decoding)."""
        return self.mode in GRAYSCALE_MODES


PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
PNG_MODES = {0: "L", 2: "RGB", 3: "P", 4: "LA", 6: "RGBA"}
"""Pillow's mode for each PNG colour type."""


def _png_header(file: Path) -> tuple[int, int, str] | None:
    """(width, height, mode) from a PNG's IHDR chunk, None if `file` is not a PNG.

    Read by hand: Pillow refuses a PNG with a bad checksum in an ancillary chunk that
    libpng (OpenCV) reads with a warning.
    """
    with file.open("rb") as stream:
        head = stream.read(33)
    if len(head) < 33 or not head.startswith(PNG_SIGNATURE) or head[12:16] != b"IHDR":
        return None
    width, height = struct.unpack(">II", head[16:24])
    return int(width), int(height), PNG_MODES.get(head[25], "?")


def _pillow_header(file: Path) -> tuple[int, int, str, str] | None:
    """(width, height, mode, format) from Pillow, None if Pillow cannot identify the file."""
    from PIL import Image, UnidentifiedImageError

    saved_limit = Image.MAX_IMAGE_PIXELS
    Image.MAX_IMAGE_PIXELS = None  # we check the size ourselves, with a message that names it
    try:
        with Image.open(file) as image:
            return int(image.width), int(image.height), str(image.mode), str(image.format)
    except (UnidentifiedImageError, OSError, ValueError, SyntaxError):
        return None
    finally:
        Image.MAX_IMAGE_PIXELS = saved_limit


def inspect_image(
    path: str | Path, *, what: str = "image", key: str | None = None, limits: ResourceLimits | None = None
) -> ImageInfo | None:
    """Reads an image file's header and checks its size against the memory limit.

    Returns:
        The header, or None for a file whose header neither the PNG reader nor Pillow
        knows (OpenCV may still decode it, within its own 2^30-pixel limit).

    Raises:
        InputError: missing, a folder, or not a file.
        ResourceError: decoding and processing it would exceed the memory limit.
    """
    file = require_input_file(path, what, key=key)
    png = _png_header(file)
    if png is not None:
        info = ImageInfo(file, png[0], png[1], png[2], "PNG")
    else:
        header = _pillow_header(file)
        if header is None:
            return None
        info = ImageInfo(file, *header)
    (limits or ResourceLimits()).check_memory(
        info.pixels * BYTES_PER_IMAGE_PIXEL,
        key=key or what,
        value=f"{file} ({info.width}x{info.height} px)",
        what="decoding and processing it",
    )
    return info


@dataclass(frozen=True)
class LoadedImage:
    """A decoded image.

    Attributes:
        bgr: (H, W, 3) uint8, OpenCV's channel order.
        info: its header.
        grayscale: it has no colour (a gray file, or three equal channels).
    """

    bgr: npt.NDArray[np.uint8]
    info: ImageInfo
    grayscale: bool


def read_image(
    path: str | Path, *, what: str = "image", key: str | None = None, limits: ResourceLimits | None = None
) -> LoadedImage:
    """Decodes an image file as (H, W, 3) uint8 BGR after `inspect_image`'s checks.

    Raises:
        InputError: missing, a folder, not an image, or an image OpenCV cannot decode.
        ResourceError: too large for the memory limit.
    """
    import cv2

    file = Path(path)
    info = inspect_image(file, what=what, key=key, limits=limits)
    with native_output_silenced():  # libpng's and OpenCV's warnings go to the process's stderr
        image = cv2.imread(str(file), cv2.IMREAD_COLOR)
    if image is None:
        damaged = f": its {info.format} data cannot be decoded (truncated?)" if info is not None else ""
        raise InputError(
            f"{file} is not a readable image (PNG, JPEG, BMP, TIFF ...){damaged}",
            path=file,
            key=key,
            expected="an image file",
        )
    bgr = np.asarray(image, dtype=np.uint8)
    if info is None:
        info = ImageInfo(file, bgr.shape[1], bgr.shape[0], "RGB", "unknown")
    gray = info.grayscale or bool(
        np.array_equal(bgr[..., 0], bgr[..., 1]) and np.array_equal(bgr[..., 1], bgr[..., 2])
    )
    return LoadedImage(bgr, info, gray)


def _article(word: str) -> str:
    """'a' or 'an' before `word` (by its first letter)."""
    return "an" if word[:1].lower() in "aeiou" else "a"


__all__ = ["GRAYSCALE_MODES", "ImageInfo", "LoadedImage", "inspect_image", "read_image", "require_input_file"]
