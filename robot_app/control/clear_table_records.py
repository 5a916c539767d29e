"""Settings and typed records of the clear-table job (`TableClearer`)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import StrEnum

import numpy as np
import numpy.typing as npt
from pydantic import Field

from robot_app.arrays import FloatArray
from robot_app.config import StrictModel
from robot_app.control.box_check import BoxCheck
from robot_app.control.episode import EpisodeResult
from robot_app.control.grasp_point import PileGraspSettings
from robot_app.control.held_look import HeldLookSettings
from robot_app.control.job_motion import PutBackSettings
from robot_app.control.limits import LimitReport
from robot_app.control.table_layers import LayerSettings
from robot_app.control.table_moved import MovedSettings
from robot_app.control.table_surface import SurfaceSettings


class LostSettings(StrictModel):
    """Picking a lost cloth again (the `clear.lost` section). Lengths [m].

    Attributes:
        enabled: look for lost cloths among the unknown regions when nothing else is left.
        min_share: share of the region's pixels in the lost cloth's main colours [-].
        margin: ... at least this much more than in any other lost cloth's [-].
        grasp_height: TCP above the table when the fingers close on the region: a
            crumpled cloth stands higher than a flat one, and a cloth under it weighs
            the lift up (laid back) [m].
        reach: the region's centre must lie this close to the way the cloth was lost (the
            segment from where it was lifted to the box for a drop, to where it was let go
            for a put-back) [m].
        apart: ... and farther than this from every unknown region the survey before the
            loss saw (what was there then is not the lost cloth) [m].
        edge_inset: the blind grasp aims only at the region's part that lies at least this
            far inside the table top's edge: past it a cloth hangs down, and fingers closing
            at `grasp_height` there close on air (bench episode 24, session 18: two blind
            grasps at y = 0.75 m, the table ending at 0.70) [m].
        wall_clearance: ... and at least this far from every box's outer walls: the open
            hand's half span (the fingers' outer faces 0.051 m off the axis; the palm 0.1 m
            wide) and a 2 cm margin, so no finger lands on a wall and the hand lifts no
            cloth out of the box (the same episode: a grasp beside the whites box lifted a
            cloth hanging out of it); 0.05 until session 34: held-out 776 and 783 (session
            33) had 10 blind grasps 5 cm from a wall, and coming down the finger's outer
            face met the wall's (replay: TCP at y 0.389, the wall at 0.44), which then
            pushed the hand 1-3 cm off its way [m].
        empty_grasps: a region whose centre lies within `empty_reach` of this many blind
            grasps that closed on nothing is not grasped blind again, under any name: it is
            no cloth the fingers can take (bench episode 40, session 20: eight blind attempts,
            under two guessed names, at a white region by the arm's base at table height).
        empty_reach: see `empty_grasps` [m].
        top_tries: deep points of the region's graspable part (`top_depth`, 8 px apart)
            whose surface the survey's pair measures; the blind grasp goes to the highest
            one measured (`table_surface`), the top of the heap: fingers coming down beside
            it sweep the cloth away before they close (held-out episode 264, session 26:
            No.12 lay flat at 8 mm at the innermost point and draped up to 85 mm beside it;
            the descent pushed it 10 cm aside, the grasp closed on nothing). 0: the
            innermost reachable point, as before.
        top_depth: ... only points at least this share of the deepest one's distance
            from the region's border [-].
        regrasps: where a blind grasp's fingers close on nothing (the cell's hold measure
            0) above `grasp_height`, they open, go `regrasp_step` lower and close again, at
            most this many times (a heap's top measured high: held-out episodes 264 and
            287, session 26, closed 26-28 mm over the nearest cloth) [-].
        regrasp_step: see `regrasps` [m].
        top_correlation: ... and only surfaces measured at least this correlated (the
            patch around a point over a layer's edge finds the upper layer beside it at a
            weak correlation: 0.71 against 0.89-0.97 on it, `tests/test_clear_table_surface`) [-].
    """

    enabled: bool = True
    min_share: float = Field(0.6, gt=0.0, le=1.0)
    margin: float = Field(0.2, ge=0.0, le=1.0)
    grasp_height: float = Field(0.025, ge=0.02, le=0.08)
    reach: float = Field(0.3, gt=0.0)
    apart: float = Field(0.05, ge=0.0)
    edge_inset: float = Field(0.02, ge=0.0)
    wall_clearance: float = Field(0.07, ge=0.0)
    empty_grasps: int = Field(2, ge=1)
    empty_reach: float = Field(0.06, gt=0.0)
    top_tries: int = Field(12, ge=0, le=64)
    top_depth: float = Field(0.5, ge=0.0, le=1.0)
    top_correlation: float = Field(0.85, ge=-1.0, le=1.0)
    regrasps: int = Field(3, ge=0, le=10)
    regrasp_step: float = Field(0.012, gt=0.0, le=0.05)


class OffSheetSettings(StrictModel):
    """The table beyond the green sheet in a survey image (the `clear.off_sheet` section).

    `identify`'s foreground is whatever is not the sheet, so the bare table around it
    would count as an unknown cloth, and a cloth lying across the sheet's edge as one
    region with the table (its colour share then too low to be picked again). Where a
    pixel's ray meets the table beyond the sheet (`TableArea`, known from the cell), it is
    table, not cloth, when its hue is the table's: the most frequent hue of those pixels
    in that image that are no other furniture (the table is the one large coloured surface
    there), at least `min_saturation` saturated (a white or grey cloth has no hue; the
    table's shade keeps its hue, darker); or when the exposure clipped its colour away
    (`clipped`).

    Attributes:
        enabled: take the table beyond the sheet out of the unknown regions.
        hue_tolerance: a pixel within this of the table's hue is table [HSV_FULL steps].
        min_saturation: ... and at least this saturated [0-255].
        min_pixels: fewer saturated pixels beyond the sheet than this: no table hue seen.
        clipped: a pixel beyond the sheet this bright in a channel [0-255] and less
            saturated than `min_saturation` is the table washed out: the exposure clipped
            its colour away, and no cloth could be told by its colours there either. Held-out
            bench episodes 517 and 540 (session 29): from the looks around, the bare table
            lay nearly white (saturation 0-9, brightness 255) and was picked blind as a lost
            cloth's region up to ten times (`grasp missed`, `out of reach`).
    """

    enabled: bool = True
    hue_tolerance: int = Field(10, ge=1, le=64)
    min_saturation: int = Field(15, ge=1, le=255)
    min_pixels: int = Field(200, ge=1)
    clipped: int = Field(250, ge=1, le=256)


@dataclass(frozen=True)
class TableArea:
    """An axis-aligned rectangle on the table in Σ_W [m]: the green sheet, or the table top."""

    x_range: tuple[float, float]
    y_range: tuple[float, float]

    def contains(self, xy: npt.ArrayLike, inset: float = 0.0) -> npt.NDArray[np.bool_]:
        """(N,) which of the (N, 2) points `xy` [m] lie in the rectangle shrunk by `inset` [m]
        on every side."""
        p = np.asarray(xy, dtype=float).reshape(-1, 2)
        (x0, x1), (y0, y1) = self.x_range, self.y_range
        inside_x = (p[:, 0] >= x0 + inset) & (p[:, 0] <= x1 - inset)
        return np.asarray(inside_x & (p[:, 1] >= y0 + inset) & (p[:, 1] <= y1 - inset), dtype=bool)

    def corners(self) -> FloatArray:
        """(4, 2) its corners in order around it [m]."""
        (x0, x1), (y0, y1) = self.x_range, self.y_range
        return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], dtype=float)


class LossKind(StrEnum):
    """How the job lost a cloth (`LostPlace.kind`): what the look-around and the lost-cloth
    rules ask of a loss, where the text of `LostPlace.how` is for people."""

    DROPPED = "dropped"  # fell from the fingers on the way to its box
    PUT_BACK = "put back"  # laid back on the table after a rejected lift (double or wrong)
    LEFT_BY_LIFT = "left by a lift"  # shed: left lying along the strip a double pick was laid on
    MOVED = "moved"  # dragged by a placed pick, held by nothing (`table_moved`)
    HIDDEN = "hidden"  # seen by a survey, not since, with unknown regions left (`TableLedger.hide`)


@dataclass(frozen=True)
class LostPlace:
    """How and where the job lost a cloth.

    Attributes:
        kind: how it was lost (`LossKind`).
        how: the same for people: "dropped in transfer", "put back with No.3", ...
        start, end: (2,) the way it went [m]: lifted at `start`, lost on the way to `end`
            (the box for a drop, the spot let go at for a put-back).
        before: (x, y) [m] of the unknown regions of the survey before the loss.
        laid: the job let it go itself along the way (a put-back, a shed): an unknown
            region seen before on that strip is no alibi, the cloth was laid over it.
        showed: for a double pick put back with its other cloth unnamed, the cloths whose
            own colours the look at what hung showed (`TableClearer._companion_seen_hanging`,
            at least `held_look.doubt_share`): one of them may be that cloth, seen or not.
        looked: that look was taken (without it, any cloth never seen may be that cloth).
        hid: the cloths of another box, never seen, that such a look could not show, their
            main colours all among the held cloth's (`held_look.hidden_in`): one of them
            may be that cloth, though none of its own colours showed.
        companion_of: for a cloth named as a double pick's other cloth and put back with it,
            the cloth that pick was meant for ("" otherwise).
    """

    kind: LossKind
    how: str
    start: FloatArray
    end: FloatArray
    before: tuple[tuple[float, float], ...]
    laid: bool = False
    showed: tuple[str, ...] = ()
    looked: bool = False
    hid: tuple[str, ...] = ()
    companion_of: str = ""


class ClearTableSettings(StrictModel):
    """How the table is cleared (the `clear` section). Lengths [m], times cell time [s].

    Attributes:
        max_picks: pick attempts in all before the job gives up.
        max_attempts: pick attempts per cloth, and one more (up to twice as many) whenever
            a cloth was placed since its last attempt (`TableLedger.untried`).
        same_place: the loop's recognition must find the cloth this close to where the
            survey saw it (else it found another cloth of that look, and stops).
        pick_depth_window: the pick's recogniser searches the cloth this far nearer or
            farther than the survey's depth, and tracks it this close to its one-shot
            depth (`AnchoredRecognizer`) [m]; None: the recogniser as it is.
        deeper_after_miss: after the fingers closed on nothing, the next attempt at that
            cloth grasps this much deeper (`loop.grasp_height` less this per miss) [m].
        weight_tolerance, weight_floor: after lifting, the wrist's load cell must read the
            cloth's own weight within this share plus this [kg]; more is a double pick,
            less a wrong cloth.
        heavy_tolerance, heavy_floor: ... but a lift reading more than the cloth's weight
            by this share plus this [kg] is a double pick (the check after the lift, of a
            surveyed or a blind lift, and a blind lift's weight read as several cloths);
            None: `weight_tolerance`, `weight_floor`. A cloth dragged partly off the table
            weighs only its hanging part: in the bench runs and replays of sessions 37-40
            (episodes 1042 and 1074-1183), 8 double picks read within 30 % + 3 g over
            (2.5-9.2 g), and of 671 lifts of one cloth alone 7 (1.0 %) read more than
            15 % + 2 g over, which 5 of the 8 did too.
        name_weight_margin: a cloth is named (a double pick's other cloth, or the one a
            wrong lift holds) only if it weighs what the load cell read (the extra, or all of
            it) within this [kg] too (`pick_checks.names_weight`): the largest error of the
            readings of 331 lifts of one cloth alone in the held-out runs 936-1033 was 6.8 g.
        nearer_margin: the load cell overrules the colours of a blind lift (a cloth of
            another box weighs nearer the reading than the meant one, `table_lost`'s
            `_weighs_more_like`) only when the reading lies at least this much [kg] nearer
            that cloth's weight than the meant one's. The readings of lifts of one cloth alone
            in sessions 36-41's runs erred by 2.0 g (standard deviation, 968 lifts); held-out
            1244 (session 41): No.18 (20.8 g) read 19.4 g, its colours fit 0.99 against No.19's
            0.70 (20.1 g, colours), and went back as "nearer No.19's" by 0.7 g: the last of
            its attempts, left on the table.
        companion_reach_px: a double pick's other cloth is looked for among the surveyed
            cloths whose footprint comes this close to the grasp point in the survey's
            image [px]; if exactly one weighs what the load cell read too much and it goes
            into the same box, both are placed.
        remembered_reach: when no cloth of the pick's survey is the double pick's other
            cloth, it is looked for among the cloths an earlier survey saw and this one did
            not (hidden since, e.g. under the target), whose footprint where last seen comes
            this close to the grasp point [m] and which the check after the lift no longer
            finds there; if exactly one weighs what the load cell read too much and it goes
            into the same box, both are placed (its identity then comes from memory, and
            the notes say so); 0: off.
        drag_extra: when the load cell reads at least this much [kg] over the meant
            cloth's weight but within `weight_tolerance`, the check after the lift also
            looks for the cloths the pick's survey saw touching the meant one (within
            `drag_reach`): one no longer where the survey saw it came along, a double pick
            (put back, booked as laid back with it); so did an unknown region of that survey
            touching it whose place the check sees bared (`moved.min_bared` of it, counted
            as an unnamed cloth that came along). A cloth dragged partly off the table
            hangs only in part from the held one, and the scale cannot tell its few grams
            from a lone lift's error (held-out 1124-1173, session 39: three undetected
            double picks read 4.8-9.2 g over, lone lifts up to 9.4 g); None: off (the
            default, and in configs/clear_table.yaml: on 12 held-out episodes, 1174-1185 in
            session 40, with `drag_look`, it caught none of the two double picks it could
            have, where the dragged cloth was part of a heap that stayed, and made two lone
            lifts double picks: neighbours out of the check's view or behind the held cloth
            were not found in their place).
        drag_reach: ... the cloths whose seen footprint comes this close to the meant
            cloth's [m].
        drag_look: ... and where the check sees none of those gone but some touched it,
            look at what hangs (`held_look`, as for a double pick's other cloth): a cloth
            showing `held_look.doubt_share` in its own colours came along. The check's
            view reaches some 0.15 m around the grasp, and the held cloth hides much of
            it (held-out 1159's dragged heap was out of view).
        put_down_height: TCP above the table when a lift that took too much (or the
            wrong cloth) is put back.
        put_down_speed: limit scale of the lowering.
        put_down_slide: ... which moves this far away from the middle of the view, to lay
            the cloths out rather than drop them in a heap [m].
        survey_latency: the arm waits this long for each survey and each check; None: as
            long as the loop's vision would take, `loop.vision_latency` per recognition
            (a survey recognises every model its colour prefilter keeps, a check is one),
            or, with `loop.vision_latency` null too, the measured computation (the
            process's CPU time, which a loaded machine does not inflate), as cell time.
        look_at_boxes: look into every box once before the first pick, from the pose of
            the checks after placing (the reference they compare with; ~5.4 s of sim per
            job for two boxes). Without it the first check takes the box to be empty, of
            the table's colour around it, which the realistic cell's box is not: its floor
            is lighter than the table and half in the walls' shadow, and an empty box read
            as 94-96 % changed (rendered, both boxes), so the cloth's colours fell under
            `min_model_share` of the change.
        boxes_when_needed: with `look_at_boxes`, the first survey's look goes only into
            the box the sort rule sends most of the known cloths to; every other box is
            looked into just before the first pick meant for it (a cloth picked by its
            survey, or a lost one picked blind), from where the arm is, which it returns
            to. A box no pick is meant for is never looked into: in the 50 held-out
            episodes 1074-1123 half had no white cloth, yet each job spent ~2.4 s of sim
            looking into whites and 1.4 s coming back from there.
        straight_from_box: a look into a box made for its reference (while a survey
            computes, or before a pick) stays over the box, and the pick goes straight from
            there over its cloth: the loop's search takes the survey's frame
            (`PickPlaceLoop.first_look`; nothing on the table moved since), instead of
            going back to the observation pose to look again. Episode 1516's first pick
            started 6.25 s into the job, after 1.5 s into colours and 1.5 s back, and 1.4 s
            into whites and 1.4 s back. Any other course (no cloth chosen) goes back first.
        box_view_height: camera above the box floor for that look and for the check
            after every release (the hand rises out of the box to it) [m]. At 0.48 the
            right image holds all four walls' tops of a 0.22 m box with 0.01 m walls 0.10
            m high (`box_check.rim_view`); at 0.42 (before session 43) the two walls across
            the image's height lay just outside it.
        rim_tries: after a release whose check sees a run of a wall's rim changed
            (`box_check.rim_covered` over `box_check.rim_run`: a cloth hangs over it), lay
            what lies on top in the box's middle (the first try) again this often
            (`box_rim.lay_again`); 0: off.
        rim_shift: ... releasing it this far from the middle away from that wall [m] (the
            open hand's half span, 5.1 cm, stays 3 cm off the walls at 0.03).
        rim_grasp_inset: the second and later tries take what lies this far inside that
            wall where the cloth crosses its rim (`box_rim.lay_again_point`) [m]; None:
            the box's middle, as the first.
        unnamed_wrong_lift: a wrong lift (the meant cloth still in its place) of a cloth
            that weighs as one not placed and that no look named is laid back booked
            unnamed (`TableLedger.unnamed`), as a double pick's unnamed other cloth: later
            surveys guess it among the cloths not placed and not seen at an unknown region
            there, picked blind and kept if it weighs right (`table_lost`).
        remembered_rival: a double pick's other cloth of the meant cloth's box is not named
            "under" or from memory while a cloth of another box that weighs the extra or
            less lay where the fingers closed when an earlier survey saw it (its footprint
            there within `remembered_reach` of the grasp) and the pick's survey did not see
            it: it may hang inside the held cloth, where no look sees it
            (`TableClearer._remembered_under_lift`).
        drop_box_check: when the gripper comes empty over the box, look into the box as
            after a release; a cloth seen there fell into its box on the way (placed, not
            lost).
        box_heap: measure from the check after every release how high the cloths in the
            box heap up (`box_contents.contents_top`, with `surface`'s settings: up to
            `surface.above`); the next release into it takes that top for the floor, so
            the hand does not press the released cloth into them (held-out 876, session 35:
            a release 5 cm into the heap of two placed cloths, and the two rose out of the
            box a second later, the simulator's contact in a heap pressed across).
        boxed_again: when a survey leaves nothing to pick and unknown regions, identify
            once more with the models of the cloths confirmed in their box too: one found
            on the table, at least this share of its seen part in those regions, was not
            what went in (a cloth of the same colours was: the box check cannot tell them
            apart) and is picked again; None: off.
        pile_grasp: where on the chosen cloth to grasp (away from the other cloths).
        put_back: how a rejected lift is laid back onto the table.
        look_around: when a survey leaves nothing to pick, look again from up to this
            many other poses (the cameras at the observation height over a put-back
            spot, an unknown region, a cloth seen before and not put away) before the
            job stops; counted anew after every pick attempt.
        look_apart: places to look at closer together than this are one [m].
        hidden_cloth_radius: after a double pick is put back, the other cloth lies under
            the spot where the pair was let go (both hung from the fingers), where the
            meant cloth may hide it from every survey: the next grasps of the meant cloth
            keep away from a disk of this radius there, as from a cloth the survey saw
            [m]; 0: off (the default: on bench episode 22 it moved three grasps and the
            cloth still came up with the other each time; unproven, not in use).
        lost: picking a cloth the job lost (dropped, laid back) and no survey recognised
            since, by an unknown region in its colours and its weight (`table_lost`).
        surface: the grasp aimed at the top surface the survey's pair shows at the grasp
            point (`table_surface`), not at the pose's plane (low on a pile).
        layers: the grasp kept off where the pair shows the target lying over another
            cloth (`table_layers`).
        off_sheet: the bare table beyond the green sheet taken out of the unknown regions.
        moved: an unknown region a placed pick moved (the sheet bared where it lay), booked
            as a cloth that came along unnamed (`table_moved`).
        held_look: the lifted cloth looked at against table the survey saw free
            (`held_look`): a blind lift that could hold a hidden cloth of another box, and a
            double pick's other cloth nobody named.
    """

    max_picks: int = Field(15, ge=1)
    max_attempts: int = Field(4, ge=1)
    same_place: float = Field(0.05, gt=0.0)
    pick_depth_window: float | None = Field(0.015, gt=0.0)
    deeper_after_miss: float = Field(0.01, ge=0.0, le=0.05)
    weight_tolerance: float = Field(0.3, ge=0.0, le=2.0)
    weight_floor: float = Field(0.003, ge=0.0)
    name_weight_margin: float = Field(0.007, ge=0.0)
    nearer_margin: float = Field(0.0015, ge=0.0)
    heavy_tolerance: float | None = Field(None, ge=0.0, le=2.0)
    heavy_floor: float | None = Field(None, ge=0.0)
    drag_extra: float | None = Field(None, gt=0.0)
    drag_reach: float = Field(0.02, ge=0.0)
    drag_look: bool = False
    put_down_height: float = Field(0.05, gt=0.02)
    put_down_speed: float = Field(0.3, gt=0.0, le=1.0)
    put_down_slide: float = Field(0.06, ge=0.0, le=0.2)
    companion_reach_px: float = Field(20.0, ge=0.0)
    remembered_reach: float = Field(0.04, ge=0.0, le=0.3)
    survey_latency: float | None = Field(None, ge=0.0)
    look_at_boxes: bool = True
    boxes_when_needed: bool = False
    straight_from_box: bool = False
    box_view_height: float = Field(0.48, gt=0.1)
    rim_tries: int = Field(1, ge=0, le=5)
    rim_shift: float = Field(0.03, ge=0.0, le=0.05)
    rim_grasp_inset: float | None = Field(None, ge=0.0, le=0.11)
    unnamed_wrong_lift: bool = False
    remembered_rival: bool = False
    drop_box_check: bool = True
    box_heap: bool = True
    boxed_again: float | None = Field(0.5, gt=0.0, le=1.0)
    pile_grasp: PileGraspSettings = Field(default_factory=PileGraspSettings)
    surface: SurfaceSettings = Field(default_factory=SurfaceSettings)
    layers: LayerSettings = Field(default_factory=LayerSettings)
    put_back: PutBackSettings = Field(default_factory=PutBackSettings)
    look_around: int = Field(2, ge=0, le=10)
    look_apart: float = Field(0.08, gt=0.0)
    hidden_cloth_radius: float = Field(0.0, ge=0.0, le=0.3)
    lost: LostSettings = Field(default_factory=LostSettings)
    off_sheet: OffSheetSettings = Field(default_factory=OffSheetSettings)
    moved: MovedSettings = Field(default_factory=MovedSettings)
    held_look: HeldLookSettings = Field(default_factory=HeldLookSettings)


@dataclass(frozen=True)
class BoxPlace:
    """A collection box as the job knows it.

    Attributes:
        name: what the sort rule calls it.
        centre: (3,) centre of its floor in Σ_W [m].
        inner_size: inner side [m].
        wall_height: its walls' height above the table [m] (0: only its floor is known).
        wall_thickness: [m].
    """

    name: str
    centre: FloatArray
    inner_size: float
    wall_height: float = 0.0
    wall_thickness: float = 0.0

    @property
    def outer_half(self) -> float:
        """Half its outer side: from its centre to the walls' outer faces [m]."""
        return self.inner_size / 2 + self.wall_thickness


class ClothOutcome(StrEnum):
    """What became of one cloth the robot identified."""

    PLACED = "placed"  # put into its box and seen there
    PLACED_UNSEEN = "placed_unseen"  # released over its box, the look inside did not confirm it
    FAILED = "failed"  # attempts used up
    LEFT = "left"  # identified, never picked (the job stopped first)


@dataclass(frozen=True)
class PickAttempt:
    """One run of the pick-and-place loop for one cloth.

    Attributes:
        name: the cloth meant (model name); after a wrong lift named by its colours
            seen hanging (`AttemptState.held_instead`), the cloth it held.
        box: the box it was meant for.
        start_time, end_time: cell time [s].
        result: the loop's result.
        lift_check: the check after lifting: "" (no lift), "ok", "double" (heavier than
            the cloth: another came along), "wrong" (lighter than it, or the meant cloth
            still seen in its place).
        came_along: the other cloth of a double pick placed with it (same box).
        weighed: the load cell's reading after lifting [kg] (None: not weighed).
        expected_weight: the meant cloth's weight [kg] (None: unknown).
        put_back: the lift was lowered back onto the table.
        dropped: the cloth was found gone from the gripper at the end of the transfer.
        box_check: the look into the box after releasing, or after the gripper came empty
            over it (None: not looked).
        check_wall_s: computation time of the checks [s].
        grasp_clearance: the job's grasp point's distance to the nearest other cloth the
            survey saw [m] (None: the loop's own grasp point; inf: no other cloth).
        remembered: of `came_along`, the cloths named from an earlier survey (the pick's
            own survey did not see them), not from vision at the lift.
        named_by: how a double pick's other cloth was named ("grasp": the one surveyed
            cloth under the grasp point that weighs the extra and is gone from its place;
            "under": the one cloth the target lay on that weighs the extra, gone; "memory";
            "look": its own colours seen hanging, `held_look`; "": not named).
        laid_back_too: the named other cloth of a double pick put back with it (another box).
    """

    name: str
    box: str
    start_time: float
    end_time: float
    result: EpisodeResult
    came_along: tuple[str, ...] = ()
    lift_check: str = ""
    weighed: float | None = None
    expected_weight: float | None = None
    put_back: bool = False
    dropped: bool = False
    box_check: BoxCheck | None = None
    check_wall_s: float = 0.0
    grasp_clearance: float | None = None
    remembered: tuple[str, ...] = ()
    named_by: str = ""
    laid_back_too: tuple[str, ...] = ()

    @property
    def not_meant_alone(self) -> bool:
        """The robot found that more than, or other than, the meant cloth left the table."""
        return self.lift_check in ("double", "wrong")


@dataclass(frozen=True)
class ClothRecord:
    """One cloth the robot identified, as it ended.

    Attributes:
        name: model name; box: its box by the sort rule.
        order: 1 for the first cloth put away, ... (None: not put away).
        attempts: pick attempts; sim_time: cell time of those attempts [s].
        outcome: see `ClothOutcome`; notes: what happened on the way.
    """

    name: str
    box: str
    order: int | None
    attempts: int
    sim_time: float
    outcome: ClothOutcome
    notes: tuple[str, ...] = ()


@dataclass(frozen=True)
class SurveyRecord:
    """One survey: when, how long it computed, what it saw.

    Attributes:
        time: cell time of the capture [s]; wall_s: its computation [s].
        detections: (name, confidence, x, y, z) of each detection, world frame [m].
        dropped: (model, region's model) candidates of a region already taken.
        above: (upper, lower) pairs.
        unknown: (x, y) on the table of each unknown region's centre [m].
        chosen: the cloth picked next (None: nothing left to pick).
    """

    time: float
    wall_s: float
    detections: tuple[tuple[str, float, float, float, float], ...]
    dropped: tuple[tuple[str, str], ...]
    above: tuple[tuple[str, str], ...]
    unknown: tuple[tuple[float, float], ...]
    chosen: str | None


@dataclass(frozen=True)
class TableResult:
    """Everything the job did and measured (the robot's view; the simulator judges elsewhere).

    Attributes:
        cloths: one record per identified cloth, in the order first identified.
        attempts: every pick attempt in order.
        surveys: every survey in order.
        stop_reason: why the job stopped.
        cleared: the robot's own verdict: every cloth it identified is placed, and the
            last survey found no known cloth.
        unknown: (x, y) [m] of the regions the last survey could not identify (left alone).
        limit_report: every commanded sample of the whole job.
        collisions: arm contacts with the table or a box (checks of loop and job).
        sim_time: cell time of the job [s]; wall_s: its wall time [s].
        interrupted: the user stopped it.
        moved_by: numbers (from 1) of the placed attempts after which the next survey saw
            that the pick had moved a cloth nobody identified (`table_moved`).
        left: known cloth not placed -> notes on the unknown regions left at the end that
            show its colours (`table_left.left_notes`; identified or not).
    """

    cloths: tuple[ClothRecord, ...]
    attempts: tuple[PickAttempt, ...]
    surveys: tuple[SurveyRecord, ...]
    stop_reason: str
    cleared: bool
    unknown: tuple[tuple[float, float], ...]
    limit_report: LimitReport
    collisions: int
    sim_time: float
    wall_s: float
    interrupted: bool = False
    notes: tuple[str, ...] = field(default=())
    moved_by: tuple[int, ...] = ()
    left: Mapping[str, tuple[str, ...]] = field(default_factory=dict)

    @property
    def placed(self) -> tuple[str, ...]:
        return tuple(
            c.name for c in self.cloths if c.outcome in (ClothOutcome.PLACED, ClothOutcome.PLACED_UNSEEN)
        )

    def median_time_per_cloth(self) -> float | None:
        """Median cell time per put-away cloth over its attempts [s] (None: none put away)."""
        times = [c.sim_time for c in self.cloths if c.order is not None]
        return float(np.median(times)) if times else None


__all__ = [
    "BoxPlace",
    "ClearTableSettings",
    "ClothOutcome",
    "ClothRecord",
    "LostPlace",
    "LostSettings",
    "PickAttempt",
    "SurveyRecord",
    "TableResult",
]
