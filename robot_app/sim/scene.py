"""Scenes from a seed: the target cloth at a random pose in the recognition range, and
optionally the blue paper occluding a given fraction of it and a distractor cloth.

Each cloth lies as a real one does: wrinkled (ridges up to `wrinkle_amplitude`) and,
with `fold_probability`, with a corner folded over; both default to the world's
realism preset. The key lamp's direction is drawn for the scene, and the cameras'
noise restarts from the scene's seed.

With `conveyor_speed` > 0 the green sheet becomes a running belt (`sim/conveyor.py`),
switched on once the cloths have settled; the target then lies at the upstream edge of
the range, as a cloth the belt has just brought fully into view, and the belt carries it
across.

Same world config, same `SceneSettings`, same seed: same scene, same images.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray
from robot_app.errors import SimulationError
from robot_app.geometry import (
    make_transform,
    rotation_about_z,
    rotation_from_rpy,
)
from robot_app.sim.cloth_body import ClothBody
from robot_app.sim.cloth_visual import ClothLook
from robot_app.sim.cloths import ClothSpec, cloth_spec, outline_polygon, polygon_area
from robot_app.sim.config import SceneSettings
from robot_app.sim.conveyor import BeltArea, BeltMotion, Conveyor
from robot_app.sim.realism import scene_defaults
from robot_app.sim.world import FLIP_FACE_UP, World

MAX_TRIES = 500


@dataclass(frozen=True)
class Scene:
    """What `make_scene` placed.

    Attributes:
        seed: the seed it was made from.
        target: the cloth to recognise and pick.
        distractor: a second cloth, or None.
        occluder: pybullet id of the blue paper, or None.
        occluded_fraction: fraction of the target's area under the paper (0 without one).
        settle_time: simulated time the cloths took to settle [s].
        conveyor: the running belt (also `world.conveyor`), None on a still table.
    """

    seed: int
    target: ClothBody
    distractor: ClothBody | None
    occluder: int | None
    occluded_fraction: float
    settle_time: float
    conveyor: Conveyor | None = None

    @property
    def target_spec(self) -> ClothSpec:
        return self.target.spec


def make_scene(world: World, config: SceneSettings | None = None, seed: int = 0) -> Scene:
    """Places the scene's cloths (and paper) in `world` and lets them settle."""
    config = config or SceneSettings()
    rng = np.random.default_rng(seed)
    world.reseed(seed)
    defaults = scene_defaults(world.config.realism)
    amplitude = (
        defaults["wrinkle_amplitude"] if config.wrinkle_amplitude is None else config.wrinkle_amplitude
    )
    fold_chance = defaults["fold_probability"] if config.fold_probability is None else config.fold_probability
    look_rng = np.random.default_rng((seed, 11))  # own stream: the layout stays the preset-free one
    range_cfg = world.config.range
    centre = np.asarray(range_cfg.centre_xy)
    half = np.asarray(range_cfg.size_xy) / 2 - config.position_margin
    target_spec = cloth_spec(config.target)
    other = cloth_spec(config.distractor) if config.distractor is not None else None
    belt = BeltMotion.from_scene(config)
    upstream = belt.direction[:2] if belt.speed > 0 else None
    for _ in range(MAX_TRIES):
        x, y, yaw = _free_pose(rng, target_spec, centre, half, [])
        if upstream is not None:
            x, y = _slide_upstream(target_spec, x, y, yaw, centre, half, upstream)
        if other is None:
            break
        try:
            # the distractor may reach beyond the range onto the green sheet's margin
            sheet_half = half + range_cfg.sheet_margin
            placed = [_placed_outline(target_spec, x, y, yaw)]
            dx, dy, dyaw = _free_pose(rng, other, centre, sheet_half, placed, tries=40)
            break
        except SimulationError:
            continue
    else:
        raise SimulationError(
            f"no room for cloths No.{target_spec.number} and No.{config.distractor} side by side in the range"
        )
    look = ClothLook.draw(look_rng, target_spec.size, amplitude, fold_chance)
    target = _drop(world, rng, target_spec, x, y, yaw, config.drop_height, look)
    distractor = None
    if other is not None:
        other_look = ClothLook.draw(look_rng, other.size, amplitude, fold_chance)
        distractor = _drop(world, rng, other, dx, dy, dyaw, config.drop_height, other_look)
    settle_time = world.settle()
    occluder, fraction = None, 0.0
    if config.occluder and config.occluded_fraction > 0:
        outline = target.outline_world()[:, :2]
        direction = rng.uniform(-np.pi, np.pi)
        normal = np.array([np.cos(direction), np.sin(direction)])
        offset = _cover_offset(outline, normal, config.occluded_fraction)
        depth, width = config.occluder_size
        paper_centre = outline.mean(axis=0) + normal * (offset + depth / 2)
        occluder = world.add_occluder(tuple(paper_centre), direction, (depth, width))
        fraction = _covered_fraction(outline, normal, offset)
    conveyor = None
    if belt.speed > 0:
        conveyor = Conveyor(belt, BeltArea.under_sheet(world.config))
        world.conveyor = conveyor
        conveyor.start(world.time)
    return Scene(seed, target, distractor, occluder, fraction, settle_time, conveyor)


def _placed_outline(spec: ClothSpec, x: float, y: float, yaw: float) -> FloatArray:
    """(K, 2) outline of a cloth whose centroid is at (x, y), turned by yaw [m]."""
    outline = outline_polygon(spec)
    outline = outline - outline.mean(axis=0)
    return outline @ rotation_about_z(yaw)[:2, :2].T + np.array([x, y])


def _slide_upstream(
    spec: ClothSpec,
    x: float,
    y: float,
    yaw: float,
    centre: FloatArray,
    half: FloatArray,
    direction: FloatArray,
) -> tuple[float, float]:
    """The centroid moved against the belt's unit `direction` until the outline touches the
    edge of the box `centre` +- `half` [m]: a cloth the belt has just brought into view."""
    corners = _placed_outline(spec, x, y, yaw)
    room = []
    for axis in range(2):
        d = float(direction[axis])
        if d > 1e-12:
            room.append(float(np.min(corners[:, axis] - (centre[axis] - half[axis]))) / d)
        elif d < -1e-12:
            room.append(float(np.min(centre[axis] + half[axis] - corners[:, axis])) / -d)
    shift = max(0.0, min(room)) if room else 0.0
    return x - shift * float(direction[0]), y - shift * float(direction[1])


def _apart(a: FloatArray, b: FloatArray, gap: float) -> bool:
    """True if the convex hulls of two outlines are at least `gap` [m] apart (separating axes)."""
    for polygon in (a, b):
        edges = np.roll(polygon, -1, axis=0) - polygon
        normals = np.column_stack([-edges[:, 1], edges[:, 0]])
        normals = normals / np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-12)
        pa, pb = a @ normals.T, b @ normals.T
        separated = (pa.min(axis=0) - pb.max(axis=0) >= gap) | (pb.min(axis=0) - pa.max(axis=0) >= gap)
        if np.any(separated):
            return True
    return False


def _free_pose(
    rng: np.random.Generator,
    spec: ClothSpec,
    centre: FloatArray,
    half: FloatArray,
    placed: list[FloatArray],
    tries: int = MAX_TRIES,
) -> tuple[float, float, float]:
    """A yaw and a centroid keeping the outline inside `half` and 1 cm clear of the `placed` outlines."""
    outline = outline_polygon(spec)
    outline = outline - outline.mean(axis=0)
    for _ in range(tries):
        yaw = float(rng.uniform(-np.pi, np.pi))
        xy = centre + rng.uniform(-half, half)
        corners = outline @ rotation_about_z(yaw)[:2, :2].T + xy
        if np.any(np.abs(corners - centre) > half + 1e-9):
            continue
        if all(_apart(corners, other, 0.01) for other in placed):
            return float(xy[0]), float(xy[1]), yaw
    raise SimulationError(
        f"could not place cloth No.{spec.number} in the range after {tries} tries "
        "(range too small or too crowded)"
    )


def _drop(
    world: World,
    rng: np.random.Generator,
    spec: ClothSpec,
    x: float,
    y: float,
    yaw: float,
    height: float,
    look: ClothLook,
) -> ClothBody:
    if height <= 0:
        return world.add_cloth(spec, x, y, yaw, settle=False, look=look)
    # tilted drops land edge first
    tilt = rotation_from_rpy(rng.uniform(-0.6, 0.6), rng.uniform(-0.6, 0.6), 0.0)
    z = world.config.table.top_z + world.config.cloth.collision_margin + height
    pose = make_transform(tilt @ rotation_about_z(yaw) @ FLIP_FACE_UP, [x, y, z])
    return world.add_cloth_at(spec, pose, settle=False, look=look)


def _clip_half_plane(polygon: FloatArray, normal: FloatArray, offset: float) -> FloatArray:
    """Part of `polygon` where normal · p >= offset (Sutherland-Hodgman)."""
    out = []
    n = len(polygon)
    for i in range(n):
        a, b = polygon[i], polygon[(i + 1) % n]
        da, db = a @ normal - offset, b @ normal - offset
        if da >= 0:
            out.append(a)
        if da * db < 0:
            out.append(a + (b - a) * da / (da - db))
    return np.asarray(out) if out else np.zeros((0, 2))


def _covered_fraction(outline: npt.ArrayLike, normal: FloatArray, offset: float) -> float:
    """Fraction of the outline's area beyond `offset` [m] from its mean along `normal`."""
    P = np.asarray(outline, dtype=float)
    mean = P.mean(axis=0)
    covered = _clip_half_plane(P - mean, normal, offset)
    total = abs(polygon_area(P))
    return abs(polygon_area(covered)) / total if len(covered) >= 3 else 0.0


def _cover_offset(outline: FloatArray, normal: FloatArray, fraction: float) -> float:
    """Offset of the paper's edge along `normal` covering `fraction` of the outline (bisection)."""
    projections = (outline - outline.mean(axis=0)) @ normal
    low, high = float(projections.min()), float(projections.max())
    for _ in range(50):
        middle = 0.5 * (low + high)
        if _covered_fraction(outline, normal, middle) > fraction:
            low = middle
        else:
            high = middle
    return 0.5 * (low + high)


__all__ = ["Scene", "make_scene"]
