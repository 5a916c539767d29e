"""Where to grasp: a point well inside the visible part of the recognised cloth.

The model's own grasp point (the maximum of the distance transform of S_in) may lie
under an occluder. Here the S_in points are projected with the recognised pose into
the right image; those whose image colour matches the model (eq. 9's first case) are
visible, and the chosen point is the visible one farthest from anything that is not
visible cloth (S_out points and hidden S_in points), i.e. a distance transform of the
visible surface.

**In a pile** (`choose_pile_grasp`, the clear-table job's choice): a gripper pinching
into a pile takes every cloth within its reach of the fingers (the simulated one anchors
every node within 35 mm). The point above is the middle of the cloth's visible part, and
on a cloth lying on another that is often right above the other one: both come up, the
load cell says so, the pair is put back (a double pick).

The survey knows more than the loop: every identified cloth's whole footprint at its
surveyed pose (hidden parts included: where it lies *under* the target) and the foreground
no model explains (unknown regions, laid onto the table plane). These are the obstacles.
Among the target's visible points at least `min_edge_gap` inside its own edge (S_out and
its hidden points) and from which it hangs at most `max_reach`, the chosen point is the
one farthest from every obstacle, counted up to `clearance`; among points that all reach
`clearance`, the one deepest inside its edge.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from pydantic import Field
from scipy.spatial import ConvexHull, QhullError, cKDTree

from robot_app.arrays import FloatArray
from robot_app.config import StrictModel
from robot_app.control.cell import StereoCapture
from robot_app.geometry import transform_points
from robot_app.vision import ClothModel, FitnessSettings, StereoRig, colour_codes, colours_match, to_hsv

MIN_VISIBLE_FRACTION = 0.1  # below this the visibility test is not trusted


def visible_grasp_point(
    model: ClothModel,
    rig: StereoRig,
    transform_model_to_camera: npt.ArrayLike,
    capture: StereoCapture,
    params: FitnessSettings | None = None,
) -> FloatArray:
    """Grasp point (3,) [m] in Σ_M, inside the part of the cloth the right camera sees.

    `params` (the recognizer's fitness) say which pixel colour matches a model point
    (`hue_threshold_in`, and which pixels have a tone instead of a hue). Falls back to the
    model's grasp point when too few points are visible.
    """
    params = FitnessSettings() if params is None else params
    T = np.asarray(transform_model_to_camera, dtype=float)
    _, pixels = rig.project_model(T, model.points_in)
    p = params
    codes = colour_codes(to_hsv(capture.right_bgr), p.min_saturation, p.min_value, p.value_split)
    height, width = codes.shape
    u = np.round(pixels[:, 0])
    v = np.round(pixels[:, 1])
    inside = np.isfinite(u) & np.isfinite(v) & (u >= 0) & (u < width) & (v >= 0) & (v < height)
    visible = np.zeros(len(model.points_in), dtype=bool)
    observed = codes[v[inside].astype(int), u[inside].astype(int)]
    visible[inside] = colours_match(observed, model.hues_in[inside], params.hue_threshold_in)
    if visible.mean() < MIN_VISIBLE_FRACTION:
        return np.array(model.grasp_point, dtype=float)
    blockers = np.concatenate([model.points_out[:, :2], model.points_in[~visible, :2]])
    candidates = model.points_in[visible, :2]
    gaps = np.linalg.norm(candidates[:, None, :] - blockers[None, :, :], axis=2).min(axis=1)
    best = candidates[int(np.argmax(gaps))]
    return np.array([best[0], best[1], 0.0])


class PileGraspSettings(StrictModel):
    """How the job chooses where to grasp in a pile (the `clear.pile_grasp` section).

    Attributes:
        enabled: choose the grasp point away from other cloths (False: the loop's own
            `visible_grasp_point`).
        clearance: wanted distance from the grasp point to any other cloth [m]; points
            farther than this count as equally clear.
        min_edge_gap: the grasp point lies at least this far inside the target's visible
            edge when any point does [m].
        obstacle_step_px: unknown regions are sampled every this many pixels [px].
        max_reach: the cloth hangs at most this far below the fingers from the chosen
            point (its farthest S_in point), when any visible point allows it: a cloth
            held near a corner hangs low enough to drag over a box wall [m].
        reach_tries: where the arm cannot grasp at the chosen point, this many points
            spread over the candidates are asked (`reachable`).
    """

    enabled: bool = True
    clearance: float = Field(0.06, gt=0.0, le=0.3)
    min_edge_gap: float = Field(0.02, ge=0.0, le=0.2)
    obstacle_step_px: int = Field(3, ge=1, le=20)
    max_reach: float = Field(0.24, gt=0.0, le=1.0)
    reach_tries: int = Field(8, ge=1, le=50)


@dataclass(frozen=True)
class PileGrasp:
    """The chosen grasp point.

    Attributes:
        point_model: (3,) in Σ_M of the pose it was chosen at [m], z = 0.
        point_world: (3,) in Σ_W [m].
        clearance: distance (x, y) to the nearest obstacle point [m] (inf: no obstacle).
        edge_gap: distance to the target's own edge or hidden part [m].
        visible: the share of the target's S_in points seen [0-1].
        moved_for_reach: the best point was out of the hand's reach; this one is not.
    """

    point_model: FloatArray
    point_world: FloatArray
    clearance: float
    edge_gap: float
    visible: float
    moved_for_reach: bool = False


def points_in_mask(
    points_model: npt.ArrayLike,
    transform_model_to_camera: npt.ArrayLike,
    camera_matrix: npt.ArrayLike,
    mask: npt.NDArray[np.bool_],
) -> npt.NDArray[np.bool_]:
    """Which model points project (ideal pinhole `camera_matrix`) into `mask`'s True pixels.

    Args:
        points_model: (N, 3) points in Σ_M [m].
        transform_model_to_camera: (4, 4) ^C T_M [m].
        camera_matrix: (3, 3) the undistorted camera's matrix [px].
        mask: (H, W) pixels of the undistorted image.
    """
    points = transform_points(np.asarray(transform_model_to_camera, dtype=float), np.asarray(points_model))
    K = np.asarray(camera_matrix, dtype=float)
    height, width = mask.shape
    z = points[:, 2]
    ahead = z > 1e-6
    u = np.full(len(points), -1)
    v = np.full(len(points), -1)
    u[ahead] = np.round(K[0, 0] * points[ahead, 0] / z[ahead] + K[0, 2]).astype(int)
    v[ahead] = np.round(K[1, 1] * points[ahead, 1] / z[ahead] + K[1, 2]).astype(int)
    inside = ahead & (u >= 0) & (u < width) & (v >= 0) & (v < height)
    seen = np.zeros(len(points), dtype=bool)
    seen[inside] = mask[v[inside], u[inside]]
    return seen


def choose_pile_grasp(
    model: ClothModel,
    transform_model_to_world: npt.ArrayLike,
    visible: npt.NDArray[np.bool_],
    obstacles_xy: npt.ArrayLike,
    settings: PileGraspSettings | None = None,
    reachable: Callable[[FloatArray], bool] | None = None,
) -> PileGrasp | None:
    """The grasp point on the target away from the obstacles (module docstring).

    Args:
        model: the target's model (S_in and S_out points).
        transform_model_to_world: (4, 4) its surveyed pose in Σ_W [m].
        visible: (N_in,) which S_in points are seen.
        obstacles_xy: (M, 2) points of other cloths in Σ_W (x, y) [m].
        settings: see `PileGraspSettings`.
        reachable: can the hand grasp at this (3,) point of the cloth [m]? When the best
            point is not, `reach_tries` points spread over the candidates are asked, and
            the best candidate in the part found reachable is taken (none: the best one,
            whose grasp then fails with its IK error). Bench episode 30: a cloth by the
            arm's base, every grasp at its middle out of reach, its far side within reach.

    Returns:
        The point, or None when fewer than 10 % of the S_in points are seen (the loop's
        own choice stands).
    """
    s = settings or PileGraspSettings()
    seen = np.asarray(visible, dtype=bool).reshape(-1)
    points_in = np.asarray(model.points_in, dtype=float)
    if seen.shape[0] != points_in.shape[0]:
        raise ValueError(f"visible has {seen.shape[0]} flags for {points_in.shape[0]} S_in points")
    share = float(seen.mean()) if seen.size else 0.0
    if share < 0.1:
        return None
    T = np.asarray(transform_model_to_world, dtype=float)
    candidates = points_in[seen]
    blockers = np.concatenate([np.asarray(model.points_out, dtype=float)[:, :2], points_in[~seen, :2]])
    edge = _nearest(candidates[:, :2], blockers)
    world = transform_points(T, candidates)
    obstacles = np.asarray(obstacles_xy, dtype=float).reshape(-1, 2)
    clear = _nearest(world[:, :2], obstacles)
    reach = _farthest(candidates[:, :2], points_in[:, :2])
    inside = edge >= s.min_edge_gap
    pool = np.flatnonzero(inside) if np.any(inside) else np.arange(len(candidates))
    short = pool[reach[pool] <= s.max_reach]
    pool = short if len(short) else pool
    # farthest from the obstacles (up to `clearance`), then deepest inside its own edge
    score = np.minimum(clear[pool], s.clearance) * 1e3 + np.minimum(edge[pool], 1.0) * 1e-3
    ranked = pool[np.argsort(-score, kind="stable")]
    best = int(ranked[0])
    if reachable is not None and not reachable(world[best]):
        best = _first_reachable(ranked, world, reachable, s.reach_tries, best)
    point_model = np.array([candidates[best, 0], candidates[best, 1], 0.0])
    return PileGrasp(
        point_model,
        transform_points(T, point_model[None])[0],
        float(clear[best]),
        float(edge[best]),
        share,
        best != int(ranked[0]),
    )


def _first_reachable(
    ranked: npt.NDArray[np.intp],
    world: FloatArray,
    reachable: Callable[[FloatArray], bool],
    tries: int,
    best: int,
) -> int:
    """Where the hand reaches, the best of `ranked` (indices into `world`, best first; the
    first, `best`, refused): `tries` points spread over them (each the farthest from those
    asked before) are asked; of the points nearer a reachable one than a refused one the
    best is taken if the hand reaches it too, else the best reachable point asked; `best`
    when none is."""
    xy = world[ranked, :2]
    asked, answers = [0], [False]
    gap = np.hypot(*(xy - xy[0]).T)
    while len(asked) < tries and float(gap.max()) > 0.0:
        k = int(np.argmax(gap))
        asked.append(k)
        answers.append(bool(reachable(world[ranked[k]])))
        gap = np.minimum(gap, np.hypot(*(xy - xy[k]).T))
    ok = np.array(answers)
    if not ok.any():
        return best
    nearest = np.argmin(np.hypot(*(xy[:, None, :] - xy[asked][None, :, :]).transpose(2, 0, 1)), axis=1)
    likely = np.flatnonzero(ok[nearest])  # positions in `ranked`, best first
    k = int(likely[0])
    if k in asked or reachable(world[ranked[k]]):
        return int(ranked[k])
    return int(ranked[min(a for a, yes in zip(asked, answers, strict=True) if yes)])


def _farthest(points: FloatArray, others: FloatArray) -> FloatArray:
    """(N,) distance from each point to the farthest of `others` (on their convex hull)."""
    if len(others) >= 4:
        with contextlib.suppress(QhullError):  # collinear points: all of them
            others = others[ConvexHull(others).vertices]
    return np.asarray(np.sqrt(((points[:, None, :] - others[None, :, :]) ** 2).sum(axis=2)).max(axis=1))


def _nearest(points: FloatArray, others: FloatArray) -> FloatArray:
    """(N,) distance from each point to the nearest of `others` (inf when there are none)."""
    if len(others) == 0:
        return np.full(len(points), np.inf)
    distances, _ = cKDTree(others).query(points)
    return np.asarray(distances, dtype=float)


__all__ = ["PileGrasp", "PileGraspSettings", "choose_pile_grasp", "points_in_mask", "visible_grasp_point"]
