"""A cloth the job itself lost sight of, picked again by where it lies and what it weighs.

A cloth dropped during a transfer, or laid back after a double pick, lands crumpled, and
the flat photo model no longer recognises it: the survey sees foreground that no model
explains (an *unknown* region, `vision.identify`) and the job would stop with a known
cloth left. But the job knows which cloths it lost (and did not see again since), so an
unknown region is not a guess about an unknown table when:

1. the region's colours are one lost cloth's: at least `min_share` of its pixels are in
   that cloth's main colours (`vision.regions.main_codes`), at least `margin` more than
   in any other lost cloth's (two lost cloths of one hue family: neither is picked);
2. once lifted (fingers closed at `grasp_height` over the region's innermost pixel), the
   wrist's load cell reads that cloth's weight (`weight_verdict`, as every lift); a
   lighter or heavier lift is laid back, as every rejected lift;
3. after the release, the box check sees the box change with its colours (as every pick);

and the region lies where the cloth can be: within `reach` of the way it was lost (from
where it was lifted to the box for a drop, to where it was let go for a put-back) and not
where an unknown region lay before the loss (`near_the_loss`).

The other cloth of a double pick that no survey identified (hidden under the target) was
laid back with it: the job knows its weight (the load cell's excess) and where it went,
not its name. Its candidates are the known cloths no survey has seen, each held to the
same three tests against all the others (`margin` over every one of them). A cloth the
job never lifted, such as an unknown cloth lying apart, is never picked this way; an
unknown cloth that came up with a double pick could be taken for a known one if its
colours and weight were one known cloth's alone (not measured: the bench's cloths are
all known). `pick_lost` does the moves (the job's own, `JobMotion`), with the
loop's phase names ("grasp", "lift", "transfer", "release") reported to the job's
callbacks, so that a witness of the lifts (simulation) sees them as every other lift.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from typing import TYPE_CHECKING

import cv2
import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray
from robot_app.control.cell import StereoCapture
from robot_app.control.clear_table_records import LostPlace, LostSettings
from robot_app.control.episode import EpisodeResult, Outcome, PhaseRecord
from robot_app.control.intercept import hanging_reach
from robot_app.control.pick_checks import DROPPED, PUT_BACK, AttemptState, weight_verdict
from robot_app.control.pick_place import LIFTED, carry_over_box, release_into_box
from robot_app.errors import IKError
from robot_app.vision import Recognizer
from robot_app.vision.exposure import sheet_gains
from robot_app.vision.hue import DARK, LIGHT, colours_match
from robot_app.vision.identify import UnknownRegion
from robot_app.vision.regions import image_codes, main_codes, undistorted

if TYPE_CHECKING:
    from robot_app.control.table_clearer import TableClearer


def colour_shares(
    capture: StereoCapture, region: UnknownRegion, recognizers: Mapping[str, Recognizer]
) -> dict[str, float]:
    """Name -> share of `region`'s pixels (in the undistorted right image) in that
    model's main colours (`palette_share`)."""
    first = next(iter(recognizers.values()))
    image = undistorted(capture.right_bgr, first.rig.right)
    fitness = first.settings.fitness
    codes = image_codes(image, sheet_gains(image, first.model, first.settings.exposure), fitness)
    seen = codes[region.mask]
    return {
        name: palette_share(seen, main_codes(recognizer.model), fitness.hue_threshold_in)
        for name, recognizer in recognizers.items()
    }


def palette_share(seen: npt.ArrayLike, palette: npt.ArrayLike, hue_threshold: int) -> float:
    """Share of the colour codes `seen` that are in `palette` (a model's main codes): a hue
    within `hue_threshold` of one of its hues, or one of its tones; a LIGHT tone (a white
    or light grey cloth, which has no hue) also takes DARK pixels, since a crumpled white
    cloth's folds lie in its own shade, darker but still without hue (a dark cloth's
    folds do not get lighter)."""
    codes = np.asarray(seen).reshape(-1)
    if not codes.size:
        return 0.0
    colours = np.asarray(palette)
    if np.any(colours == LIGHT) and not np.any(colours == DARK):
        colours = np.append(colours, DARK)
    matching = colours_match(codes[:, None], colours[None, :], hue_threshold)
    return float(np.mean(np.any(matching, axis=1)))


def near_the_loss(centre_xy: FloatArray, place: LostPlace, settings: LostSettings) -> bool:
    """Could a region centred at `centre_xy` [m] be the cloth lost at `place`: within
    `reach` of the way it was lost, and not where an unknown region lay before the loss
    (`apart`)?"""
    centre = np.asarray(centre_xy, dtype=float).reshape(2)
    a, b = np.asarray(place.start, dtype=float), np.asarray(place.end, dtype=float)
    span = b - a
    t = float(np.clip((centre - a) @ span / max(float(span @ span), 1e-12), 0.0, 1.0))
    if float(np.hypot(*(centre - (a + t * span)))) > settings.reach:
        return False
    return all(float(np.hypot(*(centre - np.asarray(xy)))) > settings.apart for xy in place.before)


def match_lost(
    capture: StereoCapture,
    regions: tuple[UnknownRegion, ...],
    centres: list[FloatArray],
    lost: Mapping[str, Recognizer],
    places: Mapping[str, LostPlace],
    settings: LostSettings,
) -> tuple[str, UnknownRegion, float] | None:
    """The first region (largest first) whose colours are one lost cloth's (`min_share`,
    ahead of every other lost cloth by `margin`) and which lies where that cloth may be
    (`near_the_loss`; `centres`: each region's centre on the table [m], `places`: where
    each cloth was lost, none: anywhere): (name, region, share), or None."""
    if not lost:
        return None
    for region, centre in zip(regions, centres, strict=True):
        shares = colour_shares(capture, region, lost)
        ranked = sorted(shares.items(), key=lambda item: -item[1])
        name, best = ranked[0]
        runner_up = ranked[1][1] if len(ranked) > 1 else 0.0
        if best < settings.min_share or best - runner_up < settings.margin:
            continue
        if name not in places or near_the_loss(centre, places[name], settings):
            return name, region, best
    return None


def inner_pixel(mask: np.ndarray) -> tuple[float, float]:
    """(u, v) of the mask's pixel farthest from its border (a crumpled heap's middle, also
    for a region that is not convex) [px]."""
    inside = np.pad(np.asarray(mask, dtype=np.uint8), 1)
    distance = cv2.distanceTransform(inside, cv2.DIST_L2, 5)[1:-1, 1:-1]
    v, u = np.unravel_index(int(np.argmax(distance)), distance.shape)
    return float(u), float(v)


def pick_lost(job: TableClearer, name: str, region: UnknownRegion, share: float) -> None:
    """Picks the lost cloth `name` at `region` of the job's last survey and places it into
    its box if the load cell reads its weight; books the attempt. Never raises for a
    failed pick (an `InterruptError` from the job's step callback passes)."""
    s, loop, table_z = job.settings.lost, job.loop_settings, job.table_z
    capture = job.survey_capture
    box = job.boxes[job.sort.box_for(name)]
    x, y = job.table.point(capture, inner_pixel(region.mask))
    unnamed = name not in job.ledger.lost  # the other cloth of a double pick, never identified
    place = job.ledger.unnamed[-1] if unnamed else job.ledger.lost[name]
    how = f"{place.how}; identity from its colours and weight" if unnamed else place.how
    where = np.eye(4)
    where[:3, 3] = (x, y, table_z)
    attempt = AttemptState(None, box, where, job.cell.time, lost_name=name)
    attempt.notes.append(
        f"lost ({how}), not recognised since: picked blind at ({x:.2f}, {y:.2f}), "
        f"an unknown region {share:.0%} in its colours"
    )
    wall = time.perf_counter()
    samples, collisions = job.cell.limit_report(job.limits).samples, job.motion.collisions
    outcome, reason, grasps = Outcome.PLACED, "", 0
    try:
        job.set_phase("approach", name)
        start = job.cell.time
        job.motion.move_tcp([x, y, table_z + loop.pregrasp_height])
        job.motion.move_tcp([x, y, table_z + s.grasp_height], speed=job.settings.put_down_speed)
        job.cell.set_gripper(0.0)
        job.motion.hold(loop.close_time)
        held = job.cell.grasp()
        grasps = 1
        _phase(job, name, "grasp", start, f"blind: {held} hold points")
        start = job.cell.time
        job.set_phase("lift", name)
        job.motion.move_tcp([x, y, table_z + loop.lift_height])
        lifted = job.cell.holding()
        _phase(job, name, "lift", start, LIFTED if lifted else "grasp missed: cloth not lifted")
        if not lifted:
            job.cell.release()
            job.cell.set_gripper(loop.gripper_open)
            outcome, reason = Outcome.GRASP_FAILED, "grasp missed: cloth not lifted"
        else:
            outcome, reason = _carry(job, attempt, name)
    except IKError as err:
        job.cell.release()
        job.cell.set_gripper(loop.gripper_open)
        outcome, reason = Outcome.GRASP_FAILED, f"out of reach: {err}"
    report = job.cell.limit_report(job.limits)
    counts = (report.samples - samples, job.motion.collisions - collisions)
    result = _result(job, outcome, reason, attempt.start_time, wall, grasps, counts)
    job.ledger.record_attempt(attempt, result, job.cell.time, job.weights.get(name))
    if outcome is Outcome.PLACED and unnamed:
        job.ledger.unnamed.pop()  # that double pick's other cloth is placed


def _carry(job: TableClearer, attempt: AttemptState, name: str) -> tuple[Outcome, str]:
    """After a lift that holds something: weigh, then into the box and look (or lay back),
    with the job's own hand-over (`TableClearer.put_back`, `TableClearer.check_box`) and
    the loop's transfer and release (`pick_place.carry_over_box`, `release_into_box`),
    made with the job's motions."""
    loop, table_z = job.loop_settings, job.table_z
    expected = job.weights.get(name)
    if job.weigh is None or expected is None:
        verdict, what = "wrong", f"{name}'s weight unknown: its identity cannot be confirmed"
    else:
        attempt.weighed = float(job.weigh())
        verdict, what = weight_verdict(attempt.weighed, expected, name, job.settings)
    attempt.lift_check = verdict
    if verdict != "ok":
        attempt.notes.append(f"{'double pick' if verdict == 'double' else 'wrong lift'} ({what}): put back")
        job.put_back(attempt, None)
        return Outcome.GRASP_FAILED, f"{PUT_BACK}: {what}"
    start = job.cell.time
    job.set_phase("transfer", name)
    carry_over_box(job.motion, attempt.box.centre, table_z, loop)
    _phase(job, name, "transfer", start, "")
    if not job.cell.holding():
        attempt.dropped = True
        attempt.notes.append("dropped during the transfer (gripper empty over the box)")
        job.cell.release()
        job.cell.set_gripper(loop.gripper_open)
        return Outcome.LOST, f"{DROPPED} during the transfer: the gripper came empty over the box"
    start = job.cell.time
    job.set_phase("release", name)
    model = job.recognizers[name].model
    reach = hanging_reach(model.points_in, model.grasp_point)
    release_into_box(job.motion, job.cell, attempt.box.centre, table_z, loop, reach)
    _phase(job, name, "release", start, "")
    job.check_box(attempt)
    return Outcome.PLACED, f"{name} placed (picked blind, its weight read)"


def _phase(job: TableClearer, name: str, phase: str, start: float, note: str) -> None:
    if job.on_phase is not None:
        job.on_phase(PhaseRecord(phase, start, job.cell.time, 0.0, note), name)


def _result(
    job: TableClearer,
    outcome: Outcome,
    reason: str,
    start: float,
    wall_start: float,
    grasps: int,
    counts: tuple[int, int],
) -> EpisodeResult:
    """The blind pick as a loop run's result (`counts`: its commanded samples and collisions)."""
    return EpisodeResult(
        outcome=outcome,
        success=outcome is Outcome.PLACED,
        reason=reason,
        placed_fraction=None,
        sim_time=job.cell.time - start,
        wall_s=time.perf_counter() - wall_start,
        phases=(),
        recognitions=(),
        limit_report=job.cell.limit_report(job.limits),
        commanded_samples=counts[0],
        collisions=counts[1],
        grasp_attempts=grasps,
        observe_returns=0,
        filter_accepted=0,
        filter_rejected=0,
        strategy="blind",
    )


__all__ = ["colour_shares", "inner_pixel", "match_lost", "near_the_loss", "palette_share", "pick_lost"]
