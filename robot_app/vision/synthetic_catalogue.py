"""The renderer's own catalogue: 13 flat cloths of colour patterns (paper Fig. 10 style).

Four hue classes more than the paper's hue threshold apart from each other, from the
green sheet and from the blue occluder, on rectangles, rounded rectangles, a trapezoid, a
T-shirt, an ellipse and an L: plain, striped, checked, dotted, patchwork. Every cloth
has a fabric grain of a few grey levels; `seed` varies the random parts of a pattern.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from robot_app.vision.synthetic import SyntheticCloth

# --- the catalogue: 12+ cloths (paper Fig. 10: No.1 .. No.12), up to 0.25 x 0.20 m ----------
CLOTH_TEXEL = 0.0005  # texture resolution [m]
# Four hue classes more than the paper's hue threshold (30 of 256) apart from each other,
# from the green sheet (91) and from the blue occluder (169): red 255, yellow 37, cyan 135,
# violet 205 (HSV_FULL). Orange (19) and crimson (242) are accents only: they match red.
RED, YELLOW, CYAN, VIOLET = (35, 30, 215), (25, 205, 230), (200, 170, 20), (190, 30, 160)
ORANGE, CRIMSON = (20, 120, 240), (70, 20, 170)
Array = npt.NDArray[np.float64]


Mask = npt.NDArray[np.bool_]
Layers = list[tuple[tuple[int, int, int], Callable[[Array, Array], Mask] | None]]


def _paint(x: Array, y: Array, layers: Layers) -> Array:
    """Colours painted in order, each where its mask (of x, y in (0, 1)) holds (None: everywhere)."""
    image = np.zeros((*x.shape, 3))
    for colour, mask in layers:
        image[np.ones(x.shape, bool) if mask is None else mask(x, y)] = colour
    return image


def _rectangle(x: Array, y: Array) -> Mask:
    return np.ones(x.shape, bool)


def _rounded(radius: float) -> Callable[[Array, Array], Mask]:
    def outline(x: Array, y: Array) -> Mask:
        dx, dy = (
            np.maximum(np.abs(x - 0.5) - (0.5 - radius), 0),
            np.maximum(np.abs(y - 0.5) - (0.5 - radius), 0),
        )
        return dx**2 + dy**2 <= radius**2

    return outline


def _trapezoid(x: Array, y: Array) -> Mask:
    return np.abs(x - 0.5) <= 0.3 + 0.2 * y


def _tshirt(x: Array, y: Array) -> Mask:
    body = np.abs(x - 0.5) <= 0.3
    sleeves = (y <= 0.4) & (np.abs(x - 0.5) <= 0.5 - 0.6 * np.maximum(0, y - 0.05))
    neck = (x - 0.5) ** 2 + (y / 0.6) ** 2 < 0.12**2
    return (body | sleeves) & ~neck


def _ellipse(x: Array, y: Array) -> Mask:
    return (x - 0.5) ** 2 + (y - 0.5) ** 2 <= 0.25


def _l_shape(x: Array, y: Array) -> Mask:
    return (x <= 0.45) | (y >= 0.55)


def _dots(x: Array, y: Array, rng: np.random.Generator) -> Array:
    centres = rng.uniform(0.08, 0.92, (14, 2))
    dots = [(YELLOW, lambda x, y, c=c: (x - c[0]) ** 2 + ((y - c[1]) * 0.8) ** 2 < 0.08**2) for c in centres]
    return _paint(x, y, [(CYAN, None), *dots])


def _patchwork(x: Array, y: Array, rng: np.random.Generator) -> Array:
    palette = [RED, YELLOW, CYAN, VIOLET]
    edges_x, edges_y = np.sort(rng.uniform(0.15, 0.85, 2)), np.sort(rng.uniform(0.15, 0.85, 2))

    def cell(k: int) -> Callable[[Array, Array], Mask]:
        return lambda x, y: np.asarray(np.searchsorted(edges_x, x) * 3 + np.searchsorted(edges_y, y) == k)

    cells: Layers = [(palette[int(rng.integers(len(palette)))], cell(k)) for k in range(9)]
    return _paint(x, y, cells)


def _layered(layers: Layers) -> Callable[[Array, Array, np.random.Generator], Array]:
    return lambda x, y, rng: _paint(x, y, layers)


def _stripes(x: Array, y: Array) -> Mask:
    return (x * 8).astype(int) % 2 == 1


def _checks(x: Array, y: Array) -> Mask:
    return ((x * 8).astype(int) + (y * 6).astype(int)) % 2 == 1


def _diagonals(x: Array, y: Array) -> Mask:
    return ((x + y) * 6).astype(int) % 2 == 1


Pattern = Callable[[Array, Array, np.random.Generator], Array]
_CATALOGUE: list[tuple[str, tuple[float, float], Callable[[Array, Array], Mask], Pattern]] = [
    ("red_plain", (0.20, 0.15), _rectangle, _layered([(RED, None)])),
    ("yellow_square", (0.18, 0.18), _rectangle, _layered([(YELLOW, None)])),
    ("red_yellow_stripes", (0.25, 0.20), _rectangle, _layered([(RED, None), (YELLOW, _stripes)])),
    ("small_colourful", (0.15, 0.12), _rectangle, _layered([
        (CYAN, None), (RED, lambda x, y: x < 0.5), (YELLOW, lambda x, y: y > 0.6),
        (VIOLET, lambda x, y: (x - 0.7) ** 2 + (y - 0.3) ** 2 < 0.05)])),
    ("violet_yellow_checks", (0.22, 0.18), _rectangle, _layered([(VIOLET, None), (YELLOW, _checks)])),
    ("yellow_dots_on_cyan", (0.20, 0.16), _rectangle, _dots),
    ("cyan_rounded", (0.22, 0.16), _rounded(0.2), _layered([(CYAN, None)])),
    ("violet_red_trapezoid", (0.20, 0.16), _trapezoid,
     _layered([(VIOLET, None), (RED, lambda x, y: y > 0.5)])),
    ("red_cyan_tshirt", (0.25, 0.20), _tshirt,
     _layered([(RED, None), (CYAN, lambda x, y: y > 0.45)])),
    ("violet_ellipse", (0.20, 0.14), _ellipse, _layered([(VIOLET, None)])),
    ("cyan_violet_diagonals", (0.20, 0.20), _rectangle, _layered([(CYAN, None), (VIOLET, _diagonals)])),
    ("patchwork", (0.24, 0.18), _rectangle, _patchwork),
    ("orange_l_shape", (0.20, 0.18), _l_shape, _layered([(ORANGE, None), (CRIMSON, lambda x, y: x < 0.2)])),
]  # fmt: skip
CATALOGUE_SIZE = len(_CATALOGUE)


def synthetic_cloth(index: int, seed: int = 0) -> SyntheticCloth:
    """One cloth of the catalogue (see `cloth_catalogue`): never green, saturated hues.

    Args:
        index: 0 .. CATALOGUE_SIZE - 1.
        seed: varies the random parts of a pattern (dots, patches, fabric grain).
    """
    if not 0 <= index < CATALOGUE_SIZE:
        raise ValueError(f"synthetic cloth index must be in 0..{CATALOGUE_SIZE - 1}, got {index}")
    rng = np.random.default_rng([seed, index])
    name, (width, height), outline, pattern = _CATALOGUE[index]
    shape = (round(height / CLOTH_TEXEL), round(width / CLOTH_TEXEL))
    y, x = (np.indices(shape) + 0.5) * CLOTH_TEXEL
    x, y = x / width, y / height  # (0, 1) across the cloth
    colours = np.asarray(pattern(x, y, rng), dtype=float)
    grain = rng.normal(0.0, 4.0, (*shape, 1))  # fabric texture, a few grey levels
    texture = np.clip(colours + grain, 0, 255).astype(np.uint8)
    return SyntheticCloth(name, texture, outline(x, y), (shape[1] * CLOTH_TEXEL, shape[0] * CLOTH_TEXEL))


__all__ = ["CATALOGUE_SIZE", "CLOTH_TEXEL", "synthetic_cloth"]
