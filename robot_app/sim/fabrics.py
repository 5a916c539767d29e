"""Fabric-like cloth textures: weave, colour variation, prints, and the duller back side.

A fabric texture starts from the cloth's colour layout (its catalogue pattern: stripes,
checks, dots, ...), adds a print if it has one (flowers, or a photograph-like picture),
then the structure of the cloth (plain weave, twill, denim, knit, towel pile) as a fine
brightness modulation, and a slow colour variation of the dye. Everything is drawn from
the catalogue number: the same cloth always looks the same. Sizes are in texture pixels
(`cloths.TEXTURE_PX_PER_M` per metre).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

Image = npt.NDArray[np.uint8]
BGR = tuple[int, int, int]
WEAVES = ("plain", "twill", "denim", "knit", "pile")
PRINTS = ("none", "floral", "photo")


@dataclass(frozen=True)
class Fabric:
    """How a cloth is made and printed.

    Attributes:
        weave: one of WEAVES.
        thread: weave period (thread pair, twill step, stitch width, pile loop) [px].
        contrast: brightness modulation of the weave (0-0.5).
        variation: slow brightness variation of the dye (0-0.3).
        print: one of PRINTS.
        print_colours: BGR colours of the print (flowers, picture tint).
        print_scale: size of a flower or of the picture, as a share of the cloth's width.
        back_fade: how much of the front's pattern the back side loses (0-1); the back
            is also darker (`BACK_DARKENING`) and without the weave's sharp contrast.
    """

    weave: str = "plain"
    thread: float = 3.0
    contrast: float = 0.12
    variation: float = 0.06
    print: str = "none"
    print_colours: tuple[BGR, ...] = ()
    print_scale: float = 0.25
    back_fade: float = 0.3

    def __post_init__(self) -> None:
        if self.weave not in WEAVES:
            raise ValueError(f"weave {self.weave!r} is not one of {WEAVES}")
        if self.print not in PRINTS:
            raise ValueError(f"print {self.print!r} is not one of {PRINTS}")
        if self.print != "none" and not self.print_colours:
            raise ValueError("a print needs print_colours")
        if not (1.0 <= self.thread <= 20.0 and 0 <= self.contrast <= 0.5 and 0 <= self.variation <= 0.3):
            raise ValueError("need 1 <= thread <= 20 px, 0 <= contrast <= 0.5, 0 <= variation <= 0.3")
        if not 0.0 <= self.back_fade <= 1.0:
            raise ValueError("back_fade must be within 0 .. 1")


BACK_DARKENING = 0.72  # brightness of the back side relative to the front's


def fabric_texture(layout_bgr: Image, fabric: Fabric, seed: int) -> Image:
    """The front of a fabric: `layout_bgr` (the cloth's colour pattern) made into cloth.

    Args:
        layout_bgr: (H, W, 3) uint8 colour layout of the cloth.
        fabric: weave, print and variation.
        seed: the catalogue number (deterministic look).
    """
    rng = np.random.default_rng(5000 + seed)
    height, width = layout_bgr.shape[:2]
    image = layout_bgr.astype(np.float32)
    if fabric.print == "floral":
        image = _floral(image, fabric, rng)
    elif fabric.print == "photo":
        image = _photo(image, fabric, rng)
    image = _blur(image, 0.7)  # dyes and prints bleed a little into the threads
    image *= weave_modulation(fabric, height, width, rng)[..., None]
    image *= _slow_variation(height, width, fabric.variation, rng)
    return np.clip(np.rint(image), 0, 255).astype(np.uint8)


def back_texture(front_bgr: Image, fabric: Fabric, seed: int) -> Image:
    """The back of the same fabric: the front's pattern faded and blurred, darker, dull."""
    rng = np.random.default_rng(9000 + seed)
    front = front_bgr.astype(np.float32)
    mean = front.reshape(-1, 3).mean(axis=0)
    blurred = _blur(front, 2.0)
    back = (1.0 - fabric.back_fade) * blurred + fabric.back_fade * mean
    height, width = front.shape[:2]
    dull = Fabric("plain", max(2.0, fabric.thread), 0.05, fabric.variation)
    back *= weave_modulation(dull, height, width, rng)[..., None] * BACK_DARKENING
    return np.clip(np.rint(back), 0, 255).astype(np.uint8)


def weave_modulation(
    fabric: Fabric, height: int, width: int, rng: np.random.Generator
) -> npt.NDArray[np.float32]:
    """(H, W) brightness factor around 1 drawn by the cloth's construction."""
    y, x = np.mgrid[0:height, 0:width].astype(np.float32)
    p, c = fabric.thread, fabric.contrast
    row_slub = rng.normal(0.0, 0.5, size=int(height / p) + 2)  # uneven yarn, thread by thread
    col_slub = rng.normal(0.0, 0.5, size=int(width / p) + 2)
    slub = row_slub[(y / p).astype(int)] + col_slub[(x / p).astype(int)]
    if fabric.weave == "plain":
        cell = (np.floor(x / p) + np.floor(y / p)) % 2
        pattern = (2.0 * cell - 1.0) * 0.6 + 0.4 * slub
    elif fabric.weave == "twill":
        pattern = np.cos(2.0 * np.pi * (x + y) / p) * 0.8 + 0.3 * slub
    elif fabric.weave == "denim":  # steep twill lines, white weft peeking out, warp streaks
        lines = np.cos(2.0 * np.pi * (x + 0.5 * y) / p)
        warp = np.repeat(rng.normal(0.0, 1.0, size=width)[None, :], height, axis=0).astype(np.float32)
        streaks = np.asarray(cv2.GaussianBlur(warp, (0, 0), sigmaX=1.5, sigmaY=40.0), dtype=np.float32)
        pattern = 0.7 * lines + 0.8 * streaks + 0.3 * slub
    elif fabric.weave == "knit":  # columns of V-shaped stitches
        across = np.abs((x % p) - p / 2.0) / (p / 2.0)
        pattern = (
            np.cos(2.0 * np.pi * (y / (0.8 * p) + 0.5 * across)) * 0.8 + 0.3 * col_slub[(x / p).astype(int)]
        )
    else:  # pile: loops of a towel, a fine random texture
        noise = rng.normal(0.0, 1.0, size=(height, width)).astype(np.float32)
        loops = _blur(noise, p / 3.0)
        pattern = loops / max(float(loops.std()), 1e-6)
    return (1.0 + c * pattern).astype(np.float32)


def _slow_variation(
    height: int, width: int, amount: float, rng: np.random.Generator
) -> npt.NDArray[np.float32]:
    """(H, W, 3) dye variation: brightness (and a little colour) changing over centimetres."""
    if amount <= 0:
        return np.ones((height, width, 3), np.float32)
    small = rng.normal(0.0, 1.0, size=(max(2, height // 24), max(2, width // 24), 4)).astype(np.float32)
    field = _blur(np.asarray(cv2.resize(small, (width, height), interpolation=cv2.INTER_CUBIC)), 6.0)
    field = field / max(float(field.std()), 1e-6)
    brightness = amount * field[..., :1]
    tint = 0.3 * amount * field[..., 1:]
    return np.clip(1.0 + brightness + tint, 0.5, 1.5).astype(np.float32)


def _floral(
    image: npt.NDArray[np.float32], fabric: Fabric, rng: np.random.Generator
) -> npt.NDArray[np.float32]:
    """Scattered five- and six-petal flowers with leaves, printed over the layout."""
    height, width = image.shape[:2]
    size = max(8.0, fabric.print_scale * width)
    colours = fabric.print_colours
    count = int(2.2 * height * width / size**2)
    canvas = image.copy()
    leaf = (45.0, 95.0, 100.0)  # olive leaves: a green as close to the sheet would vanish from the model
    for _ in range(count):
        cx, cy = rng.uniform(0, width), rng.uniform(0, height)
        radius = size * rng.uniform(0.25, 0.45)
        turn = rng.uniform(0, 2 * np.pi)
        for k in range(2):
            angle = turn + np.pi * (0.3 + k)
            centre = (int(cx + 1.4 * radius * np.cos(angle)), int(cy + 1.4 * radius * np.sin(angle)))
            axes = (max(1, int(0.55 * radius)), max(1, int(0.22 * radius)))
            cv2.ellipse(canvas, centre, axes, float(np.degrees(angle)), 0, 360, leaf, -1, cv2.LINE_AA)
        colour = tuple(float(v) for v in colours[int(rng.integers(len(colours)))])
        petals = int(rng.integers(5, 7))
        for k in range(petals):
            angle = turn + 2 * np.pi * k / petals
            centre = (int(cx + 0.55 * radius * np.cos(angle)), int(cy + 0.55 * radius * np.sin(angle)))
            axes = (max(1, int(0.5 * radius)), max(1, int(0.3 * radius)))
            cv2.ellipse(canvas, centre, axes, float(np.degrees(angle)), 0, 360, colour, -1, cv2.LINE_AA)
        cv2.circle(
            canvas, (int(cx), int(cy)), max(1, int(0.22 * radius)), (40.0, 170.0, 220.0), -1, cv2.LINE_AA
        )
    return canvas


def _photo(
    image: npt.NDArray[np.float32], fabric: Fabric, rng: np.random.Generator
) -> npt.NDArray[np.float32]:
    """A photograph-like picture (sunset over hills and water) printed in the middle."""
    height, width = image.shape[:2]
    pw = int(np.clip(fabric.print_scale, 0.1, 1.0) * width)
    ph = min(height, int(0.8 * pw))
    y, x = np.mgrid[0:ph, 0:pw].astype(np.float32)
    t = y / max(ph - 1, 1)
    top, glow = np.array(fabric.print_colours[0], np.float32), np.array(fabric.print_colours[-1], np.float32)
    picture = (1 - t[..., None]) * top + t[..., None] * glow  # sky gradient
    sun = (pw * rng.uniform(0.3, 0.7), ph * rng.uniform(0.3, 0.45), ph * 0.12)
    disc = np.exp(-(((x - sun[0]) ** 2 + (y - sun[1]) ** 2) / (2 * sun[2] ** 2)))
    picture += disc[..., None] * (np.array([150.0, 230.0, 255.0], np.float32) - picture) * 0.9
    ridge = np.cumsum(rng.normal(0.0, 1.0, size=pw)).astype(np.float32)
    ridge = cv2.GaussianBlur(ridge[None, :], (0, 0), sigmaX=pw / 30.0)[0]
    ridge = ph * 0.55 + (ridge - ridge.mean()) / max(float(ridge.std()), 1e-6) * ph * 0.06
    hills = y > ridge[None, :]
    picture[hills] = picture[hills] * 0.25 + np.array([40.0, 45.0, 70.0], np.float32)
    water = y > ph * 0.75
    picture[water] = np.flipud(picture)[water] * 0.6 + 20.0  # reflection in the water
    grain = rng.normal(0.0, 6.0, size=picture.shape).astype(np.float32)
    picture = _blur(picture + grain, 1.0)
    x0, y0 = (width - pw) // 2, (height - ph) // 2
    out = image.copy()
    out[y0 : y0 + ph, x0 : x0 + pw] = picture
    return out


def _blur(image: npt.NDArray[np.float32], sigma: float) -> npt.NDArray[np.float32]:
    """Gaussian blur of a float32 image, `sigma` [px]."""
    return np.asarray(cv2.GaussianBlur(image.astype(np.float32), (0, 0), sigma), dtype=np.float32)


__all__ = [
    "BACK_DARKENING",
    "PRINTS",
    "WEAVES",
    "Fabric",
    "back_texture",
    "fabric_texture",
    "weave_modulation",
]
