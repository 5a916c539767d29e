"""The clear-table job's checks on one pick: after LIFT (the meant cloth left its place,
the load cell reads its weight, or which other cloth came along), after TRANSFER (still
held) and after RELEASE (the box changed with the cloth's colours).

`AttemptState` is what the job knows during one loop run; the checks fill it in.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from itertools import combinations
from typing import NamedTuple

import numpy as np

from robot_app.arrays import FloatArray
from robot_app.control.box_check import BoxCheck, BoxCheckSettings, BoxView, box_view, check_box
from robot_app.control.cell import StereoCapture
from robot_app.control.clear_table_records import BoxPlace, ClearTableSettings
from robot_app.control.grasp_point import PileGrasp
from robot_app.control.table_survey import to_world
from robot_app.geometry import invert_transform
from robot_app.vision import PinholeCamera, Recognition, Recognizer, StereoRig
from robot_app.vision.identify import Detection

PUT_BACK = "put back"  # in a GRASP_FAILED reason: the job lowered the lift back
DROPPED = "dropped"  # in a LOST reason: the gripper came empty over the box


@dataclass
class AttemptState:
    """What the job knows during one loop run."""

    target: Detection | None  # None: a lost cloth picked blind (`table_lost`)
    box: BoxPlace
    transform_target_to_world: FloatArray
    start_time: float
    others: tuple[Detection, ...] = ()  # the survey's other detections
    grasp: PileGrasp | None = None  # where to grasp, away from the other cloths (Σ_W)
    grasp_used: bool = False
    grasp_point_model: FloatArray | None = None  # the loop's grasp point in Σ_M (last search)
    obstacles_xy: FloatArray | None = None  # (M, 2) the other cloths the survey saw [m]
    came_along: tuple[str, ...] = ()
    remembered: tuple[str, ...] = ()  # of `came_along`, those known from an earlier survey only
    laid_back_too: tuple[str, ...] = ()  # known cloths that came along and were put back with it
    put_back_at: FloatArray | None = None  # (2,) where a put-back let go [m]
    unnamed_along: bool = False  # a double pick whose other cloth no survey identified
    named_by: str = ""  # how a double pick's other cloth was named: "grasp", "gone", "memory"
    companion_search: str = ""  # what the search for that cloth found (picks.csv, diagnosis)
    lift_check: str = ""
    weighed: float | None = None
    put_back: bool = False
    dropped: bool = False
    box_check: BoxCheck | None = None
    check_wall_s: float = 0.0
    notes: list[str] = field(default_factory=list)
    lost_name: str = ""  # the cloth meant, without a detection

    @property
    def name(self) -> str:
        """The cloth meant."""
        return self.target.name if self.target is not None else self.lost_name


def weight_verdict(
    weighed: float, expected: float, name: str, settings: ClearTableSettings
) -> tuple[str, str]:
    """("ok" | "double" | "wrong", what was read) for `weighed` [kg] lifted where the cloth
    `name` weighs `expected` [kg] (`weight_tolerance`, `weight_floor`)."""
    s = settings
    if weighed > expected * (1 + s.weight_tolerance) + s.weight_floor:
        return "double", f"{weighed * 1000:.0f} g lifted, {name} weighs {expected * 1000:.0f} g"
    if weighed < expected * (1 - s.weight_tolerance) - s.weight_floor:
        return "wrong", f"{weighed * 1000:.0f} g lifted, {name} weighs {expected * 1000:.0f} g"
    return "ok", ""


def companion(
    survey: StereoCapture,
    camera: PinholeCamera,
    grasp_world: FloatArray,
    others: tuple[Detection, ...],
    extra: float,
    weights: Mapping[str, float],
    settings: ClearTableSettings,
) -> str | None:
    """The one surveyed cloth under the grasp point (`grasp_world`, on the table [m]) whose
    weight is the `extra` [kg] the load cell read, or None (none, or more than one, fits)."""
    to_camera = invert_transform(survey.transform_right_camera_to_world)
    u, v = camera.project((to_camera[:3, :3] @ grasp_world + to_camera[:3, 3])[None])[0]
    s = settings
    fits = []
    for d in others:
        height, width = d.footprint.shape
        reach = int(s.companion_reach_px)
        u0, u1 = max(0, round(u) - reach), min(width, round(u) + reach + 1)
        v0, v1 = max(0, round(v) - reach), min(height, round(v) + reach + 1)
        if u0 >= u1 or v0 >= v1 or not np.any(d.footprint[v0:v1, u0:u1]):
            continue
        weight = weights.get(d.name)
        if weight is not None and abs(extra - weight) <= weight * s.weight_tolerance + s.weight_floor:
            fits.append(d.name)
    return fits[0] if len(fits) == 1 else None


def remembered_companion(
    grasp_xy: FloatArray,
    extra: float,
    remembered: Mapping[str, FloatArray],
    weights: Mapping[str, float],
    settings: ClearTableSettings,
) -> str | None:
    """The one cloth an earlier survey saw, that the pick's own survey no longer saw (it
    lies hidden, e.g. under the target), whose footprint where it was last seen comes
    within `remembered_reach` [m] of the grasp point and whose weight is the `extra` [kg]
    the load cell read; None if none or more than one fits.

    Args:
        grasp_xy: (2,) where the fingers closed, on the table [m].
        extra: the load cell's reading less the meant cloth's weight [kg].
        remembered: cloth name -> (M, 2) table points [m] of its footprint where it was
            last seen, for the cloths seen before, not seen by the pick's survey and not
            put away.
        weights: cloth name -> its weight [kg].
        settings: `remembered_reach`, `weight_tolerance`, `weight_floor`.
    """
    s = settings
    if s.remembered_reach <= 0:
        return None
    grasp = np.asarray(grasp_xy, dtype=float).reshape(2)
    fits = []
    for name, footprint in remembered.items():
        points = np.asarray(footprint, dtype=float).reshape(-1, 2)
        if not len(points) or float(np.min(np.hypot(*(points - grasp).T))) > s.remembered_reach:
            continue
        weight = weights.get(name)
        if weight is not None and abs(extra - weight) <= weight * s.weight_tolerance + s.weight_floor:
            fits.append(name)
    return fits[0] if len(fits) == 1 else None


class GoneCompanion(NamedTuple):
    """The search for a double pick's other cloth(s) by what left the table.

    Attributes:
        names: the cloths named (those gone whose weight together is the extra), or ().
        candidates: the surveyed cloths within reach light enough to be (part of) the
            extra, in order: each was checked once.
        gone: of `candidates`, those the check after the lift no longer finds in place.
        unseen: of `candidates`, those the check's images do not show enough of to tell
            (then nothing is named: the unseen one may be what came along).
    """

    names: tuple[str, ...]
    candidates: tuple[str, ...]
    gone: tuple[str, ...]
    unseen: tuple[str, ...] = ()


def weighs(extra: float, weight: float, settings: ClearTableSettings) -> bool:
    """Is `extra` [kg] what a load of `weight` [kg] reads (`weight_tolerance`, `weight_floor`)?"""
    return abs(extra - weight) <= weight * settings.weight_tolerance + settings.weight_floor


def gone_companion(
    grasp_xy: FloatArray,
    extra: float,
    footprints: Mapping[str, FloatArray],
    reach: float,
    weights: Mapping[str, float],
    settings: ClearTableSettings,
    stayed: Callable[[str], bool | None],
) -> GoneCompanion:
    """The double pick's other cloth(s) named by what left the table: the cloths the pick's
    survey saw whose footprint comes within `reach` [m] of the grasp point and that weigh
    no more than the `extra` [kg] the load cell read are checked (`stayed`, one check
    each); of those gone from their place, the one set whose weight together is the extra
    is named, only if exactly one set of them is (one cloth gone that weighs it, or two
    dragged along together). Never by weight alone: a named cloth was found gone; and never
    while a candidate's place was out of the check's view (its absence is then unknown).

    Args:
        grasp_xy: (2,) where the fingers closed, on the table [m].
        extra: the load cell's reading less the meant cloth's weight [kg].
        footprints: cloth name -> (M, 2) table points [m] of its footprint where the pick's
            survey saw it (the meant cloth left out).
        reach: how far from the grasp point a cloth that came along can have lain [m]
            (the meant cloth's hanging reach: a dragged cloth touched it or the fingers).
        weights: cloth name -> its weight [kg] (a cloth of unknown weight is never named).
        settings: `weight_tolerance`, `weight_floor`.
        stayed: name -> does the check after the lift still find it where it was seen?
            (None: its place is not enough in that check's view to tell.)

    Raises:
        ValueError: `reach` negative or `grasp_xy` not two numbers.
    """
    if not reach >= 0.0:
        raise ValueError(f"reach must be >= 0 m, got {reach}")
    grasp = np.asarray(grasp_xy, dtype=float)
    if grasp.shape != (2,):
        raise ValueError(f"grasp_xy must be (x, y) [m], got shape {grasp.shape}")
    candidates = []
    for name, footprint in footprints.items():
        points = np.asarray(footprint, dtype=float).reshape(-1, 2)
        if not len(points) or float(np.min(np.hypot(*(points - grasp).T))) > reach:
            continue
        weight = weights.get(name)
        if weight is not None and extra >= weight * (1 - settings.weight_tolerance) - settings.weight_floor:
            candidates.append(name)
    verdicts = {name: stayed(name) for name in candidates}
    gone = tuple(name for name in candidates if verdicts[name] is False)
    unseen = tuple(name for name in candidates if verdicts[name] is None)
    if unseen:
        return GoneCompanion((), tuple(candidates), gone, unseen)
    fits = [
        subset
        for size in range(1, len(gone) + 1)
        for subset in combinations(gone, size)
        if weighs(extra, sum(weights[n] for n in subset), settings)
    ]
    return GoneCompanion(fits[0] if len(fits) == 1 else (), tuple(candidates), gone)


def in_view_share(
    capture: StereoCapture, camera: PinholeCamera, pose_world: FloatArray, points_model: FloatArray
) -> float:
    """Share of a cloth's model points (`points_model`, Σ_M, at `pose_world`) that the right
    camera of `capture` has in its image: how much of its place a check there can see."""
    to_camera = invert_transform(capture.transform_right_camera_to_world) @ pose_world
    points = np.asarray(points_model, dtype=float).reshape(-1, 3)
    inside = to_camera[:3, :3] @ points.T + to_camera[:3, 3:4]
    ahead = inside[2] > 1e-6
    if not np.any(ahead):
        return 0.0
    u, v = camera.project(inside.T[ahead]).T
    width, height = camera.image_size
    seen = (u >= 0) & (u < width) & (v >= 0) & (v < height)
    return float(np.count_nonzero(seen)) / len(points)


def still_there(
    recognizer: Recognizer, capture: StereoCapture, pose_world: FloatArray, same_place: float
) -> bool:
    """Does the cloth's recogniser still find it where the survey saw it (`pose_world`,
    within `same_place` [m], at its decision threshold)?"""
    threshold = recognizer.settings.decide.threshold
    expected = invert_transform(capture.transform_right_camera_to_world) @ pose_world
    checked = recognizer.check(capture.left_bgr, capture.right_bgr, expected, seed=0)
    return agrees(checked, capture, pose_world, threshold, same_place)


def agrees(
    recognition: Recognition,
    capture: StereoCapture,
    pose_world: FloatArray,
    threshold: float,
    same_place: float,
) -> bool:
    """Is `recognition` confident (`threshold`) and within `same_place` [m] of `pose_world`?"""
    if recognition.confidence < threshold:
        return False
    where = to_world(capture, recognition.transform_model_to_camera)
    return bool(np.hypot(*(where[:2, 3] - pose_world[:2, 3])) <= same_place)


def check_release(
    attempt: AttemptState,
    capture: StereoCapture,
    rig: StereoRig,
    recognizer: Recognizer,
    views: dict[str, BoxView | None],
    settings: BoxCheckSettings,
) -> None:
    """After RELEASE: did the box's inside change with the cloth's colours since the last
    look (`views`, updated when the box was in view)? Sets `attempt.box_check`."""
    view = box_view(capture, rig, attempt.box.centre, attempt.box.inner_size, settings)
    model = recognizer.model
    fitness = recognizer.settings.fitness
    attempt.box_check = check_box(views[attempt.box.name], view, model, fitness, settings)
    if attempt.box_check.in_view >= settings.min_in_view:
        views[attempt.box.name] = view
    if not attempt.box_check.confirmed:
        c = attempt.box_check
        attempt.notes.append(
            f"box check: not confirmed (changed {c.changed:.0%}, model colours {c.model_share:.0%}, "
            f"seen {c.in_view:.0%})"
        )


__all__ = [
    "DROPPED",
    "PUT_BACK",
    "AttemptState",
    "GoneCompanion",
    "agrees",
    "check_release",
    "companion",
    "gone_companion",
    "in_view_share",
    "remembered_companion",
    "still_there",
    "weighs",
    "weight_verdict",
]
