"""A cloth the job itself lost sight of, picked again by where it lies and what it weighs.

A cloth dropped during a transfer, or laid back after a double pick, lands crumpled, and
the flat photo model no longer recognises it: the survey sees foreground that no model
explains (an *unknown* region, `vision.identify`) and the job would stop with a known
cloth left. But the job knows which cloths it lost (and did not see again since), so an
unknown region is not a guess about an unknown table when:

1. the region's colours are one lost cloth's: at least `min_share` of its pixels are in
   that cloth's main colours (`vision.regions.main_codes`; a cloth of tones only counted at
   its `ColourFit.lightness`: no lighter than its photo, a white one with some white
   showing), at least `margin` more than
   in any other lost cloth's that could lie there. Two lost cloths of one hue family
   (within `margin` of each other): neither is picked if they belong in different boxes;
   if they belong in the same box, which one it is does not change where it goes, so the
   best is picked and the others are its *alike* (`LostMatch.alike`);
2. once lifted (fingers closed over the heap's top, the highest surface the survey's pair
   measures at the deep points of the region's part a hand can close on, `_heap_top`, or
   at `grasp_height` over its innermost pixel; that part lies on the table top, clear of
   the boxes' walls, `table_furniture.graspable`; a region with no such part is not
   grasped, its attempt booked `unreachable` with the cause), the
   wrist's load cell reads that cloth's weight (`weight_verdict`, as every lift), or
   that of the cloth and some of its alike together, or of one of its alike
   (`weighed_as`: a heap of two lost cloths of one box comes up as one, and goes into
   that box as one); any other lift is laid back, as every rejected lift;
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
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, replace
from itertools import combinations
from typing import TYPE_CHECKING

import cv2
import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray
from robot_app.control.cell import StereoCapture
from robot_app.control.clear_table_records import ClearTableSettings, LostPlace, LostSettings
from robot_app.control.colour_fit import colour_shares, palette_share, survey_colours
from robot_app.control.episode import EpisodeResult, Outcome, PhaseRecord
from robot_app.control.held_look import HeldColours, held_verdict, look_at_held
from robot_app.control.pick_checks import (
    DROPPED,
    FELL_INTO_BOX,
    PUT_BACK,
    AttemptState,
    comes_within,
    could_be_in,
    weighs_extra,
    weight_verdict,
)
from robot_app.control.pick_place import EMPTY_GRASP, LIFTED, carry_over_box, release_into_box
from robot_app.control.table_furniture import OPENING, clear_of_walls, graspable
from robot_app.control.table_surface import SurfaceHeight, surface_heights
from robot_app.errors import IKError
from robot_app.geometry import transform_points
from robot_app.vision import Recognizer
from robot_app.vision.identify import UnknownRegion
from robot_app.vision.regions import in_palette, main_codes

if TYPE_CHECKING:
    from robot_app.control.table_clearer import TableClearer
    from robot_app.control.table_survey import TablePlane

WALL_MARGIN = 0.05  # [m] a blind grasp's approach stays this far over the boxes' walls until over its point
REACH_TRIES = 24  # deepest pixels of a lost cloth's region tried for a reachable blind grasp
TOP_APART = 8.0  # [px] between the points of a lost cloth's region measured for the heap's top
# lost cloths one blind lift may be named after together (a put-back heap of a double pick).
# Not three: at three cloths' weight (some 75 g) the load cell's tolerance (30 % + 3 g) is a
# whole cloth's, so three cannot be told from four. Held-out episode 593 (session 30): 95 g
# named "No.16 and No.8 and No.20" (77 g, colours) held No.18 of whites too, never
# identified, and it went into colours; the two other triples named in 190 held-out
# episodes (449, 454, session 28) held other cloths than named, of the same box by chance.
MAX_HEAP = 2
WHOLE = 0.9  # a colour patch this much of its region is the region (tested whole)
UNGRASPABLE = "no blind grasp"  # a lost cloth's region no hand can close on (`table_furniture.graspable`)


def colour_patches(
    capture: StereoCapture,
    regions: Sequence[UnknownRegion],
    lost: Mapping[str, Recognizer],
    smallest: float,
) -> tuple[UnknownRegion, ...]:
    """The pieces of the unknown `regions` in one lost cloth's main colours: where a heap
    of several cloths (a put-back of a lift that took three or four) shows one of them on
    top. Each region's pixels in a cloth's palette (`in_palette`), opened by `OPENING` px
    square as `identify` opens its foreground, each connected piece of at least `smallest`
    pixels and less than `WHOLE` of its region (the whole region is tested as it is),
    largest first, none twice (cloths of one palette give the same piece)."""
    if not lost or not regions:
        return ()
    fitness = next(iter(lost.values())).settings.fitness
    codes = survey_colours(capture, lost)[2]
    square = np.ones((OPENING, OPENING), np.uint8)
    pieces: dict[bytes, UnknownRegion] = {}
    for recognizer in lost.values():
        ours = in_palette(codes, main_codes(recognizer.model), fitness.hue_threshold_in)
        for region in regions:
            ours_there = (np.asarray(region.mask, dtype=bool) & ours).astype(np.uint8)
            mask = cv2.morphologyEx(ours_there, cv2.MORPH_OPEN, square)
            count, labels, stats, centroids = cv2.connectedComponentsWithStats(mask, connectivity=8)
            for k in range(1, count):
                area = int(stats[k, cv2.CC_STAT_AREA])
                if area >= smallest and area < WHOLE * region.area:
                    piece = labels == k
                    key = np.packbits(piece).tobytes()
                    pieces.setdefault(
                        key, UnknownRegion((float(centroids[k][0]), float(centroids[k][1])), area, piece)
                    )
    return tuple(sorted(pieces.values(), key=lambda region: -region.area))


def near_the_loss(centre_xy: FloatArray, place: LostPlace, settings: LostSettings) -> bool:
    """Could a region centred at `centre_xy` [m] be the cloth lost at `place`: within
    `reach` of the way it was lost, and not where an unknown region lay before the loss
    (`apart`), unless the job laid the cloth there itself (`LostPlace.laid`: a region seen
    before within `apart` of the laid strip had the cloth laid over it; bench episode 62,
    session 20: No.11, laid back twice along the heap it was lifted from, was never looked
    for there again)."""
    centre = np.asarray(centre_xy, dtype=float).reshape(2)
    if _off_segment(centre, place) > settings.reach:
        return False
    before = [np.asarray(xy, dtype=float) for xy in place.before]
    if place.laid:
        before = [xy for xy in before if _off_segment(xy, place) > settings.apart]
    return all(float(np.hypot(*(centre - xy))) > settings.apart for xy in before)


def _off_segment(point: FloatArray, place: LostPlace) -> float:
    """Distance [m] of `point` ((2,) [m]) from the way `place`'s cloth went (start to end)."""
    return off_way(point, place.start, place.end)


def off_way(point: npt.ArrayLike, start: npt.ArrayLike, end: npt.ArrayLike) -> float:
    """Distance [m] of `point` from the segment `start`-`end` (each (2,) [m])."""
    p, a, b = (np.asarray(v, dtype=float).reshape(2) for v in (point, start, end))
    span = b - a
    t = float(np.clip((p - a) @ span / max(float(span @ span), 1e-12), 0.0, 1.0))
    return float(np.hypot(*(p - (a + t * span))))


@dataclass(frozen=True)
class LostMatch:
    """An unknown region taken for a lost cloth (`match_lost`).

    Attributes:
        name: the lost cloth whose colours the region shows most.
        region: the region of the survey's identification.
        share: share of its pixels in that cloth's main colours [-].
        alike: the other lost cloths that could lie there whose colours fit nearly as well
            (within `margin`); all belong in `name`'s box.
        piece: the region is a piece of a larger one in `name`'s colours (`colour_patches`):
            a heap whose other cloths' colours the piece does not show, so a lift is
            taken for one cloth alone (`weighed_as` with `most=1`), never for a sum of
            cloths that might be any of those below (bench episode 29: a four-cloth heap
            of No.16 and three whites weighed as No.16, No.1 and No.8, all of the colours
            box, and the three whites went into it).
        guessed: of `name` and `alike`, the guessed companions of a double pick (any known
            cloth not placed or seen): a lift is taken for one of them alone, never for a sum
            with one (bench episodes 40 and 48, session 19: a heap's blind lift read as a
            named lost cloth plus a guessed one, 74 g and 46 g within the tolerance, held two
            other cloths; in 48 one of them belonged in the other box).
        doubted: cloths of another box that weigh as much and may lie hidden under the
            region (`TableClearer._suspects_under`): the lift goes on only if the lifted
            cloth, looked at against free table, shows `name`'s colours and hardly any of
            theirs (`held_look`).
        rivals: lost cloths of another box whose colours fit the region as well as
            `name`'s (`match_lost(ties=True)`): the lift is the one whose weight the load
            cell reads and whose colours a look at it shows alone (`_carry`).
    """

    name: str
    region: UnknownRegion
    share: float
    alike: tuple[str, ...] = ()
    piece: bool = False
    guessed: frozenset[str] = frozenset()
    doubted: tuple[str, ...] = ()
    rivals: tuple[str, ...] = ()


def match_lost(
    capture: StereoCapture,
    regions: tuple[UnknownRegion, ...],
    centres: list[FloatArray],
    lost: Mapping[str, Recognizer],
    places: Mapping[str, LostPlace],
    settings: LostSettings,
    box_for: Callable[[str], str] | None = None,
    guessed: frozenset[str] = frozenset(),
    spent: frozenset[str] = frozenset(),
    ties: bool = False,
) -> LostMatch | None:
    """The first region (largest first) whose colours are a lost cloth's (`min_share`)
    that lies where that cloth may be (`near_the_loss`; `centres`: each region's centre on
    the table [m], `places`: where each cloth was lost, none: anywhere), ahead by `margin`
    of every other lost cloth that may lie there, or only of those of another box
    (`box_for`: cloth -> its box; None: of every one); None if no region is.

    `guessed`: the candidates for a cloth that came along unnamed (any known cloth not
    placed). One of them is not taken where a lost cloth the job named (not guessed) may lie
    too, with `min_share` of the region in its colours: the region is then likely the two
    laid back together, which a blind lift weighs as both (bench episode 19 on 0bb8019: the
    heap of No.8 and its unnamed companion, taken for No.16, lifted four cloths, and the heap
    they were put back as slid off the table). Where that named cloth fits within `margin`
    of the guess, the region is taken for it, the guesses its `alike` (each taken only
    alone): held-out 807 (session 34), No.1 (red) came up with an unnamed No.15, both went
    back, No.15 was identified and placed, and No.1's region (0.98) went unpicked behind the
    guessed No.8 (orange, 0.99) until the job stopped.

    `spent`: those of `lost` with no attempts left. They are ranked and rival as the others
    (their colours still explain their region), but a region one of them fits best is not
    taken: held-out bench episode 227 (session 24): No.6, put back four times, had no
    attempts left and left the candidates, and its region (white with purple and red) went
    to the guessed No.7, of the other box: No.6 into the colours box.

    `ties`: only a region whose best cloths tie across boxes (none guessed) is taken, the
    other box's cloths its `rivals`: held-out 1771 (session 49), No.19 (colours) and No.6
    (whites), put back together, fit their heap at 0.50 and 0.42, and neither was picked."""
    if not lost:
        return None
    for region, centre in zip(regions, centres, strict=True):
        fits = colour_shares(capture, region.mask, lost)
        ranked = [
            (name, fit)
            for name, fit in sorted(fits.items(), key=lambda item: -item[1].score)
            if name not in places or near_the_loss(centre, places[name], settings)
        ]
        if not ranked or ranked[0][1].share * ranked[0][1].lightness < settings.min_share:
            continue  # not its colours, or a white cloth's palette on a dark or grey region
        name, best = ranked[0]
        if name in spent:
            continue  # its colours are a lost cloth's with no attempts left: nobody else's
        named = [(o, fit) for o, fit in ranked[1:] if o not in guessed and fit.share >= settings.min_share]
        if name in guessed and named:
            if best.score - named[0][1].score >= settings.margin:
                continue
            name, best = named[0]
            if name in spent:
                continue
        alike = tuple(o for o, fit in ranked if o != name and best.score - fit.score < settings.margin)
        if alike and box_for is None:
            continue  # which cloth it is might change where it goes
        rivals = tuple(o for o in alike if box_for is not None and box_for(o) != box_for(name))
        if rivals and (not ties or guessed & {name, *alike}):
            continue  # which cloth it is would change where it goes
        if ties and not rivals:
            continue  # the other rounds' to take
        alike = tuple(o for o in alike if o not in rivals)
        return LostMatch(name, region, best.share, alike, guessed=guessed & {name, *alike}, rivals=rivals)
    return None


def match_heap(
    capture: StereoCapture,
    regions: tuple[UnknownRegion, ...],
    centres: list[FloatArray],
    named: Mapping[str, Recognizer],
    suspects: Mapping[str, Recognizer],
    places: Mapping[str, LostPlace],
    settings: LostSettings,
    box_for: Callable[[str], str],
) -> LostMatch | None:
    """A region that is a heap of several lost cloths, none of which it shows enough of
    alone (`match_lost` found none): the first region (largest first) where at least two
    of the cloths that may lie there (`near_the_loss`: the lost ones the job `named`, and the
    `suspects`, seen by a survey and gone since a double pick laid its unnamed companion
    back) with at least one named among them, all belong in one box, and together explain
    `min_share` of its pixels (their main colours joined, `palette_share`). The match is the
    named one whose colours it shows most, the others its `alike`, none guessed: a blind lift
    that weighs as some of them together (`weighed_as`) goes into that box as one. A cloth of
    the other box that may lie there rules the region out; one never seen at all could be
    in the heap too, and then the weight is more than the candidates' (laid back). Bench
    episode 89 (session 22): a first lift took all three cloths of the pile (65 g), the
    put-back heap showed the colours of three, no one of them filled 60 % of it, and none was
    picked again."""
    candidates = {**named, **suspects}
    if len(candidates) < 2 or not named:
        return None
    fitness = next(iter(candidates.values())).settings.fitness
    _, _, codes = survey_colours(capture, candidates)
    for region, centre in zip(regions, centres, strict=True):
        here = [n for n in candidates if n not in places or near_the_loss(centre, places[n], settings)]
        if len(here) < 2 or not any(n in named for n in here) or len({box_for(n) for n in here}) > 1:
            continue
        palette = np.unique(np.concatenate([main_codes(candidates[n].model) for n in here]))
        share = palette_share(codes[region.mask], palette, fitness.hue_threshold_in)
        if share < settings.min_share:
            continue
        fits = colour_shares(capture, region.mask, {n: candidates[n] for n in here})
        name = max((n for n in here if n in named), key=lambda n: fits[n].score)
        return LostMatch(name, region, share, tuple(n for n in here if n != name))
    return None


def weighed_as(
    weighed: float,
    name: str,
    alike: tuple[str, ...],
    weights: Mapping[str, float],
    settings: ClearTableSettings,
    most: int = MAX_HEAP,
    alone_only: frozenset[str] = frozenset(),
) -> tuple[str, ...]:
    """Which lost cloths a blind lift of `weighed` [kg] holds: `name` alone if it weighs
    that (`weight_verdict`), else the fewest of `name` and its `alike` (at most `most`
    together, `name` first where it fits, those in `alone_only` only alone) whose weights
    sum to it; () if none. All of them belong in one box, so the lift goes there whichever
    they are."""
    candidates = [n for n in (name, *alike) if n in weights]
    together = [n for n in candidates if n not in alone_only]
    for size in range(1, min(most, len(candidates)) + 1):
        for group in combinations(candidates if size == 1 else together, size):
            verdict, _ = weight_verdict(weighed, sum(weights[n] for n in group), name, settings, lift=True)
            if verdict == "ok":
                return group
    return ()


def away_from(
    aims: npt.NDArray[np.bool_],
    capture: StereoCapture,
    table: TablePlane,
    empty: Sequence[FloatArray],
    reach: float,
) -> npt.NDArray[np.bool_]:
    """`aims` without the pixels whose table point lies within `reach` [m] of a blind
    grasp that closed on nothing (`empty`, (2,) each [m]): the next one aims elsewhere in
    the region. Held-out episode 409 (session 28): ten blind grasps under three names at
    one spot of one region, (0.66, 0.46), each lifting nothing; the region's centre lay
    8 cm from it, beyond `empty_reach` of the rule that gives a region up."""
    if not len(empty) or not np.any(aims):
        return aims
    v, u = np.nonzero(aims)
    xy = table.pixels(capture, u, v)
    spots = np.asarray(empty, dtype=float).reshape(-1, 2)
    near = np.min(np.linalg.norm(xy[:, None, :] - spots[None, :, :], axis=2), axis=1) <= reach
    kept = aims.copy()
    kept[v[near], u[near]] = False
    return kept


def inner_pixel(mask: np.ndarray) -> tuple[float, float]:
    """(u, v) of the mask's pixel farthest from its border (a crumpled heap's middle, also
    for a region that is not convex) [px]."""
    return inner_pixels(mask, 1)[0]


def inner_pixels(
    mask: np.ndarray, count: int, apart: float = 4.0, depth_share: float = 0.0
) -> list[tuple[float, float]]:
    """Up to `count` (u, v) of the mask's pixels, deepest inside first (distance from the
    border), each at least `apart` [px] from those before it and at least `depth_share` of
    the deepest one's distance from the border [px]."""
    inside = np.pad(np.asarray(mask, dtype=np.uint8), 1)
    distance = cv2.distanceTransform(inside, cv2.DIST_L2, 5)[1:-1, 1:-1]
    deep = distance > 0
    if np.any(deep):
        deep &= distance >= depth_share * float(distance.max())
    vs, us = np.nonzero(deep)
    order = np.argsort(-distance[vs, us], kind="stable")
    chosen: list[tuple[float, float]] = []
    for i in order:
        u, v = float(us[i]), float(vs[i])
        if all((u - a) ** 2 + (v - b) ** 2 >= apart**2 for a, b in chosen):
            chosen.append((u, v))
            if len(chosen) == count:
                break
    return chosen


def reachable_point(
    mask: np.ndarray,
    table_point: Callable[[tuple[float, float]], tuple[float, float]],
    reachable: Callable[[float, float], bool],
    tries: int = REACH_TRIES,
) -> tuple[float, float]:
    """(x, y) [m] on the table of the region's innermost pixel the hand can grasp at
    (`reachable`), trying the `tries` deepest pixels spread over the region; the innermost
    one if none is (the grasp then fails with its IK error, as before). Bench episode 12: a
    lost cloth laid back near the arm's base, its innermost pixel at (0.27, 0.19) had no IK
    solution with the cameras looking down (15 mm short), the rest of the heap farther out."""
    pixels = inner_pixels(mask, tries)
    points = [table_point(px) for px in pixels]
    return next((xy for xy in points if reachable(*xy)), points[0])


def pick_lost(job: TableClearer, match: LostMatch) -> None:
    """Picks the lost cloth `match.name` at `match.region` of the job's last survey and
    places it into its box if the load cell reads its weight (or its and some of its
    alike's: `weighed_as`); books the attempt. Never raises for a failed pick (an
    `InterruptError` from the job's step callback passes)."""
    name, region, share = match.name, match.region, match.share
    s, loop, table_z = job.settings.lost, job.loop_settings, job.table_z
    capture = job.survey_capture
    box = job.boxes[job.sort.box_for(name)]
    heights = (loop.pregrasp_height, s.grasp_height, loop.lift_height)
    aims = graspable(
        region.mask, capture, job.table, job.table_top, job.boxes.values(), s.edge_inset, s.wall_clearance
    )
    tried = np.any(aims)
    aims = away_from(aims, capture, job.table, job.ledger.empty_grasps, s.empty_reach)
    x, y = job.table.point(capture, region.centroid)
    top: tuple[float, float, float, str] | None = None
    if np.any(aims):

        def reaches(x: float, y: float) -> bool:
            return all(job.motion.reaches([x, y, table_z + h]) for h in heights)

        x, y = reachable_point(aims, lambda px: job.table.point(capture, px), reaches)
        top = _heap_top(job, match, aims, reaches)
        if top is not None:
            x, y = top[0], top[1]
    known_lost = set(job.ledger.lost)
    unnamed = name not in known_lost  # the other cloth of a double pick, not named
    place = job.ledger.unnamed[-1] if unnamed else job.ledger.lost[name]
    how = f"{place.how}; identity from its colours and weight" if unnamed else place.how
    where = np.eye(4)
    where[:3, 3] = (x, y, table_z)
    if np.any(aims):
        # before the attempt's clock starts, as for a surveyed pick; a tie's rivals' boxes too
        for into in dict.fromkeys(job.sort.box_for(n) for n in (name, *match.rivals)):
            job.look_into_box(into)
    attempt = AttemptState(
        None,
        box,
        where,
        job.cell.time,
        lost_name=name,
        doubted=match.doubted,
        guessed=unnamed,
        taken_for=(name, *match.alike),
    )
    attempt.from_region = np.array(job.table.point(capture, region.centroid))
    seen = f"an unknown region {share:.0%} in its colours" + (
        f" (as much in {', '.join(match.alike)}'s, same box)" if match.alike else ""
    )
    if not np.any(aims):
        # no hand closes on it there: not tried, the attempt booked with the cause
        reason = (
            f"{UNGRASPABLE}: its region around ({x:.2f}, {y:.2f}) lies past the table's edge "
            f"or within {s.wall_clearance * 100:.0f} cm of a box's walls"
            if not tried
            else f"{UNGRASPABLE}: blind grasps closed on nothing all over its region by ({x:.2f}, {y:.2f})"
        )
        attempt.notes.append(f"lost ({how}), not recognised since: {seen}; {reason}")
        result = EpisodeResult.not_started(Outcome.UNREACHABLE, reason, "blind")
        job.ledger.record_attempt(attempt, result, job.cell.time, job.weights.get(attempt.name))
        return
    attempt.notes.append(f"lost ({how}), not recognised since: picked blind at ({x:.2f}, {y:.2f}), {seen}")
    if top is not None:
        grasp_z = top[2]
        attempt.notes.append(top[3])
    else:
        grasp_z = _blind_grasp_height(job, match, (x, y), attempt.notes)
    wall = time.perf_counter()
    samples, collisions = job.cell.limit_report(job.limits).samples, job.motion.collisions
    outcome, reason, grasps = Outcome.PLACED, "", 0
    try:
        job.set_phase("approach", name)
        start = job.cell.time
        for point in _approach(
            job.motion.tcp_position(), (x, y), grasp_z, loop.pregrasp_height - s.grasp_height, job
        ):
            job.motion.move_tcp(point)
        job.motion.move_tcp([x, y, grasp_z], speed=job.settings.put_down_speed)
        held, grasps = close_lowering(job, (x, y), grasp_z, attempt.notes)
        _phase(job, name, "grasp", start, f"blind: {held} hold points")
        start = job.cell.time
        job.set_phase("lift", name)
        job.motion.move_tcp([x, y, table_z + loop.lift_height])
        attempt.lifted_at = job.motion.tcp_position()
        lifted = job.cell.holding()
        _phase(job, name, "lift", start, LIFTED if lifted else EMPTY_GRASP)
        if not lifted:
            job.cell.release()
            job.cell.set_gripper(loop.gripper_open)
            outcome, reason = Outcome.GRASP_FAILED, EMPTY_GRASP
        else:
            outcome, reason = _carry(job, attempt, match)
    except IKError as err:
        job.cell.release()
        job.cell.set_gripper(loop.gripper_open)
        outcome, reason = Outcome.GRASP_FAILED, f"out of reach: {err}"
    report = job.cell.limit_report(job.limits)
    counts = (report.samples - samples, job.motion.collisions - collisions)
    result = _result(job, outcome, reason, attempt.start_time, wall, grasps, counts)
    job.ledger.record_attempt(attempt, result, job.cell.time, job.weights.get(attempt.name))
    if outcome is Outcome.PLACED:
        # a double pick's other cloth, not named, placed (named by colours and weight)
        placed_unnamed = sum(1 for n in (attempt.name, *attempt.came_along) if n not in known_lost)
        del job.ledger.unnamed[len(job.ledger.unnamed) - min(placed_unnamed, len(job.ledger.unnamed)) :]


def _approach(
    here: FloatArray, xy: tuple[float, float], grasp_z: float, above: float, job: TableClearer
) -> list[list[float]]:
    """The blind grasp's way to `above` [m] over `grasp_z` at `xy`, `WALL_MARGIN` over the
    boxes' walls until over the point: straight up from `here` first if it is lower, across
    at that height, then down to the pregrasp point. A straight line from a low pose (a
    put-back's end, a box check) to the pregrasp point passed the colours box's wall:
    held-out bench episode 107 (session 22), the left finger on it at TCP (0.305, -0.410,
    0.090). Where the hand does not reach that height over the point (by the arm's base: the
    replay's blind grasp at (0.20, -0.25)), the last leg goes straight from `here` raised."""
    walls = max((box.wall_height for box in job.boxes.values()), default=0.0)
    safe = job.table_z + walls + WALL_MARGIN
    x, y = xy
    points = [[float(here[0]), float(here[1]), safe]] if here[2] < safe else []
    pregrasp = grasp_z + above
    if pregrasp < safe and job.motion.reaches([x, y, safe]):
        points.append([x, y, safe])
    return [*points, [x, y, pregrasp]]


def close_lowering(
    job: TableClearer, xy: tuple[float, float], grasp_z: float, notes: list[str]
) -> tuple[int, int]:
    """Closes the fingers at `grasp_z` [m] over `xy`; while they close on nothing (the
    cell's hold measure 0: a gripper closed to its stop) and the TCP is still over
    `lost.grasp_height` above the table, opens them, lowers the TCP by `lost.regrasp_step`
    (at most `lost.regrasps` times) and closes again: a heap's top measured high leaves the
    fingers over the cloth (held-out episodes 264 and 287, session 26: two blind grasps
    closed 26-28 mm over the nearest cloth, the simulated fingers reaching 13 mm below
    the TCP). Returns (the last hold measure, closings)."""
    s, loop = job.settings, job.loop_settings
    lowest = job.table_z + s.lost.grasp_height
    job.cell.set_gripper(0.0)
    job.motion.hold(loop.close_time)
    held, closings, start = job.cell.grasp(), 1, grasp_z
    while held == 0 and closings <= s.lost.regrasps and grasp_z > lowest + 1e-6:
        job.cell.release()
        job.cell.set_gripper(loop.gripper_open)
        job.motion.hold(loop.close_time)
        grasp_z = max(lowest, grasp_z - s.lost.regrasp_step)
        job.motion.move_tcp([xy[0], xy[1], grasp_z], speed=s.put_down_speed)
        job.cell.set_gripper(0.0)
        job.motion.hold(loop.close_time)
        held, closings = job.cell.grasp(), closings + 1
    if closings > 1:
        notes.append(
            f"the fingers closed on nothing {(start - job.table_z) * 1000:.0f} mm over the table: "
            f"closed {closings} times, lowered to {(grasp_z - job.table_z) * 1000:.0f} mm"
            + ("" if held else ", still nothing")
        )
    return held, closings


def _measurable(job: TableClearer, match: LostMatch) -> bool:
    """May a blind grasp of `match` be aimed at the surface the survey's pair measures?
    Not with `clear.surface` off, for a cloth without a recogniser, or after a blind grasp
    of this cloth closed on nothing (then at `lost.grasp_height` over the table)."""
    return (
        job.settings.surface.enabled and job.ledger.misses(match.name) == 0 and match.name in job.recognizers
    )


def _surfaces(
    job: TableClearer, match: LostMatch, points: Sequence[tuple[float, float]]
) -> list[SurfaceHeight]:
    """The surface the survey's pair measures at each table point (x, y) [m] inside the
    region of `match` (`table_surface.surface_heights`, with its recogniser's model); the
    arm holds for the computation time."""
    cpu = time.process_time()
    recognizer, table_z = job.recognizers[match.name], job.table_z
    found = surface_heights(
        job.survey_capture, job.rig, recognizer.model, recognizer.settings.depth, match.region.mask,
        [[x, y, table_z] for x, y in points], table_z, job.settings.surface,
    )  # fmt: skip
    job.motion.hold(time.process_time() - cpu)
    return found


def _blind_grasp_height(
    job: TableClearer, match: LostMatch, xy: tuple[float, float], notes: list[str]
) -> float:
    """The TCP's height [m] for a blind grasp at `xy`: `grasp_height` over the table, or,
    where the survey's pair measures the region's top surface there (`table_surface`, as
    the loop's grasp) and no blind grasp of this cloth has missed yet, the loop's
    `grasp_height` over that surface if higher. A put-back heap stands several cloths
    high, and fingers closing 25 mm over the table reach through all of them (bench
    episodes 29, 39, 43: the crossed heap came up whole at every blind lift); aimed at its
    top they reach the top cloth's layer, as on a pile. The arm holds for the time measured."""
    s, table_z = job.settings, job.table_z
    fixed = table_z + s.lost.grasp_height
    if not _measurable(job, match):
        return fixed
    (found,) = _surfaces(job, match, [xy])
    if not found.trusted:
        return fixed
    aimed = max(fixed, found.z + job.loop_settings.grasp_height)
    notes.append(
        f"blind grasp {(aimed - table_z) * 1000:.0f} mm over the table: the region's surface there at "
        f"{(found.z - table_z) * 1000:.0f} mm (correlation {found.correlation:.2f})"
    )
    return aimed


def _heap_top(
    job: TableClearer, match: LostMatch, aims: np.ndarray, reaches: Callable[[float, float], bool]
) -> tuple[float, float, float, str] | None:
    """The blind grasp at the top of the heap: of the `lost.top_tries` deep points of the
    region's graspable part `aims` (`lost.top_depth`, `TOP_APART` apart) that the hand
    `reaches`, the one whose surface the survey's pair measures highest (`surface_heights`
    inside the region, as `_blind_grasp_height`; only measurements that correlate at least
    `lost.top_correlation`: a patch over a layer's edge finds the upper layer at a weak
    correlation beside it; where the hand reaches and clears the walls at that top, up the
    point's ray), with the TCP the loop's `grasp_height` over it (at least
    `lost.grasp_height` over the table) where the point's ray meets that surface (a heap's
    top 9 cm up, 20 cm off the camera's axis, lies 3 cm nearer the axis than the ray's
    point on the table): (x, y, z) [m] and the note; None when off, when no point is
    measured, or after a blind grasp of this cloth closed on nothing (then
    `_blind_grasp_height`). Fingers coming down at the innermost point beside a higher part
    sweep a light cloth away before they close (held-out episode 264, session 26: No.12
    lay flat at 8 mm there and draped up to 85 mm beside it; pushed 10 cm, the grasp held
    nothing). The arm holds for the time measured."""
    s, table_z = job.settings, job.table_z
    if s.lost.top_tries <= 0 or not _measurable(job, match):
        return None
    capture = job.survey_capture
    pixels = inner_pixels(aims, s.lost.top_tries, TOP_APART, s.lost.top_depth)
    points = [p for p in (job.table.point(capture, px) for px in pixels) if reaches(*p)]
    if not points:
        return None
    found = _surfaces(job, match, points)
    measured = [
        (f, p)
        for f, p in zip(found, points, strict=True)
        if f.trusted and f.correlation >= s.lost.top_correlation
    ]
    # the point is where the pixel's ray meets the table; the surface seen there lies up the
    # ray, where the hand must reach and clear the walls too (the table point was checked,
    # the top up the ray can lie nearer a wall: a guard added in session 34 while tracing
    # held-out 776 and 783's wall contacts, which it turned out not to cause)
    camera = np.asarray(capture.transform_right_camera_to_world, dtype=float)[:3, 3]
    tops = [
        (f, camera[:2] + (camera[2] - f.z) / (camera[2] - table_z) * (np.array(p) - camera[:2]))
        for f, p in measured
    ]
    walls = job.boxes.values()
    tops = [(f, xy) for f, xy in tops if clear_of_walls(xy, walls, s.lost.wall_clearance)[0] and reaches(*xy)]
    if not tops:
        return None
    best, top = max(tops, key=lambda m: m[0].z)
    x, y = float(top[0]), float(top[1])
    aimed = max(table_z + s.lost.grasp_height, best.z + job.loop_settings.grasp_height)
    note = (
        f"blind grasp {(aimed - table_z) * 1000:.0f} mm over the table at the heap's top: the region's "
        f"surface there at {(best.z - table_z) * 1000:.0f} mm (correlation {best.correlation:.2f}; the "
        f"highest of {len(measured)} measured of {len(points)} points)"
    )
    return x, y, aimed, note


def _carry(job: TableClearer, attempt: AttemptState, match: LostMatch) -> tuple[Outcome, str]:
    """After a lift that holds something: weigh, then into the box and look (or lay back),
    with the job's own hand-over (`TableClearer.put_back`, `TableClearer.check_box`) and
    the loop's transfer and release (`pick_place.carry_over_box`, `release_into_box`),
    made with the job's motions. A weight that is not `name`'s but that of some of it and
    its `alike` (one box) names the lift after them (`weighed_as`: a piece's lift is one
    cloth, a guessed companion is only ever alone); such a lift is looked at before it goes
    anywhere when cloths of another box would weigh as much in their stead
    (`weighs_instead`), as one whose match doubted others (`LostMatch.doubted`)."""
    loop, table_z, name = job.loop_settings, job.table_z, match.name
    expected = job.weights.get(name)
    held: tuple[str, ...] = ()
    partners: tuple[str, ...] = ()  # lost cloths of the box that may lie at the grasp (`lost_with`)
    instead: tuple[str, ...] = ()  # cloths of another box that would weigh as much as `held`
    unseen: frozenset[str] = frozenset()  # of those, the never-seen ones (`weighs_instead(unlooked)`)
    tied: tuple[str, ...] = ()  # of a tie (`LostMatch.rivals`), the cloths whose weight it reads
    if job.weigh is None or expected is None:
        verdict, what = "wrong", f"{name}'s weight unknown: its identity cannot be confirmed"
    else:
        weighed = attempt.weighed = float(job.weigh())
        tied = _tied(job, match, weighed)
        if tied and tied[0] != name:
            name = _take_as(job, attempt, tied[0], f"{weighed * 1000:.0f} g, its weight")
            expected = job.weights[name]
        verdict, what = weight_verdict(weighed, expected, name, job.settings, lift=True)
        grasp_xy = attempt.transform_target_to_world[:2, 3]
        if verdict == "ok":
            # a cloth of another box of about its weight may hang there instead (held-out
            # episode 622, session 31: 31 g, No.2's weight, held No.6 of whites)
            instead = weighs_instead(job, attempt.box.name, (name,), weighed, grasp_xy, unlooked=True)
            unseen = frozenset(instead) - set(
                weighs_instead(job, attempt.box.name, (name,), weighed, grasp_xy)
            )
        else:
            most = 1 if match.piece else MAX_HEAP
            partners = lost_with(job, name, attempt.box.name, grasp_xy)
            along, only_alone = lift_candidates(match, partners)
            held = weighed_as(weighed, name, along, job.weights, job.settings, most, only_alone)
    if held:
        # more than, or other than, the cloth meant came up; all of it belongs in this box
        attempt.lift_check = "double" if len(held) > 1 else "wrong"
        attempt.lost_name, attempt.came_along = held[0], held[1:]
        why = "may lie there too" if any(n in partners for n in held) else "colours alike"
        attempt.notes.append(
            f"{weighed * 1000:.0f} g lifted: the weight of {' and '.join(held)} "
            f"({why}, same box): placed as {'one lift' if len(held) > 1 else held[0]}"
        )
        name = held[0]
        instead = weighs_instead(job, attempt.box.name, held, weighed, grasp_xy)
        meant = (match.name, *match.alike, *partners)
        along = with_the_meant(weighed, meant, instead, job.weights, job.settings, held)
        if along:
            # no look tells: a dragged cloth hangs inside the held one (held-out episode 328)
            attempt.lift_check = "double"
            what = (
                f"{weighed * 1000:.0f} g: {' and '.join(held)}, or {match.name} with "
                f"{' or '.join(along)} (another box)"
            )
            attempt.notes.append(f"{what}: put back")
            job.put_back(attempt, None)
            return Outcome.GRASP_FAILED, f"{PUT_BACK}: {what}"
        # never-seen cloths where no one looked at an unnamed put-back: looked for, not
        # enough to put the lift back unlooked (any pair of colours weighs a colours and a
        # white cloth's weight)
        looked_for = weighs_instead(job, attempt.box.name, held, weighed, grasp_xy, unlooked=True)
        instead, unseen = looked_for, frozenset(looked_for) - set(instead)
        if instead:
            attempt.notes.append(f"as much as {' or '.join(instead)} (another box) in their stead")
    else:
        attempt.lift_check = verdict
        if verdict != "ok":
            kind = "double pick" if verdict == "double" else "wrong lift"
            if verdict == "double" and attempt.weighed is not None and expected is not None:
                # the extra goes back unnamed, as a surveyed pick's does (held-out 1339,
                # session 42: a guess lifted with the never-seen No.14 went back, the guess
                # was placed later, and No.14's region was never taken: no unnamed place left)
                attempt.unnamed_along = job.count_unnamed(attempt, attempt.weighed - expected)
            attempt.notes.append(f"{kind} ({what}): put back")
            job.put_back(attempt, None)
            return Outcome.GRASP_FAILED, f"{PUT_BACK}: {what}"
    # all of another box than the cloth it is taken as (a tie's rival may be taken instead)
    box = attempt.box.name
    doubted = tuple(n for n in dict.fromkeys((*match.doubted, *instead)) if job.sort.box_for(n) != box)
    if doubted:
        hanging, where = look_at_held(job, name, doubted, fit=True, along=held[1:])
        looked = hanging  # every fit, for the scale's say (`_weighs_more_like`)
        if hanging is not None and unseen - set(match.doubted):
            # a cloth never seen is held to its own colours showing, not to a fit as close as
            # the meant cloth's (held-out 651 on fe0a83a: No.7, a print with white, fit 0.63,
            # the never-seen white No.6 0.75 with none of its own showing: put back at every lift)
            fits = {n: f for n, f in hanging.fits.items() if n not in unseen or n in match.doubted}
            hanging = replace(hanging, fits=fits)
        alone, seen = _alone(job, name, doubted, attempt, hanging, where, looked)
        attempt.notes.append(f"looked at against free table (could be {', '.join(doubted)}): {seen}")
        for other in () if alone or held[1:] else tied[1:]:
            alone, seen = _tied_alone(job, attempt, other, doubted, seen)
            if alone:
                name = _take_as(job, attempt, other, "seen hanging alone")
                break
        booked = "" if alone or held[1:] else booked_in_stead(job, attempt, doubted)
        if booked in job.ledger.still_unsure():
            earlier = _the_earlier_lift(job, booked, attempt.meant)
            number = len(job.ledger.attempts) + 1
            job.ledger.swap_placed(booked, earlier, f"lifted blind again at attempt {number}, seen hanging")
        if booked:
            alone, attempt.held_instead, name = True, booked, booked
        if not alone:
            attempt.lift_check = "wrong"
            attempt.notes.append(f"not sure it is {name} alone: put back")
            job.put_back(attempt, None)
            return (
                Outcome.GRASP_FAILED,
                f"{PUT_BACK}: the lifted cloth's colours not sure to be {name}'s ({seen})",
            )
    start = job.cell.time
    job.set_phase("transfer", name)
    # the other cloths of a lift named as several hang from the held one
    extra = max((job.hanging_reach(other) for other in held[1:]), default=0.0)
    carry_over_box(job.motion, attempt.box.centre, table_z, loop, extra, job.motion.tcp_position())
    _phase(job, name, "transfer", start, "")
    if not job.cell.holding():
        attempt.dropped = True
        attempt.notes.append("dropped during the transfer (gripper empty over the box)")
        job.cell.release()
        job.cell.set_gripper(loop.gripper_open)
        if job.fell_into_box(attempt):
            return Outcome.PLACED, FELL_INTO_BOX
        return Outcome.LOST, f"{DROPPED} during the transfer: the gripper came empty over the box"
    job.check_carried(attempt)
    start = job.cell.time
    job.set_phase("release", name)
    reach = job.hanging_reach(name) + extra
    release_into_box(
        job.motion, job.cell, attempt.box.centre, table_z, loop, reach, job.box_heap(attempt.box.name)
    )
    _phase(job, name, "release", start, "")
    job.check_box(attempt)
    return Outcome.PLACED, f"{name} placed (picked blind, its weight read)"


def _tied(job: TableClearer, match: LostMatch, weighed: float) -> tuple[str, ...]:
    """Of a tie's cloths (`match.name` and its `rivals`, of another box), those whose own
    weight the reading `weighed` [kg] is (`weight_verdict`), the match first; () without
    rivals."""
    if not match.rivals:
        return ()
    return tuple(
        n
        for n in (match.name, *match.rivals)
        if n in job.weights and weight_verdict(weighed, job.weights[n], n, job.settings, lift=True)[0] == "ok"
    )


def _take_as(job: TableClearer, attempt: AttemptState, name: str, why: str) -> str:
    """Books a tie's blind lift as its rival `name`, bound for that cloth's box; returns
    `name`."""
    attempt.held_instead, attempt.taken_for = name, (name,)
    attempt.box = job.boxes[job.sort.box_for(name)]
    attempt.notes.append(
        f"taken as {name} ({attempt.box.name}; the region's colours tied with {attempt.meant}'s): {why}"
    )
    return name


def _tied_alone(
    job: TableClearer, attempt: AttemptState, other: str, doubted: Sequence[str], seen: str
) -> tuple[bool, str]:
    """Does a tie's blind lift, not shown to be the cloth it was taken as, hold its rival
    `other` (of another box, its weight read) alone? A look for it (`look_at_held`)
    against the cloths of another box than its own among `doubted` and the one taken as
    (`_alone`); and what was seen, after `seen`."""
    box = job.sort.box_for(other)
    against = [n for n in dict.fromkeys((attempt.name, *doubted)) if job.sort.box_for(n) != box]
    alone, also = _looked_alone(job, attempt, other, against, f"tied, {box}", box)
    return alone, f"{seen}; for {other}: {also}"


def _looked_alone(
    job: TableClearer, attempt: AttemptState, name: str, doubted: Sequence[str], why: str, box: str = ""
) -> tuple[bool, str]:
    """A look for `name` at a blind lift (`look_at_held`, with colour fits) against the
    `doubted` cloths of another box than `box` (`_alone`), noted with `why`: (does it hold
    `name` alone, what was seen)."""
    hanging, where = look_at_held(job, name, doubted, fit=True)
    alone, seen = _alone(job, name, doubted, attempt, hanging, where, hanging, box)
    attempt.notes.append(f"looked at for {name} ({why}): {seen}")
    return alone, seen


def booked_in_stead(job: TableClearer, attempt: AttemptState, doubted: Sequence[str]) -> str:
    """A blind lift whose look did not show the meant cloth alone: a cloth of its box other
    than the meant one, whose weight the load cell reads and whose colours a look
    for it shows hanging (`held_verdict` against the same `doubted` cloths of other boxes,
    and no nearer weight among them); "" if none. The lift then goes into the box as that
    cloth. Such cloths: one booked placed by an earlier blind lift that could have been
    another cloth of the box not placed since (`TableLedger.placed_unsure`: that lift held
    the other one), and one not placed whose attempts are spent. Held-out episode 1739
    (session 48): a blind lift named No.6 (white print, whites), its region as much in
    No.17's colours (whites), held No.17 and was placed as No.6; the real No.6, crumpled,
    was then lifted ten times under guesses (No.17, No.18, of whites; No.20, No.7, of
    colours), each look fit none of them, and it went back every time. Held-out 1664
    (session 47): No.15 (colours), its attempts spent, was lifted four times under the
    guess No.13 (colours) and went back, the look showing 5-14 % in No.13's colours."""
    ledger, weighed, box = job.ledger, attempt.weighed, attempt.box.name
    if weighed is None:
        return ""
    unsure = [
        (booked, f"placed by a blind lift that could have been {' or '.join(others)}")
        for booked, others in ledger.still_unsure().items()
    ]
    spent = [
        (name, "its attempts spent")
        for name in job.recognizers
        if name not in ledger.placed_order and name in ledger.records and not job.untried(name)
    ]
    for name, why in (*unsure, *spent):
        weight = job.weights.get(name)
        if (
            name == attempt.meant
            or job.sort.box_for(name) != box
            or weight is None
            or weight_verdict(weighed, weight, name, job.settings, lift=True)[0] != "ok"
        ):
            continue
        if _looked_alone(job, attempt, name, doubted, why)[0]:
            return name
    return ""


def _alone(
    job: TableClearer,
    name: str,
    doubted: Sequence[str],
    attempt: AttemptState,
    hanging: HeldColours | None,
    where: str,
    looked: HeldColours | None,
    box: str = "",
) -> tuple[bool, str]:
    """(does the blind lift hold `name` alone, what was seen): the `held_verdict` on what
    a look for it saw hang (`hanging`, None: no look, `where` says why), withdrawn where one
    of the `doubted` cloths of another box than `box` (default: the attempt's) weighs
    nearer the reading (`_weighs_more_like` on the fits of `looked`)."""
    alone, seen = (False, where) if hanging is None else held_verdict(hanging, job.settings.held_look)
    seen += "" if hanging is None else f" ({where})"
    box = box or attempt.box.name
    nearer = _weighs_more_like(job, name, doubted, attempt.weighed, box, looked)
    if alone and nearer:
        alone, seen = False, f"{seen}; the weight is nearer {nearer}'s (another box)"
    return alone, seen


def _the_earlier_lift(job: TableClearer, booked: str, meant: str) -> str:
    """Which of the cloths a blind lift booked as `booked` could have been, not placed yet
    (`TableLedger.still_unsure`), it was, now `booked` is seen held again: `meant` (the
    current lift was taken for it by its colours) if among them, else the first."""
    others = job.ledger.still_unsure()[booked]
    return meant if meant in others else others[0]


def _weighs_more_like(
    job: TableClearer,
    name: str,
    doubted: Sequence[str],
    weighed: float | None,
    box: str,
    hanging: HeldColours | None = None,
) -> str:
    """For a blind lift named `name` (lost by name or guessed), the first of the `doubted`
    cloths of another box whose weight is nearer the load cell's reading `weighed` [kg]
    than `name`'s, by `nearer_margin` at least (the scale's own error: held-out 1244,
    session 41, went back for 0.7 g), and whose colour fit to what `hanging` shows comes
    within twice `held_look.margin` of `name`'s (any, where the fits are not known) ("" if
    none): a blind grasp takes whatever lies on top of the heap at the region, whatever the
    region is named after, and a colour fit a little ahead does not overrule the scale. `hanging`
    keeps the fits of never-seen cloths too (the colour verdict holds those to their own
    colours showing). Where both cloths are of tones only (`TableClearer.tones_only`), the
    fit does not count: held-out 1535 (session 45), a blind lift meant for No.17 (white
    towel, whites, 23.5 g; a phantom named after a false alarm's extra weight) read 19.1 g
    and fit No.17 at 0.99 against 0.49 for what hung, No.19 (grey melange, colours, 21.3 g,
    2.2 g nearer), lit white; it went into whites.
    Held-out 939 (session 36): a blind lift at the region of No.17 (white towel, whites,
    24.5 g; lost by name, put back after a double pick) read 21.8 g and showed 95 % in
    No.17's colours (fit 0.73 against 0.44 for No.19, grey melange, colours, 21.4 g): it
    was No.19, and went into whites. Until then only guesses were held to the scale;
    held-out 769 (session 33) was the same pair of colours under a guess: No.6 (white print,
    22 g) read 16.7 g, fit 0.72 against No.19's 0.49, into whites. Held-out 862 (session 34):
    a lift guessed No.18 (whites) showed 99 % white, fit 1.00, weighed nearer the never-seen
    red No.1, whose fit the verdict had dropped, and went back twice (it was No.17, of whites
    too). Held-out 799 (session 33, before the fit's bound): a lift guessed No.14 (colours)
    fit 0.97, the white No.17 0.00, weighed nearer No.17 and went back; it was No.15
    (colours), never identified, and stayed on the table."""
    expected = job.weights.get(name)
    if weighed is None or expected is None:
        return ""
    meant_fit = hanging.meant_fit if hanging is not None else None
    margin = job.settings.nearer_margin
    for other in doubted:
        weight = job.weights.get(other)
        nearer = weight is not None and abs(weight - weighed) <= abs(expected - weighed) - margin
        fit = hanging.fits.get(other) if hanging is not None else None
        if meant_fit is not None and fit is not None and not (job.tones_only(name) and job.tones_only(other)):
            nearer &= fit.score >= meant_fit.score - 2 * job.settings.held_look.margin
        if nearer and job.sort.box_for(other) != box:
            return other
    return ""


def lift_candidates(match: LostMatch, partners: Sequence[str]) -> tuple[tuple[str, ...], frozenset[str]]:
    """The cloths besides `match.name` a blind lift may be named after by its weight
    (`weighed_as`): the match's alike and the `partners` that may lie at the grasp
    (`lost_with`); and those of them taken only alone: the guesses (`LostMatch.guessed`)
    that are no partner."""
    return tuple(dict.fromkeys((*match.alike, *partners))), match.guessed - frozenset(partners)


def lost_with(job: TableClearer, name: str, box: str, grasp_xy: npt.ArrayLike) -> tuple[str, ...]:
    """The other lost cloths of `box`, not placed, that may lie where a blind lift meant for
    `name` grasped (`grasp_xy` [m], `near_the_loss` of their loss) whether or not the
    region shows their colours: a double pick's other cloth, put back inside the meant
    one, shows none (held-out episode 407, session 28: No.8 and No.2, both colours, came up
    together at five lifts, the region 100 % in No.8's orange; each read 43-46 g, the two
    together, and went back, as No.2 was no alike of it). With them, where the grasp may
    be at a put-back of a double pick whose other cloth was not named (`TableLedger.unnamed`,
    `near_the_loss`), the suspects of that cloth in `box`: seen by an earlier survey, not by
    the last, not lost and not placed (`TableClearer._lost_to_pick`'s). Held-out episodes
    415 and 429 (session 29): No.12 came up with No.20 at four blind lifts (38 g), No.8 with
    No.14 and No.11 (78 g), all colours, each hidden since the first survey and put back
    with the meant cloth unnamed; every lift went back, as neither was lost. `weighed_as`
    may name the lift after them with `name`, a suspect too where the match guessed it
    (`LostMatch.guessed`, otherwise only ever taken alone: replay of held-out 475, No.17 and
    No.6 of whites came up together, No.6 a guess by its colours, and went back); they go
    into its box (`weighs_instead` and `with_the_meant` still doubt the cloths of another
    box that could be in it). Alike or not: the caller merges them with the match's alike."""
    ledger, placed = job.ledger, set(job.ledger.placed_order)
    grasp = np.asarray(grasp_xy, dtype=float).reshape(2)
    near = {other for other, place in ledger.lost.items() if near_the_loss(grasp, place, job.settings.lost)}
    if any(near_the_loss(grasp, place, job.settings.lost) for place in ledger.unnamed):
        surveys = len(ledger.surveys)
        near |= {
            other
            for other, survey in ledger.last_survey.items()
            if survey != surveys and other not in ledger.lost
        }
    return tuple(
        sorted(
            other
            for other in near
            if other != name
            and other not in placed
            and other in job.weights
            and job.sort.box_for(other) == box
        )
    )


def weighs_instead(
    job: TableClearer,
    box: str,
    held: Sequence[str],
    weighed: float,
    grasp_xy: npt.ArrayLike,
    unlooked: bool = False,
) -> tuple[str, ...]:
    """The cloths of another box than `box` that could be in a blind lift named after
    `held` by the load cell's reading `weighed` [kg] (`weighed_as`): those that weigh the
    reading (`weighs_extra`) or less (held-out episode 299 on 7941f33, session 26: 65 g
    named "No.16 and No.3" held No.19, No.3 and No.17 of whites; held-out episode 328,
    session 27: 43 g named "No.16" alone held No.8 and No.17 of whites, dragged along: a lift
    that is not the meant cloth's weight is as often a double pick as another cloth); not
    placed, and lost, or seen by a survey;
    one the last survey saw only if its footprint there comes within `remembered_reach`
    [m] of the grasp at `grasp_xy` [m] (farther, it lies apart from the lift). Held-out
    episode 304 (session 26): a blind lift meant for the dropped No.18 read 41 g, No.18
    and No.17 (whites) together; it held No.17 and No.9 (colours, 16 g: put back there,
    missed blind, not found by the loop, a candidate of the last survey 4 cm from the
    grasp), which weigh as much: No.9 went into whites. A cloth never seen is one of them
    where it showed its own colours hanging from a double pick put back unnamed near the
    grasp (`LostPlace.showed`, `near_the_loss`): held-out episode 514 (session 29), No.1 of
    colours, never identified, came up with No.18 of whites and showed 11 % hanging; the
    pair, put back, was lifted blind as "No.6 and No.18" and went into whites. With
    `unlooked`, where no one looked at what hung from that double pick (no single cloth
    weighed its extra), every cloth never seen may be in it: held-out episode 615 (session
    31), No.18 of whites, never identified, came up with No.16 and No.5 (79 g, 47 g extra),
    put back unlooked, and went into colours in a blind lift of No.16's weight. So are,
    with `unlooked`, the never-seen cloths that look could not show (`LostPlace.hid`):
    held-out 1819 (session 49), No.17 (white towel, whites, never identified) came up with
    No.16 (a print with white, colours), the look saw 98 % in No.16's colours, and No.17,
    lifted blind alone as No.16 (24.5 g for 31.9 g), went into colours unlooked; 1820 the
    same with No.18 (white linen) and No.3."""
    ledger, s = job.ledger, job.settings
    placed, surveys = set(ledger.placed_order), len(ledger.surveys)
    grasp = np.asarray(grasp_xy, dtype=float).reshape(2)
    never_seen = {
        name for name in job.recognizers if name not in ledger.last_pose and name not in ledger.lost
    }

    def suspected(place: LostPlace) -> Iterable[str]:
        if unlooked:
            return (*place.showed, *place.hid) if place.looked else never_seen
        return place.showed

    showed = {
        name for place in ledger.unnamed if near_the_loss(grasp, place, s.lost) for name in suspected(place)
    }

    def apart(name: str) -> bool:
        if name in ledger.lost or ledger.last_survey.get(name) != surveys:
            return False
        footprint = transform_points(ledger.last_pose[name], job.recognizers[name].model.points_in)
        return not comes_within(footprint[:, :2], grasp, s.remembered_reach)

    return tuple(
        sorted(
            name
            for name in set(ledger.lost) | set(ledger.last_pose) | showed
            if name not in placed
            and name not in held
            and name in job.recognizers
            and job.sort.box_for(name) != box
            and could_be_in(weighed, job.weights.get(name), s)  # alone, or with any of them
            and not apart(name)
        )
    )


def with_the_meant(
    weighed: float,
    meant: Sequence[str],
    others: Sequence[str],
    weights: Mapping[str, float],
    settings: ClearTableSettings,
    named: Sequence[str] = (),
) -> tuple[str, ...]:
    """Of `others` (cloths of another box that could be in a blind lift, `weighs_instead`),
    those whose weight is what the reading `weighed` [kg] adds to that of one of the cloths
    the lift was meant for (`meant`: the match and its alike; unknown weights skipped), or
    to that of all the cloths `weighed_as` `named` it after: the lift is then as well such
    a cloth (or those) with one of them as what `weighed_as` named it, and the look cannot
    settle it, since a dragged cloth hangs inside the held one. Replay of held-out episode
    540 (session 30): 67 g named "No.11 and No.4" (50 g, within the tolerance that lets a
    dragged cloth read light) held No.17 of whites (24 g) too, inside; it went into colours.
    Held-out episode 328 (session 27): a blind lift meant for No.8 (21 g) read 43 g, the
    weight of its alike No.16 alone (colours, a guess); it held No.8 with the dragged No.17
    (whites, 24 g, lost nearby), which the look did not see (18,412 held pixels all in
    No.8's orange), and No.17 went into colours. Its replay on the first form of this rule
    (the match's own weight only) put it into colours as the guess No.16 with No.12 (45 g),
    the match being No.16 by then."""
    held = [weights[name] for name in meant if name in weights]
    if named and all(name in weights for name in named):
        held.append(sum(weights[name] for name in named))
    return tuple(
        name for name in others if any(weighs_extra(weighed - w, weights.get(name), settings) for w in held)
    )


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


__all__ = [
    "LostMatch",
    "close_lowering",
    "colour_patches",
    "inner_pixel",
    "inner_pixels",
    "lift_candidates",
    "match_heap",
    "match_lost",
    "near_the_loss",
    "pick_lost",
    "reachable_point",
    "weighed_as",
    "weighs_instead",
    "with_the_meant",
]
