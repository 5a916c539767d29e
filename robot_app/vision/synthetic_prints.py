"""Harder synthetic cloths: photographic prints, hue families, wrinkles, a folded corner.

The renderer's own catalogue (`synthetic.synthetic_cloth`) is flat colour patterns; a real
cloth carries a photographic print. Prints here are scikit-image's bundled colour
photographs (a test and benchmark dependency, imported on first use), recoloured so that
no part has the green sheet's hue: either spread over the hues away from green, or
squeezed into one hue family (a band of `FAMILY_WIDTH` around a centre hue), which gives
prints of nearly one hue whose half turn the hue fitness cannot tell apart, and several
cloths of one family that share the hue bands. `extended_cloth` numbers the 20-cloth
catalogue: 0-12 the renderer's own, 13-19 the prints (families `FAMILIES`).

`wrinkled` and `folded_corner` change a cloth's texture and outline but keep its flat
frame (`SyntheticCloth.origin`), so the ground-truth pose is that of the flat cloth.
"""

from __future__ import annotations

import functools
from collections.abc import Callable

import cv2
import numpy as np
import numpy.typing as npt

from robot_app.errors import InputError
from robot_app.vision.synthetic import SyntheticCloth
from robot_app.vision.synthetic_catalogue import CATALOGUE_SIZE, CLOTH_TEXEL, synthetic_cloth

Image = npt.NDArray[np.uint8]
GREEN_HUE = 86  # the sheet's hue (HSV_FULL, 0-255)
GREEN_GAP = 45  # prints keep this far from it
FAMILY_WIDTH = 24  # hue band of a family print (HSV_FULL steps)
EXTENDED_CATALOGUE_SIZE = 20


def _ellipse(x: npt.NDArray[np.float64], y: npt.NDArray[np.float64]) -> npt.NDArray[np.bool_]:
    return (x - 0.5) ** 2 + (y - 0.5) ** 2 <= 0.25


def _rectangle(x: npt.NDArray[np.float64], y: npt.NDArray[np.float64]) -> npt.NDArray[np.bool_]:
    return np.ones(x.shape, bool)


def _rounded(x: npt.NDArray[np.float64], y: npt.NDArray[np.float64]) -> npt.NDArray[np.bool_]:
    r = 0.18
    dx = np.maximum(np.abs(x - 0.5) - (0.5 - r), 0)
    dy = np.maximum(np.abs(y - 0.5) - (0.5 - r), 0)
    return dx**2 + dy**2 <= r**2


def _tshirt(x: npt.NDArray[np.float64], y: npt.NDArray[np.float64]) -> npt.NDArray[np.bool_]:
    body = np.abs(x - 0.5) <= 0.3
    sleeves = (y <= 0.4) & (np.abs(x - 0.5) <= 0.5 - 0.6 * np.maximum(0, y - 0.05))
    neck = (x - 0.5) ** 2 + (y / 0.6) ** 2 < 0.12**2
    return (body | sleeves) & ~neck


def _trapezoid(x: npt.NDArray[np.float64], y: npt.NDArray[np.float64]) -> npt.NDArray[np.bool_]:
    return np.abs(x - 0.5) <= 0.3 + 0.2 * y


Outline = Callable[[npt.NDArray[np.float64], npt.NDArray[np.float64]], npt.NDArray[np.bool_]]
# name, scikit-image photo, hue family centre (None: all hues away from green), outline, size [m]
_PRINTS: list[tuple[str, str, int | None, Outline, tuple[float, float]]] = [
    ("amber_astronaut", "astronaut", 22, _rectangle, (0.22, 0.18)),
    ("amber_coffee", "coffee", 22, _rounded, (0.24, 0.16)),
    ("amber_cat_ellipse", "chelsea", 22, _ellipse, (0.22, 0.15)),
    ("rocket_print", "rocket", None, _rectangle, (0.16, 0.22)),
    ("violet_cells", "immunohistochemistry", 205, _rectangle, (0.20, 0.20)),
    ("violet_motorcycle", "motorcycle", 205, _tshirt, (0.25, 0.20)),
    ("astronaut_print", "astronaut_face", None, _trapezoid, (0.20, 0.16)),
]
FAMILIES: dict[str, tuple[int, ...]] = {"amber": (13, 14, 15), "violet": (17, 18)}


@functools.lru_cache(maxsize=8)
def _photo(name: str) -> Image:
    """A bundled scikit-image photo as BGR uint8."""
    try:
        from skimage import data
    except ImportError as err:  # a test/bench dependency only
        raise InputError("photographic prints need scikit-image (pip install scikit-image)") from err
    if name == "motorcycle":
        rgb = data.stereo_motorcycle()[0]
    elif name == "astronaut_face":
        rgb = data.astronaut()[20:260, 120:420]
    else:
        rgb = getattr(data, name)()
    rgb = np.asarray(rgb)[..., :3]
    return np.ascontiguousarray(rgb[..., ::-1]).astype(np.uint8)


def recoloured(photo_bgr: Image, family: int | None) -> Image:
    """`photo_bgr` with its hues moved away from the green sheet's: spread over the arc of
    hues at least `GREEN_GAP` from it (family None), or squeezed into a band of
    `FAMILY_WIDTH` around `family`; saturation raised so that most of it has a hue."""
    hsv = cv2.cvtColor(photo_bgr, cv2.COLOR_BGR2HSV_FULL).astype(float)
    hue = hsv[..., 0]
    if family is None:
        arc = 256 - 2 * GREEN_GAP
        hue = (GREEN_HUE + GREEN_GAP + hue * arc / 256.0) % 256
    else:
        hue = (family + (hue / 256.0 - 0.5) * FAMILY_WIDTH) % 256
    hsv[..., 0] = hue
    hsv[..., 1] = np.clip(hsv[..., 1] * 1.2 + 50, 0, 255)
    hsv[..., 2] = np.clip(hsv[..., 2] * 0.85 + 25, 0, 255)
    return np.asarray(cv2.cvtColor(np.rint(hsv).astype(np.uint8), cv2.COLOR_HSV2BGR_FULL), dtype=np.uint8)


def photo_print(index: int) -> SyntheticCloth:
    """Print `index` (0-6) of `_PRINTS` as a cloth: the photo fitted to the cloth's size,
    recoloured, cut to its outline."""
    name, photo, family, outline, (width, height) = _PRINTS[index]
    shape = (round(height / CLOTH_TEXEL), round(width / CLOTH_TEXEL))
    source = _photo(photo)
    aspect = shape[1] / shape[0]
    h, w = source.shape[:2]
    if w / h > aspect:  # crop the photo to the cloth's aspect, centred
        cw = round(h * aspect)
        source = source[:, (w - cw) // 2 : (w - cw) // 2 + cw]
    else:
        ch = round(w / aspect)
        source = source[(h - ch) // 2 : (h - ch) // 2 + ch]
    texture = np.asarray(cv2.resize(source, (shape[1], shape[0]), interpolation=cv2.INTER_CUBIC), np.uint8)
    y, x = (np.indices(shape) + 0.5) / np.array(shape)[:, None, None]
    return SyntheticCloth(name, recoloured(texture, family), outline(x, y), (width, height))


def extended_cloth(index: int, seed: int = 0) -> SyntheticCloth:
    """Cloth `index` of the 20-cloth catalogue: 0-12 `synthetic_cloth`, 13-19 the prints."""
    if not 0 <= index < EXTENDED_CATALOGUE_SIZE:
        raise ValueError(f"catalogue index must be in 0..{EXTENDED_CATALOGUE_SIZE - 1}, got {index}")
    if index < CATALOGUE_SIZE:
        return synthetic_cloth(index, seed)
    return photo_print(index - CATALOGUE_SIZE)


def family_of(index: int) -> tuple[int, ...]:
    """The other catalogue cloths of `index`'s hue family (empty if it has none)."""
    for members in FAMILIES.values():
        if index in members:
            return tuple(m for m in members if m != index)
    return ()


def wrinkled(
    cloth: SyntheticCloth, rng: np.random.Generator, amplitude: float = 0.002, shading: float = 0.25
) -> SyntheticCloth:
    """The cloth with wrinkles: two or three ridges of random direction and wavelength
    (25-60 mm) shift its texture and outline by up to `amplitude` [m] and shade it by up to
    `shading` (the slopes facing away darker); its frame stays the flat cloth's."""
    height, width = cloth.alpha.shape
    v, u = np.indices((height, width)).astype(np.float32)
    du = np.zeros_like(u)
    dv = np.zeros_like(v)
    light = np.ones_like(u)
    for _ in range(int(rng.integers(2, 4))):
        angle = rng.uniform(0, np.pi)
        wavelength = rng.uniform(0.025, 0.06) / CLOTH_TEXEL
        phase = rng.uniform(0, 2 * np.pi)
        along = (u * np.cos(angle) + v * np.sin(angle)) * (2 * np.pi / wavelength) + phase
        shift = amplitude / CLOTH_TEXEL * rng.uniform(0.4, 1.0) * np.sin(along)
        du += shift * np.cos(angle)
        dv += shift * np.sin(angle)
        light *= 1.0 + shading * rng.uniform(0.4, 1.0) * np.cos(along) / 2.0
    texture = cv2.remap(cloth.texture_bgr, u + du, v + dv, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)
    alpha = cv2.remap(cloth.alpha.astype(np.uint8), u + du, v + dv, cv2.INTER_NEAREST, borderValue=0)
    shaded = np.clip(texture.astype(np.float32) * light[..., None], 0, 255).astype(np.uint8)
    centroid = cloth.centroid
    return SyntheticCloth(f"{cloth.name}_wrinkled", shaded, alpha.astype(bool), cloth.size,
                          (float(centroid[0]), float(centroid[1])))  # fmt: skip


def folded_corner(cloth: SyntheticCloth, fraction: float, direction: float) -> SyntheticCloth:
    """The cloth with the part beyond a fold line turned over onto itself, its back side up.

    Args:
        cloth: the flat cloth.
        fraction: share of the cloth's area beyond the fold line (0-0.5).
        direction: direction of the corner that is folded, in texture x-y [rad].

    The back side is the print's mean colour faded towards a light grey, with the fabric's
    grain. The frame stays the flat cloth's.
    """
    if not 0.0 < fraction < 0.5:
        raise ValueError(f"fold fraction must be in (0, 0.5), got {fraction}")
    height, width = cloth.alpha.shape
    v, u = np.indices((height, width)).astype(float)
    d = np.array([np.cos(direction), np.sin(direction)])
    along = u * d[0] + v * d[1]
    line = float(np.quantile(along[cloth.alpha], 1.0 - fraction))
    beyond = cloth.alpha & (along > line)
    # reflect the flap across the line: a texel at distance s beyond lands at distance s before
    vb, ub = np.nonzero(beyond)
    s = along[vb, ub] - line
    ur = np.rint(ub - 2 * s * d[0]).astype(int)
    vr = np.rint(vb - 2 * s * d[1]).astype(int)
    inside = (ur >= 0) & (ur < width) & (vr >= 0) & (vr < height)
    alpha = cloth.alpha & ~beyond
    texture = cloth.texture_bgr.copy()
    mean = cloth.texture_bgr[cloth.alpha].reshape(-1, 3).mean(axis=0)
    back = 0.35 * mean + 0.65 * np.array([205.0, 205.0, 210.0])
    grain = np.random.default_rng(7).normal(0.0, 4.0, (int(inside.sum()), 3))
    flap = np.zeros_like(alpha)
    flap[vr[inside], ur[inside]] = True
    flap = cv2.morphologyEx(flap.astype(np.uint8), cv2.MORPH_CLOSE, np.ones((3, 3), np.uint8)).astype(bool)
    texture[flap] = np.clip(back, 0, 255).astype(np.uint8)
    texture[vr[inside], ur[inside]] = np.clip(back + grain, 0, 255).astype(np.uint8)
    alpha |= flap
    texture[~alpha] = 0
    centroid = cloth.centroid
    return SyntheticCloth(
        f"{cloth.name}_folded", texture, alpha, cloth.size, (float(centroid[0]), float(centroid[1]))
    )


def crumpled(cloth: SyntheticCloth, rng: np.random.Generator) -> SyntheticCloth:
    """The cloth as it might lie after a drop (a guess, not a model of the physics): two
    corners turned over (10-25 % of the area each, their directions at least 90° apart; the
    second may fold over the first's back) and heavy wrinkles (ridges of 4-8 mm, shading up
    to 0.5). The frame stays the flat cloth's."""
    first = float(rng.uniform(0, 2 * np.pi))
    second = first + float(rng.uniform(np.pi / 2, 3 * np.pi / 2))
    folded = folded_corner(cloth, float(rng.uniform(0.1, 0.25)), first)
    folded = folded_corner(folded, float(rng.uniform(0.1, 0.25)), second)
    out = wrinkled(folded, rng, amplitude=float(rng.uniform(0.004, 0.008)), shading=0.5)
    centroid = cloth.centroid
    return SyntheticCloth(
        f"{cloth.name}_crumpled",
        out.texture_bgr,
        out.alpha,
        out.size,
        (float(centroid[0]), float(centroid[1])),
    )


__all__ = [
    "EXTENDED_CATALOGUE_SIZE",
    "FAMILIES",
    "crumpled",
    "extended_cloth",
    "family_of",
    "folded_corner",
    "photo_print",
    "recoloured",
    "wrinkled",
]
