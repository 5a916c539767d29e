"""The catalogue of sample cloths: No.1-No.12 (paper Fig. 10) and the extended No.13-No.20.

A cloth's textures are drawn deterministically from its catalogue entry (no downloads):
the flat cartoon colours of its pattern (`texture_image`, what the clean cell shows) and
its fabric look (`fabric_texture_image`: weave, colour variation, prints) with a darker,
duller back side. Texture coordinates: the image spans the cloth's bounding box, image x
(right) along Σ_M x and image y (down) along Σ_M y, `TEXTURE_PX_PER_M` pixels per metre.
Outlines are polygons in the same texture frame [m] (origin at the box's top-left corner).

Colours avoid the green of the background sheet (HSV_FULL hue 85 ± 30): the model photo
is taken on it, and a green cloth would vanish (a user would pick another sheet). No.1-12
keep mutually distinct hues away from the blue occluder, as before. No.13-20 do not:
they add hue families (three blues, a second red, two whites) and cloths without hue
(white, grey, black with a photo print, navy), so that the hue band alone does not tell
cloths apart, and blue cloths meet the blue paper.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray
from robot_app.errors import InputError
from robot_app.sim.fabrics import Fabric, back_texture, fabric_texture

TEXTURE_PX_PER_M = 2000.0  # 2 px/mm: finer than both cameras' footprint (< 1.8 px/mm)
MAX_SIZE = (0.25, 0.20)  # largest cloth [m], paper Sec. III
OUTLINES = ("rectangle", "rounded", "trapezoid", "shirt", "ellipse")
PATTERNS = ("plain", "stripes", "checks", "dots", "motifs", "patches", "plaid", "diagonal")

BGR = tuple[int, int, int]
PLAIN_WEAVE = Fabric()


@dataclass(frozen=True)
class ClothSpec:
    """One catalogue cloth.

    Attributes:
        number: catalogue number 1-20.
        name: short description.
        size: (width, height) of the bounding box [m]; width along Σ_M x.
        outline: one of OUTLINES.
        pattern: one of PATTERNS.
        colours: BGR colours [0-255] used by the pattern (first = ground colour).
        mass: total mass [kg] of the real cloth; the simulation gives every mesh node
            the same mass instead (see `cloth_body`).
        scale: pattern period [m] (stripe width, check size, dot spacing...).
        fabric: weave, print and variation of its fabric look.
    """

    number: int
    name: str
    size: tuple[float, float]
    outline: str
    pattern: str
    colours: tuple[BGR, ...]
    mass: float
    scale: float = 0.02
    fabric: Fabric = PLAIN_WEAVE

    def __post_init__(self) -> None:
        width, height = self.size
        if not (0.03 <= width <= MAX_SIZE[0] + 1e-9 and 0.03 <= height <= MAX_SIZE[1] + 1e-9):
            raise ValueError(f"cloth size {self.size} m must lie within 0.03 .. {MAX_SIZE} m")
        if self.outline not in OUTLINES:
            raise ValueError(f"outline {self.outline!r} is not one of {OUTLINES}")
        if self.pattern not in PATTERNS:
            raise ValueError(f"pattern {self.pattern!r} is not one of {PATTERNS}")
        if self.mass <= 0 or not self.colours:
            raise ValueError("a cloth needs a positive mass [kg] and at least one colour")


# BGR. No cloth colour is within the fitness' hue threshold (30 of 256) of the green sheet
# (hue ~88) or of the blue occluder paper (hue ~162): a blue cloth would match the paper
# that hides it. White and black carry no hue; they shape the outline only.
RED, WHITE, BLACK, YELLOW = (40, 30, 200), (225, 225, 225), (35, 35, 35), (30, 200, 225)
MAGENTA, ORANGE, PURPLE, PINK = (170, 40, 200), (30, 120, 230), (150, 50, 110), (160, 110, 230)
VIOLET, BROWN, TURQUOISE, MAROON = (210, 60, 150), (40, 60, 120), (190, 200, 40), (50, 30, 130)

# No.13-20: hue families and cloths without hue (BGR)
INDIGO, SKY, NAVY, CRIMSON = (140, 85, 45), (225, 175, 120), (80, 35, 20), (45, 25, 165)
TOWEL_WHITE, LINEN, GREY, TEE_BLACK = (228, 230, 232), (212, 224, 230), (128, 128, 128), (32, 32, 34)
PETAL_PINK, PETAL_WHITE, DUSK_BLUE, DUSK_ORANGE = (
    (185, 140, 240),
    (235, 235, 240),
    (120, 60, 35),
    (40, 120, 240),
)

CATALOGUE: tuple[ClothSpec, ...] = (
    ClothSpec(1, "plain red towel", (0.24, 0.19), "rectangle", "plain", (RED,), 0.060,
              fabric=Fabric("pile", 3.0, 0.18, 0.05)),
    ClothSpec(2, "turquoise-white stripes", (0.22, 0.18), "rectangle", "stripes", (WHITE, TURQUOISE),
              0.050, 0.016, Fabric("plain", 3.0, 0.1, 0.04)),
    ClothSpec(3, "small colourful patchwork, light", (0.16, 0.13), "rounded", "patches",
              (YELLOW, RED, MAGENTA, VIOLET, ORANGE, TURQUOISE), 0.018, 0.032,
              Fabric("plain", 2.5, 0.08, 0.05, "floral", (WHITE, PINK, YELLOW), 0.12, 0.6)),
    ClothSpec(4, "yellow-black checks", (0.20, 0.17), "rectangle", "checks", (YELLOW, BLACK), 0.045,
              0.025, Fabric("twill", 4.0, 0.12, 0.05)),
    ClothSpec(5, "pink with white dots", (0.21, 0.16), "rounded", "dots", (PINK, WHITE), 0.035, 0.03,
              Fabric("knit", 5.0, 0.12, 0.05, back_fade=0.7)),
    ClothSpec(6, "white with printed motifs", (0.19, 0.19), "rectangle", "motifs", (WHITE, RED, VIOLET),
              0.04, 0.05, Fabric("plain", 3.0, 0.08, 0.04, back_fade=0.75)),
    ClothSpec(7, "purple child's shirt", (0.25, 0.20), "shirt", "plain", (PURPLE, WHITE), 0.070,
              fabric=Fabric("knit", 5.0, 0.14, 0.06)),
    ClothSpec(8, "orange diagonal stripes", (0.23, 0.17), "trapezoid", "diagonal", (ORANGE, BROWN), 0.05,
              0.02, Fabric("twill", 4.0, 0.12, 0.05)),
    ClothSpec(9, "magenta-yellow stripes", (0.18, 0.15), "rectangle", "stripes", (MAGENTA, YELLOW), 0.03,
              0.022, Fabric("plain", 3.0, 0.1, 0.05)),
    ClothSpec(10, "turquoise oval mat, black dots", (0.20, 0.14), "ellipse", "dots", (TURQUOISE, BLACK), 0.04,
              0.035, Fabric("pile", 4.0, 0.16, 0.06, back_fade=0.5)),
    ClothSpec(11, "tartan", (0.25, 0.18), "rectangle", "plaid", (RED, BLACK, YELLOW), 0.065, 0.05,
              Fabric("twill", 4.0, 0.15, 0.05)),
    ClothSpec(12, "maroon handkerchief, white dots", (0.14, 0.12), "rectangle", "dots", (MAROON, WHITE),
              0.015, fabric=Fabric("plain", 2.5, 0.08, 0.05, back_fade=0.6)),
    ClothSpec(13, "indigo denim", (0.24, 0.18), "rectangle", "plain", (INDIGO,), 0.070,
              fabric=Fabric("denim", 4.0, 0.22, 0.1, back_fade=0.5)),
    ClothSpec(14, "light-blue knit jersey", (0.21, 0.17), "rounded", "plain", (SKY,), 0.040,
              fabric=Fabric("knit", 5.0, 0.12, 0.06)),
    ClothSpec(15, "navy twill napkin", (0.20, 0.20), "rectangle", "plain", (NAVY,), 0.045,
              fabric=Fabric("twill", 3.5, 0.14, 0.06)),
    ClothSpec(16, "crimson floral print", (0.20, 0.16), "rounded", "plain", (CRIMSON,), 0.035,
              fabric=Fabric("plain", 2.5, 0.08, 0.05, "floral", (PETAL_PINK, PETAL_WHITE), 0.22, 0.65)),
    ClothSpec(17, "white terry towel", (0.23, 0.17), "rectangle", "plain", (TOWEL_WHITE,), 0.060,
              fabric=Fabric("pile", 3.0, 0.16, 0.04)),
    ClothSpec(18, "white linen napkin", (0.18, 0.18), "rectangle", "plain", (LINEN,), 0.030,
              fabric=Fabric("plain", 3.0, 0.1, 0.05)),
    ClothSpec(19, "grey melange knit", (0.21, 0.17), "trapezoid", "plain", (GREY,), 0.045,
              fabric=Fabric("knit", 4.5, 0.14, 0.12)),
    ClothSpec(20, "black tee with a photo print", (0.25, 0.20), "shirt", "plain", (TEE_BLACK, (60, 60, 62)),
              0.075, fabric=Fabric("knit", 5.0, 0.12, 0.05, "photo", (DUSK_BLUE, DUSK_ORANGE), 0.45, 0.85)),
)  # fmt: skip


# Cloths of one dominant hue (or of none), which the hue fitness alone hardly tells apart:
# scenes put them together to test identification; the robot never reads this table.
HUE_FAMILIES: dict[str, tuple[int, ...]] = {
    "blue": (13, 14, 15),
    "red": (1, 11, 12, 16),
    "white": (6, 17, 18),
    "no_hue": (19, 20),
}


def hue_family(number: int) -> str | None:
    """The name of cloth No.`number`'s hue family (`HUE_FAMILIES`), or None."""
    return next((name for name, members in HUE_FAMILIES.items() if number in members), None)


def cloth_spec(number: int) -> ClothSpec:
    """The catalogue cloth No.`number` (1-20)."""
    if not 1 <= int(number) <= len(CATALOGUE):
        raise InputError(
            f"cloth number must be 1..{len(CATALOGUE)}, got {number}",
            value=number,
            expected=f"1..{len(CATALOGUE)}",
        )
    return CATALOGUE[int(number) - 1]


def outline_polygon(spec: ClothSpec, corner_points: int = 6) -> FloatArray:
    """The cloth's outline, (K, 2) counter-clockwise in image axes, texture frame [m]."""
    w, h = spec.size
    if spec.outline == "rectangle":
        pts = [(0, 0), (0, h), (w, h), (w, 0)]
    elif spec.outline == "trapezoid":
        inset = 0.18 * w
        pts = [(inset, 0), (0, h), (w, h), (w - inset, 0)]
    elif spec.outline == "ellipse":
        t = np.linspace(0, 2 * np.pi, 40, endpoint=False)
        pts = list(zip(w / 2 + w / 2 * np.cos(t), h / 2 - h / 2 * np.sin(t), strict=True))
    elif spec.outline == "rounded":
        r = 0.2 * min(w, h)
        pts = []
        corners = ((r, r, np.pi), (w - r, r, 1.5 * np.pi), (w - r, h - r, 0.0), (r, h - r, 0.5 * np.pi))
        for cx, cy, start in corners:  # image axes (y down): angle t sweeps clockwise on screen
            for t in np.linspace(start, start + 0.5 * np.pi, corner_points):
                pts.append((cx + r * np.cos(t), cy + r * np.sin(t)))
    else:  # shirt: body with short sleeves and a neckline, symmetric about x = w/2
        u = np.array(
            [(0.30, 0.0), (0.42, 0.08), (0.58, 0.08), (0.70, 0.0), (1.0, 0.22), (0.86, 0.42),
             (0.78, 0.34), (0.78, 1.0), (0.22, 1.0), (0.22, 0.34), (0.14, 0.42), (0.0, 0.22)]
        )  # fmt: skip
        pts = [(x * w, y * h) for x, y in u[::-1]]
    polygon = np.asarray(pts, dtype=float)
    if polygon_area(polygon) < 0:
        polygon = polygon[::-1]
    return polygon


def polygon_area(polygon: npt.ArrayLike) -> float:
    """Signed area [m²] (shoelace); positive when counter-clockwise in (x, y)."""
    P = np.asarray(polygon, dtype=float)
    x, y = P[:, 0], P[:, 1]
    return float(0.5 * np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def polygon_centroid(polygon: npt.ArrayLike) -> FloatArray:
    """Area centroid (2,) of a simple polygon [m]."""
    P = np.asarray(polygon, dtype=float)
    x, y = P[:, 0], P[:, 1]
    cross = x * np.roll(y, -1) - np.roll(x, -1) * y
    area = 0.5 * cross.sum()
    cx = np.sum((x + np.roll(x, -1)) * cross) / (6 * area)
    cy = np.sum((y + np.roll(y, -1)) * cross) / (6 * area)
    return np.array([cx, cy])


def texture_image(spec: ClothSpec) -> npt.NDArray[np.uint8]:
    """The cloth's (H, W, 3) BGR cartoon texture (flat colours) covering its bounding box."""
    width = round(spec.size[0] * TEXTURE_PX_PER_M)
    height = round(spec.size[1] * TEXTURE_PX_PER_M)
    colours = spec.colours
    image = np.empty((height, width, 3), np.uint8)
    image[:] = colours[0]
    period = max(4, round(spec.scale * TEXTURE_PX_PER_M))
    rng = np.random.default_rng(1000 + spec.number)
    ys, xs = np.mgrid[0:height, 0:width]
    second = colours[1 % len(colours)]
    if spec.pattern == "stripes":
        image[(ys // (period // 2)) % 2 == 1] = second
    elif spec.pattern == "diagonal":
        image[((xs + ys) // (period // 2)) % 2 == 1] = second
    elif spec.pattern == "checks":
        image[((xs // period) + (ys // period)) % 2 == 1] = second
    elif spec.pattern == "plaid":
        for k, colour in enumerate(colours[1:]):
            band = period // (4 + 2 * k)
            offset = k * period // 3
            image[((xs + offset) % period) < band] = colour
            image[((ys + offset) % period) < band] = colour
    elif spec.pattern == "dots":
        radius = max(2, period // 5)
        for j, y in enumerate(range(period // 2, height, period)):
            for x in range(period // 2 + (j % 2) * period // 2, width, period):
                cv2.circle(image, (x, y), radius, second, -1, cv2.LINE_8)
    elif spec.pattern == "patches":
        for y in range(0, height, period):
            for x in range(0, width, period):
                colour = colours[int(rng.integers(len(colours)))]
                cv2.rectangle(image, (x, y), (x + period - 1, y + period - 1), colour, -1)
        for _ in range(6):
            centre = (int(rng.integers(width)), int(rng.integers(height)))
            colour = colours[int(rng.integers(len(colours)))]
            cv2.circle(image, centre, int(rng.integers(period // 3, period)), colour, -1)
    elif spec.pattern == "motifs":
        for j, y in enumerate(range(period // 2, height, period)):
            for i, x in enumerate(range(period // 2, width, period)):
                colour = colours[1 + (i + j) % (len(colours) - 1)]
                s = period // 3
                if (i + j) % 2 == 0:
                    tri = np.array([(x, y - s), (x - s, y + s), (x + s, y + s)], np.int32)
                    cv2.fillPoly(image, [tri], colour)
                else:
                    cv2.circle(image, (x, y), s, colour, -1)
    elif spec.pattern == "plain" and spec.outline == "shirt":
        # a contrasting collar band and hem make the silhouette's orientation visible
        image[: height // 10] = second
        image[-height // 12 :] = second
    return image


def fabric_texture_image(spec: ClothSpec) -> npt.NDArray[np.uint8]:
    """The cloth's (H, W, 3) BGR fabric look: its pattern woven, knitted or printed."""
    return fabric_texture(texture_image(spec), spec.fabric, spec.number)


def fabric_atlas_image(spec: ClothSpec) -> npt.NDArray[np.uint8]:
    """(H, 2W, 3) front (left half) and back side (right half) of the cloth's fabric."""
    front = fabric_texture_image(spec)
    return np.hstack([front, back_texture(front, spec.fabric, spec.number)])


TEXTURE_KINDS = ("flat", "flat_atlas", "fabric")


def texture_path(spec: ClothSpec, cache_dir: str | Path, kind: str = "flat") -> Path:
    """Writes (once) and returns one of the cloth's texture PNGs in `cache_dir`.

    Kinds: `flat` the cartoon texture; `flat_atlas` it twice side by side (front | back,
    for a render mesh); `fabric` the fabric atlas (front | back side).
    """
    if kind not in TEXTURE_KINDS:
        raise ValueError(f"texture kind {kind!r} is not one of {TEXTURE_KINDS}")
    folder = Path(cache_dir)
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"cloth_{spec.number:02d}_{kind}_{_spec_tag(spec)}.png"
    if not path.is_file():
        if kind == "fabric":
            image = fabric_atlas_image(spec)
        elif kind == "flat_atlas":
            image = np.hstack([texture_image(spec)] * 2)
        else:
            image = texture_image(spec)
        tmp = path.with_suffix(f".{np.random.default_rng().integers(1 << 30)}.png")
        cv2.imwrite(str(tmp), image)
        tmp.replace(path)
    return path


TEXTURE_VERSION = 3  # bump when the drawing code changes, so cached textures are redrawn


def _spec_tag(spec: ClothSpec) -> str:
    import hashlib

    return hashlib.sha1(f"{TEXTURE_VERSION}{spec!r}".encode()).hexdigest()[:10]


__all__ = [
    "CATALOGUE",
    "HUE_FAMILIES",
    "MAX_SIZE",
    "OUTLINES",
    "PATTERNS",
    "TEXTURE_KINDS",
    "TEXTURE_PX_PER_M",
    "ClothSpec",
    "cloth_spec",
    "fabric_atlas_image",
    "fabric_texture_image",
    "hue_family",
    "outline_polygon",
    "polygon_area",
    "polygon_centroid",
    "texture_image",
    "texture_path",
]
