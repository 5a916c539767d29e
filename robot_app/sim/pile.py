"""Several cloths on the table from a seed: some apart, some lying on others, wrinkled.

`make_pile` draws 2-6 catalogue cloths (or takes the ones given), places each at a
random pose inside the recognition range and drops them one after the other, each from
above the cloths already under it (above the top of the highest stack its outline
overlaps, a folded cloth counting two layers), so that a later cloth lies on an earlier one
where their outlines overlap: a real overlap of soft bodies (pybullet's deformable-deformable
contact keeps them apart by about twice `world.cloth.collision_margin`; below 7 mm of
margin the contact lets most nodes through, so the clear-table config sets 8 mm). Each
cloth is wrinkled and maybe folded as the realism preset says.

A pile can be asked to overlap (the largest overlap of two cloths at least
`min_overlap` of the smaller one's area), to keep every cloth apart, or to hold two or
more cloths of one hue family (`cloths.HUE_FAMILIES`). What it reports about the layout
(`PileCloth.covered`, `Pile.max_overlap`, which cloth lies on which) is ground truth,
for judging only.

Same world config, same `PileSettings`, same seed: same pile, same images.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from pydantic import Field, field_validator, model_validator

from robot_app.arrays import FloatArray
from robot_app.config import StrictModel
from robot_app.errors import SimulationError
from robot_app.geometry import rotation_about_z
from robot_app.sim.cloth_body import ClothBody
from robot_app.sim.cloth_visual import ClothLook
from robot_app.sim.cloths import (
    HUE_FAMILIES,
    ClothSpec,
    cloth_spec,
    hue_family,
    outline_polygon,
    polygon_centroid,
)
from robot_app.sim.config import CATALOGUE_SIZE
from robot_app.sim.realism import scene_defaults
from robot_app.sim.world import World

MAX_LAYOUTS = 400  # layouts drawn before a pile's wishes count as impossible
MAX_POSES = 200  # poses tried per cloth within one layout
RASTER = 0.002  # grid of the overlap measurement [m]
ALL_CLOTHS = tuple(range(1, CATALOGUE_SIZE + 1))


class PileSettings(StrictModel):
    """What `make_pile` puts on the table.

    Attributes:
        cloths: the catalogue numbers to lay out, in drop order; None: `count` drawn from
            `candidates`.
        count: (fewest, most) cloths drawn when `cloths` is None (2-6).
        candidates: the catalogue numbers drawn from.
        layout: one (x, y, yaw) per cloth [m, m, rad]: Σ_M's origin in Σ_W and its turn;
            None: random poses inside the range.
        overlap: "any" (random, cloths may overlap), "apart" (every two cloths at least
            `gap` apart) or "overlap" (the largest overlap of two cloths covers at least
            `min_overlap` of the smaller one's area).
        min_overlap: see `overlap` [-].
        max_cover: no cloth covers more than this share of an earlier one's area [-]
            (1: a cloth may vanish under another).
        same_family: at least two drawn cloths share a hue family (`HUE_FAMILIES`).
        gap: least distance between two cloths kept apart [m].
        margin: cloths' outlines stay this far inside the range [m].
        drop_height: a cloth starts this far above the highest cloth under it [m].
        wrinkle_amplitude, fold_probability: None takes the realism preset's.
    """

    cloths: tuple[int, ...] | None = None
    count: tuple[int, int] = (3, 5)
    candidates: tuple[int, ...] = ALL_CLOTHS
    layout: tuple[tuple[float, float, float], ...] | None = None
    overlap: str = Field("any", pattern="^(any|apart|overlap)$")
    min_overlap: float = Field(0.2, ge=0.0, le=0.8)
    max_cover: float = Field(0.6, gt=0.0, le=1.0)
    same_family: bool = False
    gap: float = Field(0.01, ge=0.0, le=0.1)
    margin: float = Field(0.0, ge=-0.05, le=0.1)
    drop_height: float = Field(0.01, ge=0.0, le=0.2)
    wrinkle_amplitude: float | None = Field(None, ge=0.0, le=0.03)
    fold_probability: float | None = Field(None, ge=0.0, le=1.0)

    @field_validator("cloths", "candidates")
    @classmethod
    def _catalogue_numbers(cls, value: tuple[int, ...] | None) -> tuple[int, ...] | None:
        if value is None:
            return value
        if any(not 1 <= n <= CATALOGUE_SIZE for n in value):
            raise ValueError(f"catalogue numbers are 1-{CATALOGUE_SIZE}, got {list(value)}")
        if len(set(value)) != len(value):
            raise ValueError(f"each catalogue cloth exists once, got {list(value)}")
        return value

    @model_validator(mode="after")
    def _consistent(self) -> PileSettings:
        low, high = self.count
        if not 2 <= low <= high <= 6:
            raise ValueError(f"count must be (fewest, most) within 2-6, got {self.count}")
        if self.cloths is not None and not 1 <= len(self.cloths) <= 6:
            raise ValueError(f"a pile holds 1-6 cloths, got {len(self.cloths)}")
        if self.cloths is None and len(self.candidates) < high:
            raise ValueError(f"{len(self.candidates)} candidates cannot give {high} different cloths")
        if self.layout is not None and (self.cloths is None or len(self.layout) != len(self.cloths)):
            raise ValueError("layout needs `cloths` and one (x, y, yaw) per cloth")
        return self


@dataclass(frozen=True)
class PileCloth:
    """One cloth of a pile (ground truth).

    Attributes:
        body: the soft body.
        number: its catalogue number.
        order: drop order, 0 first (lowest where cloths overlap).
        covered: share of its area under cloths dropped later, as laid out [-].
    """

    body: ClothBody
    number: int
    order: int
    covered: float


@dataclass(frozen=True)
class Pile:
    """What `make_pile` placed.

    Attributes:
        seed: the seed it was made from.
        cloths: the cloths in drop order.
        max_overlap: largest overlap of two cloths as laid out, over the smaller one's area [-].
        same_family: two or more cloths share a hue family.
        settle_time: simulated time the pile took to settle [s].
    """

    seed: int
    cloths: tuple[PileCloth, ...]
    max_overlap: float
    same_family: bool
    settle_time: float

    def by_number(self, number: int) -> PileCloth:
        """The cloth No.`number` of the pile.

        Raises:
            KeyError: no such cloth in the pile.
        """
        for cloth in self.cloths:
            if cloth.number == number:
                return cloth
        raise KeyError(f"cloth No.{number} is not in the pile")


def make_pile(world: World, settings: PileSettings | None = None, seed: int = 0) -> Pile:
    """Lays a pile of cloths in `world` and lets it settle.

    Raises:
        SimulationError: no layout meets the settings (too many or too large cloths for
            the range, or an overlap that cannot be had).
    """
    s = settings or PileSettings()
    rng = np.random.default_rng((seed, 23))
    world.reseed(seed)
    numbers = list(s.cloths) if s.cloths is not None else _draw_cloths(rng, s)
    specs = [cloth_spec(n) for n in numbers]
    poses = list(s.layout) if s.layout is not None else _draw_layout(rng, world, specs, s)
    outlines = [_placed_outline(spec, *pose) for spec, pose in zip(specs, poses, strict=True)]
    rasters = _rasters(outlines)
    defaults = scene_defaults(world.config.realism)
    amplitude = defaults["wrinkle_amplitude"] if s.wrinkle_amplitude is None else s.wrinkle_amplitude
    folds = defaults["fold_probability"] if s.fold_probability is None else s.fold_probability
    look_rng = np.random.default_rng((seed, 29))
    layer = 2.0 * world.config.cloth.collision_margin + 0.002
    bodies = []
    tops: list[int] = []  # layers up to each dropped cloth's top (a folded one is two thick)
    for k, (spec, (x, y, yaw)) in enumerate(zip(specs, poses, strict=True)):
        under = max((tops[j] for j in range(k) if np.any(rasters[j] & rasters[k])), default=0)
        look = ClothLook.draw(look_rng, spec.size, amplitude, folds)
        tops.append(under + (2 if look.fold is not None else 1))
        bodies.append(
            world.add_cloth(spec, x, y, yaw, under * layer + s.drop_height, settle=False, look=look)
        )
    settle_time = world.settle()
    covered = [_covered(rasters, k) for k in range(len(specs))]
    cloths = tuple(
        PileCloth(body, n, k, c) for k, (body, n, c) in enumerate(zip(bodies, numbers, covered, strict=True))
    )
    families = [hue_family(n) for n in numbers]
    same = any(f is not None and families.count(f) > 1 for f in families)
    return Pile(seed, cloths, _max_overlap(rasters), same, settle_time)


def _draw_cloths(rng: np.random.Generator, s: PileSettings) -> list[int]:
    count = int(rng.integers(s.count[0], s.count[1] + 1))
    candidates = list(s.candidates)
    chosen: list[int] = []
    if s.same_family:
        families = [m for m in HUE_FAMILIES.values() if sum(n in candidates for n in m) >= 2]
        if not families:
            raise SimulationError("same_family: no hue family has two cloths among the candidates")
        members = [n for n in families[int(rng.integers(len(families)))] if n in candidates]
        chosen = [
            int(n)
            for n in rng.choice(
                members, size=min(len(members), count, 2 + int(rng.integers(2))), replace=False
            )
        ]
    rest = [n for n in candidates if n not in chosen]
    chosen += [int(n) for n in rng.choice(rest, size=count - len(chosen), replace=False)]
    order = rng.permutation(len(chosen))
    return [chosen[i] for i in order]


def _draw_layout(
    rng: np.random.Generator, world: World, specs: list[ClothSpec], s: PileSettings
) -> list[tuple[float, float, float]]:
    """Random poses keeping each outline inside the range, with the wished overlap."""
    centre = np.asarray(world.config.range.centre_xy)
    half = np.asarray(world.config.range.size_xy) / 2 - s.margin
    for _ in range(MAX_LAYOUTS):
        poses: list[tuple[float, float, float]] = []
        outlines: list[FloatArray] = []
        for spec in specs:
            pose = _free_pose(rng, spec, centre, half, outlines, s)
            if pose is None:
                break
            poses.append(pose)
            outlines.append(_placed_outline(spec, *pose))
        else:
            if s.overlap != "overlap" or _max_overlap(_rasters(outlines)) >= s.min_overlap:
                return poses
    numbers = ", ".join(f"No.{spec.number}" for spec in specs)
    raise SimulationError(
        f"no layout of {numbers} in the range with overlap '{s.overlap}' after {MAX_LAYOUTS} tries"
    )


def _free_pose(
    rng: np.random.Generator,
    spec: ClothSpec,
    centre: FloatArray,
    half: FloatArray,
    placed: list[FloatArray],
    s: PileSettings,
) -> tuple[float, float, float] | None:
    """A pose inside the range, apart from or covering at most `max_cover` of the placed cloths."""
    for _ in range(MAX_POSES):
        yaw = float(rng.uniform(-np.pi, np.pi))
        xy = centre + rng.uniform(-half, half)
        corners = _placed_outline(spec, float(xy[0]), float(xy[1]), yaw)
        if np.any(np.abs(corners - centre) > half + 1e-9):
            continue
        if s.overlap == "apart":
            if all(_distance(corners, other) >= s.gap for other in placed):
                return float(xy[0]), float(xy[1]), yaw
            continue
        masks = _rasters([*placed, corners])
        if all(_covered(masks, j) <= s.max_cover for j in range(len(placed))):
            return float(xy[0]), float(xy[1]), yaw
    return None


def _share(mask: np.ndarray, over: np.ndarray) -> float:
    """Share of `mask`'s area that `over` covers."""
    return float(np.count_nonzero(mask & over) / max(int(np.count_nonzero(mask)), 1))


def _placed_outline(spec: ClothSpec, x: float, y: float, yaw: float) -> FloatArray:
    """(K, 2) outline of a cloth lying face up with Σ_M's origin (the outline's area centroid)
    at (x, y), turned by yaw [m]."""
    outline = outline_polygon(spec)
    outline = outline - polygon_centroid(outline)
    # a face-up cloth's Σ_M has y flipped against the world (world.FLIP_FACE_UP)
    outline = outline * np.array([1.0, -1.0])
    return outline @ rotation_about_z(yaw)[:2, :2].T + np.array([x, y])


def _distance(a: FloatArray, b: FloatArray) -> float:
    """Least distance between two polygons' edges [m] (0 if they overlap), on a 2 mm raster."""
    masks = _rasters([a, b], pad=0.1)
    if np.any(masks[0] & masks[1]):
        return 0.0
    inside = np.asarray(masks[1], dtype=np.uint8)
    distance = cv2.distanceTransform(1 - inside, cv2.DIST_L2, 5)
    return float(distance[masks[0]].min()) * RASTER - RASTER


def _rasters(outlines: list[FloatArray], pad: float = 0.0) -> list[np.ndarray]:
    """Boolean masks of polygons on one RASTER grid covering them all."""
    low = np.min([o.min(axis=0) for o in outlines], axis=0) - pad
    high = np.max([o.max(axis=0) for o in outlines], axis=0) + pad
    shape = tuple(int(v) for v in np.ceil((high - low) / RASTER)[::-1] + 1)
    masks = []
    for outline in outlines:
        mask = np.zeros(shape, np.uint8)
        cv2.fillPoly(mask, [np.round((outline - low) / RASTER).astype(np.int32)], 1)
        masks.append(mask.astype(bool))
    return masks


def _max_overlap(masks: list[np.ndarray]) -> float:
    best = 0.0
    for i in range(len(masks)):
        for j in range(i + 1, len(masks)):
            shared = np.count_nonzero(masks[i] & masks[j])
            if shared:
                smaller = min(np.count_nonzero(masks[i]), np.count_nonzero(masks[j]))
                best = max(best, shared / smaller)
    return best


def _covered(masks: list[np.ndarray], k: int) -> float:
    above = np.zeros_like(masks[k])
    for j in range(k + 1, len(masks)):
        above |= masks[j]
    return _share(masks[k], above)


__all__ = ["Pile", "PileCloth", "PileSettings", "make_pile"]
