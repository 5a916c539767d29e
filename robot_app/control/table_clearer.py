"""Clearing a table of several known cloths, each into its box, every step verified.

`TableClearer.run` repeats until no known cloth is left to pick:

1. **survey** from the observation pose: every known model not yet seen in its box is
   recognised in one stereo pair and the recognitions are compared region by region
   (`vision.identify`): which cloths lie where, which lies on which, what no model
   explains (unknown: left alone, reported);
2. **order**: the most confident cloth nothing lies on (`Identification.preferred`);
3. **pick** it with a `PickPlaceLoop` built for its model and its box (the sort rule).
   The loop's own search must find it where the survey saw it (else it found a look-alike
   elsewhere and stops). The job watches the loop through its callbacks and verifies:
   - after LIFT: the meant cloth left its place (`Recognizer.check` at the surveyed pose
     no longer finds it) and nothing else came with it: the wrist's load cell reads the
     cloth's own weight (weighed when its model photo was taken). Heavier is a double
     pick, lighter or still in its place a wrong one: the lift is lowered back onto the
     table and the attempt ends (`Outcome.GRASP_FAILED`, reason "put back"). The hand
     cameras cannot tell which other cloth hangs from the gripper (the bundle fills the
     middle of both images), so a double pick is always put back;
   - after TRANSFER: the gripper still carries it (else it was dropped: the attempt ends,
     `Outcome.LOST`, and the next survey finds it again);
   - after RELEASE: the box's inside, seen from straight above it (the hand rises out
     of the box first), changed with the cloth's colours since the last look
     (`box_check`); the loop goes home from there;
4. **re-survey** (the pile changed) and go on.

The job acts on what the robot senses only; `ground_truth` (simulation) goes into the
loop's logs of pose errors and nowhere else. The loop is used through its constructor,
`run()` and its callbacks; an `EpisodeAbortError` raised in a callback ends its episode
the way the loop's own aborts do (release, back to the observation pose).
"""

from __future__ import annotations

import time
from collections import Counter
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray
from robot_app.control.box_check import (
    BoxCheckSettings,
    BoxView,
    RimView,
    box_view,
    look_tcp,
    rim_runs,
    rim_view,
)
from robot_app.control.box_contents import contents_top
from robot_app.control.box_rim import lay_again, over_wall_note
from robot_app.control.cell import Cell, StereoCapture
from robot_app.control.clear_table_records import (
    BoxPlace,
    ClearTableSettings,
    LossKind,
    LostPlace,
    SurveyRecord,
    TableArea,
    TableResult,
)
from robot_app.control.colour_fit import colour_shares
from robot_app.control.episode import (
    EpisodeAbortError,
    EpisodeResult,
    Outcome,
    PhaseRecord,
    Strategy,
    VisionCycle,
)
from robot_app.control.grasp_point import points_in_mask
from robot_app.control.held_look import hidden_in, look_at_held
from robot_app.control.intercept import hanging_reach
from robot_app.control.job_motion import JobMotion
from robot_app.control.kinematics import Kinematics
from robot_app.control.limits import JointLimits
from robot_app.control.logged_cell import LoggedCell
from robot_app.control.loop_settings import LoopSettings
from robot_app.control.pick_checks import (
    DROPPED,
    FELL_INTO_BOX,
    PUT_BACK,
    AttemptState,
    check_release,
    cloths_in_extra,
    comes_within,
    companion,
    could_be_in,
    fell_on_the_way,
    footprints_touch,
    names_weight,
    remembered_companion,
    still_there,
    weighs_extra,
    weight_verdict,
)
from robot_app.control.pick_handover import check_found_in_place, grasp_in_model, pick_recognizer, pile_grasp
from robot_app.control.pick_place import LIFTED, PickPlaceLoop, observation_posture
from robot_app.control.pose_filter import PoseFilterSettings
from robot_app.control.sort_rule import SortSettings
from robot_app.control.table_furniture import (
    clear_of_walls,
    furniture_mask,
    graspable,
    table_beyond_sheet,
    without_furniture,
)
from robot_app.control.table_layers import layer_map
from robot_app.control.table_ledger import TableLedger
from robot_app.control.table_left import left_notes
from robot_app.control.table_lost import (
    LostMatch,
    away_from,
    colour_patches,
    match_heap,
    match_lost,
    near_the_loss,
    off_way,
    pick_lost,
)
from robot_app.control.table_moved import bared_from_elsewhere, grown, moved_regions
from robot_app.control.table_recovery import TableRecovery
from robot_app.control.table_surface import aimed_at, surface_height
from robot_app.control.table_survey import (
    TablePlane,
    choose_target,
    disk_points,
    obstacles_on_table,
    to_world,
)
from robot_app.errors import IKError, InterruptError, TrajectoryError
from robot_app.geometry import transform_points
from robot_app.vision import Recognizer
from robot_app.vision.identify import (
    Detection,
    Identification,
    IdentifySettings,
    UnknownRegion,
    identify,
    without,
)
from robot_app.vision.regions import DARK, Mask, footprint, main_codes, sheet_mask, undistorted


@dataclass(frozen=True)
class _BeforePick:
    """What the survey that chose a pick saw, for `TableClearer._notice_moved`."""

    name: str
    regions: tuple[UnknownRegion, ...]
    footprint: npt.NDArray[np.bool_]
    camera_pose: FloatArray
    box_xy: FloatArray
    capture: StereoCapture


STILL_IN_PLACE = "seen from where the hand looked, it still lies where the survey saw it"


def _any_of(names: Sequence[str]) -> str:
    """`names` for a note: "No.2 or No.17", or "one of 17 cloths (No.1, No.2, No.3, ...)"."""
    if len(names) <= 3:
        return " or ".join(names)
    return f"one of {len(names)} cloths ({', '.join(names[:3])}, ...)"


class TableClearer:
    """The clear-table job on one cell.

    Args:
        cell: the robot cell (wrapped in a `LoggedCell` here).
        kinematics: the arm, poses in Σ_W.
        recognizers: model name -> recogniser, every cloth the robot knows.
        limits: joint limits of every commanded sample.
        observation_camera_pose: (4, 4) the right camera's pose in Σ_W where the job
            surveys (the joints come from the controller's IK, `observation_posture`).
        boxes: the cell's collection boxes.
        sort: cloth -> box name.
        table_z: height of the table top [m].
        settings, identify_settings, loop_settings, filter_settings, box_settings: see
            each class.
        on_phase: called with each loop phase and the cloth it is for.
        on_step: called after every control step with the phase name ("survey", "put
            back", a loop phase, ...) and the cloth meant (or None).
        on_recognition: called with each of the loop's vision cycles and the cloth meant.
        on_survey: called with each survey's record.
        ground_truth: model name -> its true pose in Σ_W now (simulation; for the loop's
            error logs only), or None.
        weigh: the wrist load cell: what the gripper carries now [kg] (None: no weight check).
        weights: model name -> the cloth's weight [kg], weighed with its model photo.
        posture_seed: joints [rad] the observation IK starts from (e.g. the arm's home).
        sheet: the green sheet's extent on the table (None: unknown, the table beyond it
            is not told from cloths; `ClearTableSettings.off_sheet`).
        table_top: the table top's extent (None: unknown; a blind grasp of a lost cloth
            then may aim past its edge, `LostSettings.edge_inset`).

    Raises:
        IKError: the observation pose has no IK solution within the joint limits.
    """

    def __init__(
        self,
        cell: Cell,
        kinematics: Kinematics,
        recognizers: Mapping[str, Recognizer],
        limits: JointLimits,
        observation_camera_pose: npt.ArrayLike,
        boxes: tuple[BoxPlace, ...],
        sort: SortSettings,
        table_z: float,
        settings: ClearTableSettings | None = None,
        identify_settings: IdentifySettings | None = None,
        loop_settings: LoopSettings | None = None,
        filter_settings: PoseFilterSettings | None = None,
        box_settings: BoxCheckSettings | None = None,
        *,
        on_phase: Callable[[PhaseRecord, str], None] | None = None,
        on_step: Callable[[str, str | None], None] | None = None,
        on_recognition: Callable[[VisionCycle, str], None] | None = None,
        on_survey: Callable[[SurveyRecord], None] | None = None,
        ground_truth: Callable[[str], Callable[[], FloatArray] | None] | None = None,
        weigh: Callable[[], float] | None = None,
        weights: Mapping[str, float] | None = None,
        posture_seed: npt.ArrayLike | None = None,
        sheet: TableArea | None = None,
        table_top: TableArea | None = None,
    ) -> None:
        if not recognizers:
            raise ValueError("the job needs at least one known cloth")
        sort.check_boxes(tuple(b.name for b in boxes))
        self.cell = LoggedCell(cell)
        self.kinematics = kinematics
        self.recognizers = dict(recognizers)
        self.limits = limits
        self.loop_settings = loop_settings or LoopSettings()
        self.observation_camera_pose = np.array(observation_camera_pose, dtype=float).reshape(4, 4)
        self.observation_joints = observation_posture(
            kinematics, limits, self.observation_camera_pose, posture_seed, self.loop_settings.ik_tolerance
        )
        self.boxes = {b.name: b for b in boxes}
        self.sort = sort
        self.table_z = float(table_z)
        self.settings = settings or ClearTableSettings()
        self.identify_settings = identify_settings or IdentifySettings()
        self.filter_settings = filter_settings
        self.box_settings = box_settings or BoxCheckSettings()
        self.on_phase = on_phase
        self.on_step = on_step
        self.on_recognition = on_recognition
        self.on_survey = on_survey
        self.ground_truth = ground_truth
        self.weigh = weigh
        self.weights = dict(weights or {})
        self.sheet = sheet
        self.table_top = table_top
        self.rig = next(iter(self.recognizers.values())).rig
        self.table = TablePlane(self.rig.right.camera_matrix, self.table_z)
        self._phase: str = "survey"
        self._meant: str | None = None
        self.motion = JobMotion(
            self.cell,
            kinematics,
            limits,
            self.observation_joints,
            on_step=lambda: self._step(),
            ik_time_budget=5 * self.loop_settings.ik_time_budget,
        )
        self.recovery = TableRecovery(
            self.motion,
            self.cell,
            self.table,
            self.rig.right,
            self.settings,
            self.loop_settings,
            table_top=table_top,
            boxes=boxes,
            sheet=sheet,
        )

    # ------------------------------------------------------------------ job
    def run(self) -> TableResult:
        """Clears the table; never raises for a failed pick. A stop the user asked for
        (`InterruptError` from `on_step`) ends the job where it is, `interrupted`."""
        wall_start, start = time.perf_counter(), self.cell.time
        self.start()
        interrupted, stop_reason = False, ""
        last: Identification | None = None
        try:
            self.cell.set_gripper(self.loop_settings.gripper_open)
            # the first survey's image is taken before the look into the boxes, which is made
            # while the computer identifies the cloths in it (the arm is free meanwhile)
            boxes_first: Callable[[], None] | None = (
                (lambda: self._look_at_boxes(self._first_boxes(), stay=self.settings.straight_from_box))
                if self.settings.look_at_boxes
                else None
            )
            while True:
                self._looked_left.clear()  # this round's looks' regions (`_from_observation`)
                self._back_to_observation()
                last = self._survey(meanwhile=boxes_first if last is None else self._boxes_ahead(last))
                self._notice_moved()
                target = choose_target(last, self.ledger.records, self.untried)
                if target is None:  # the rules below look and survey from the observation pose
                    self._back_to_observation()
                looked, lost = False, None
                for place in self._places_to_look(last) if target is None else ():
                    self._record_survey(last, None)
                    if not self._look_from(place):
                        continue
                    looked = True
                    last = self._survey()
                    target = choose_target(last, self.ledger.records, self.untried)
                    lost = self._lost_to_pick(last) if target is None else None
                    if target is None and lost is None:
                        last, lost = self._weak_lost_to_pick(last)
                    if target is not None or lost is not None:
                        break
                else:
                    if looked:  # the looks found nothing: the rules below read the whole table
                        last, target = self._from_observation(last)
                    lost = self._lost_to_pick(last) if target is None else None
                if target is None and lost is None:
                    last, target = self._boxed_again(last)
                if target is None and lost is None:
                    weak = self._unconfirmed_as_unknown(last)
                    if self._book_hidden(weak) or weak is not last:
                        lost = self._lost_to_pick(weak)
                    last = weak
                if lost is not None and len(self.ledger.attempts) < self.settings.max_picks:
                    self._record_survey(last, None)
                    pick_lost(self, lost)
                    continue
                self._record_survey(last, target)
                if target is None:
                    stop_reason = (
                        "no known cloth left to pick"
                        if not last.detections
                        else ("every cloth still seen has used its attempts")
                    )
                    break
                if len(self.ledger.attempts) >= self.settings.max_picks:
                    stop_reason = f"{self.settings.max_picks} pick attempts used"
                    break
                if self._pick(target, last):
                    interrupted, stop_reason = True, "interrupted"
                    break
        except InterruptError:
            interrupted, stop_reason = True, "interrupted"
        except (IKError, TrajectoryError) as err:
            stop_reason = f"the job's own motion failed: {err}"
        return self._result(last, stop_reason, interrupted, start, wall_start)

    def _from_observation(self, last: Identification) -> tuple[Identification, Detection | None]:
        """After looks from other poses that found nothing to pick: books the last look's
        survey, surveys again from the observation pose and returns that survey and the
        cloth it chooses. The rules that follow (a lost cloth picked blind, the boxed cloths
        looked for again, hidden ones booked) read the survey they are given, and the last
        look may not see the table's regions at all: held-out episode 814 (session 34), No.19
        dropped in transfer lay as an unknown region the observation survey saw; the two
        looks around saw nothing, and the job stopped with it on the table."""
        if last.unknown:  # what the last look saw, for the results should the job stop
            self._looked_left.update(self._left(last, "seen by the last look around"))
        self._record_survey(last, None)
        self._back_to_observation()
        again = self._survey()
        return again, choose_target(again, self.ledger.records, self.untried)

    def _book_hidden(self, last: Identification) -> bool:
        """With no cloth to pick and unknown regions left, the cloths a survey saw that none
        sees now (not placed, not lost, attempts left) are booked lost where they were seen
        (`TableLedger.hide`), so that the lost-cloth rules may find them in those regions by
        their colours and weight. Held-out episode 626 (session 31): No.14, No.19 and No.13,
        seen by the first surveys, crumpled into one heap after No.5 was lifted off them,
        and the job stopped with it an unknown region. Whether any was booked."""
        if not last.unknown or not self.settings.lost.enabled:
            return False
        seen = {d.name for d in last.detections}
        return bool(self.ledger.hide(lambda name: name not in seen and self.untried(name)))

    def tones_only(self, name: str) -> bool:
        """Are all of cloth `name`'s main colours tones (white, grey, black: no hue)? Such
        a cloth's tone moves with the light and the exposure, so a colour fit cannot tell two
        of them apart."""
        return bool(np.all(main_codes(self.recognizers[name].model) >= DARK))

    def hanging_reach(self, name: str) -> float:
        """How far cloth `name` hangs below where it is held [m] (`intercept.hanging_reach`
        from its grasp point), the reach a cloth hanging from a held one adds to it."""
        model = self.recognizers[name].model
        return hanging_reach(model.points_in, model.grasp_point)

    def untried(self, name: str) -> bool:
        """Has `name` attempts left (`TableLedger.untried`)?"""
        return self.ledger.untried(name, self.settings.max_attempts)

    def start(self) -> None:
        """A fresh job's books: nothing picked, laid back or looked at yet."""
        self.ledger = TableLedger()
        self._views: dict[str, BoxView | None] = dict.fromkeys(self.boxes)
        self._rims: dict[str, RimView] = {}  # box -> its rim at the last look from the check's pose
        self._collisions = 0
        self._hidden_spots: dict[str, FloatArray] = {}  # cloth -> (x, y) an unseen cloth lies at [m]
        self._laid: list[tuple[AttemptState, FloatArray, FloatArray]] = []  # put-backs: (start, let-go)
        self._box_heaps: dict[str, float] = {}  # box -> its heap's top over the floor [m]
        self._looked_into: set[str] = set()  # boxes looked into for their reference view
        self._looked_left: dict[str, tuple[str, ...]] = {}  # regions the last looks saw, per cloth
        self._before_pick: _BeforePick | None = None
        self.recovery.forget()
        self._survey_camera_pose = self.observation_camera_pose.copy()
        self._survey_joints = self.observation_joints.copy()  # where the last survey was taken

    # ------------------------------------------------------------------ survey
    def first_survey(self) -> Identification:
        """A fresh job's first survey from the observation pose, and nothing else
        (`experiments.first_survey`, `scripts/bench_survey.py`)."""
        self.start()
        self._back_to_observation()
        return self._survey()

    def _survey(self, meanwhile: Callable[[], None] | None = None, boxed: bool = False) -> Identification:
        """Surveys from where the arm is; `meanwhile` moves the arm while the computer
        identifies (the job goes on from where it ends: over a box with
        `clear.straight_from_box`, and `run` brings it back unless a pick follows); `boxed`:
        with the models of the cloths seen in their box too."""
        self._phase, self._meant = "survey", None
        capture = self.cell.capture()
        self._survey_joints = self.motion.q.copy()
        at_observation = np.allclose(self.motion.q, self.observation_joints, atol=1e-6)
        self._survey_camera_pose = (
            self.observation_camera_pose
            if at_observation
            else self.kinematics.frame_pose(self.motion.q, "camera_right_optical")
        )
        names = [n for n in self.recognizers if boxed or n not in self.ledger.seen_in_box]
        wall, cpu = time.perf_counter(), time.process_time()
        ident = (
            identify(
                {n: self.recognizers[n] for n in names},
                capture.left_bgr,
                capture.right_bgr,
                self.identify_settings,
                seed=len(self.ledger.surveys),
            )
            if names
            else Identification((), (), (), (), {})
        )
        ident = self._without_furniture(ident, capture)
        self._survey_capture, self._survey_wall = capture, time.perf_counter() - wall
        recognitions = len(names) - len(ident.skipped) + len(ident.searched_again)
        self._wait(time.process_time() - cpu, recognitions, meanwhile)
        self._phase = "survey"
        return ident

    def _without_furniture(self, ident: Identification, capture: StereoCapture) -> Identification:
        """`ident` with the boxes (foreground no cloth model explains: known furniture, not a
        cloth) and the bare table beyond the green sheet (`off_sheet`: a cloth across its
        edge) taken out of its unknown regions."""
        if not ident.unknown:
            return ident
        furniture = furniture_mask(capture, self.rig.right, self.boxes.values(), ident.unknown[0].mask.shape)
        if self.sheet is not None and self.settings.off_sheet.enabled:
            furniture |= table_beyond_sheet(
                capture, self.rig.right, self.table, self.sheet, self.settings.off_sheet, furniture
            )
        smallest = self.identify_settings.min_unknown_area * furniture.size
        return replace(ident, unknown=without_furniture(ident.unknown, furniture, smallest))

    def _boxed_again(self, ident: Identification) -> tuple[Identification, Detection | None]:
        """With nothing left to pick and unknown regions: surveys again with the models of
        the cloths seen in their box too (`clear.boxed_again`). One found on the table, its
        seen part mostly in those regions, is not in its box (another cloth of its colours
        went in: the box check cannot tell them apart) and is picked again. Held-out episode
        768 (session 33): the grasp meant for No.13 lifted No.14 (same hue, lying on it,
        never seen), which went into colours and was seen there as No.13; No.13 stayed an
        unknown region on the table where the first survey had seen it at 1.00, and the job
        stopped. Returns the new survey (the other boxed cloths' detections taken out) and the
        cloth it chooses."""
        boxed = self.ledger.seen_in_box
        share = self.settings.boxed_again
        if share is None or not ident.unknown or not boxed:
            return ident, None
        self._record_survey(ident, None)
        again = self._survey(boxed=True)
        unknown = np.zeros(ident.unknown[0].mask.shape, bool)
        for region in ident.unknown:
            unknown |= region.mask
        back = [
            d.name
            for d in again.detections
            if d.name in boxed
            and d.found
            and np.count_nonzero(d.explained & unknown) >= share * max(int(np.count_nonzero(d.explained)), 1)
        ]
        gone = [d.name for d in again.detections if d.name in boxed and d.name not in back]
        if gone:  # still taken to be in their box: their pixels stay unknown
            again = without(again, gone, self._survey_sheet(), self.identify_settings)
            again = self._without_furniture(again, self._survey_capture)
        if not back:
            return again, None
        how = f"seen in its box, yet found on the table by survey {len(self.ledger.surveys) + 1}"
        for name in back:
            self.ledger.reopen(name, f"{how}: another cloth of its colours went in")
        return again, choose_target(again, self.ledger.records, self.untried)

    def _unconfirmed_as_unknown(self, ident: Identification) -> Identification:
        """With nothing left to pick: `ident` with the candidates the loop's search could not
        confirm (`choose_target`'s unconfirmed ones, attempts left) taken out, their pixels
        unknown regions again, so that the lost-cloth rules may pick them blind by their
        colours and weight (`_book_hidden`). A cloth laid back crumpled shows as a weak
        candidate the loop never finds: held-out episode 730 (session 32): No.11, put back
        with No.13, seen at 0.35 and 0.22, not found by the loop's three searches, and the
        job stopped with it on the table after one attempt."""
        if not self.settings.lost.enabled:
            return ident
        records = self.ledger.records
        names = [
            d.name
            for d in ident.detections
            if not d.found and records.get(d.name, {}).get("unconfirmed") and self.untried(d.name)
        ]
        if not names:
            return ident
        unknown = without(ident, names, self._survey_sheet(), self.identify_settings)
        return self._without_furniture(unknown, self._survey_capture)

    def _weak_lost_to_pick(self, ident: Identification) -> tuple[Identification, LostMatch | None]:
        """After a look around chose nothing: its weak candidates the loop could not confirm
        taken as unknown regions (`_unconfirmed_as_unknown`) for the lost-cloth rules; returns
        the look's survey so changed and the lost cloth to pick there, or `ident` unchanged
        and None.
        A weak detection is no sighting: taken as one, it kept the cloth from the rules
        (`_lost_to_pick` passes over the cloths a survey sees) and, booked, from being lost
        (`TableLedger.record_survey`). Held-out episode 1704 (session 48): No.8, dropped off
        the green sheet on the way to its box, seen by a look around at 0.39, not found by
        the pick's searches, seen again at 0.37, and left on the table with attempts left."""
        weak = self._unconfirmed_as_unknown(ident)
        if weak is ident:
            return ident, None
        lost = self._lost_to_pick(weak)
        return (weak, lost) if lost is not None else (ident, None)

    def _survey_sheet(self) -> Mask:
        """The last survey's right-image pixels of the green sheet (undistorted, as
        `identify` reads them)."""
        return self._sheet(self._survey_capture)

    def _sheet(self, capture: StereoCapture) -> Mask:
        """`capture`'s right-image pixels of the green sheet (undistorted)."""
        first = next(iter(self.recognizers.values()))
        image = undistorted(capture.right_bgr, self.rig.right)
        i = self.identify_settings
        return sheet_mask(image, first.model.background_hue, i.sheet_tolerance, i.sheet_min_saturation)

    def _notice_moved(self) -> None:
        """After a placed pick, from the same camera pose as the survey that chose it: the
        unknown regions of that survey the pick moved (`table_moved`) are booked as cloths
        that came along unnamed, to be named by their colours and weight later; a region in
        the colours of a cloth the job lost and named (`match_lost`, as a blind pick would
        take it) is that cloth, moved: its loss now runs from there to the box. Held-out
        episode 744 (session 33): the put-back heap of No.7 moved with No.9's pick, was booked
        an unnamed cloth, and a guess of it, No.6 of whites, absent from the table, took five
        blind lifts of that heap and kept No.20's lifts from going into colours (a colour fit
        within the margin of No.6's). Of the cloths the held-out runs 415-744 named at such
        unnamed places, 23 were absent from the table (3 of them placed: other cloths under
        their names, 703's into the wrong box), 15 present."""
        before, self._before_pick = self._before_pick, None
        s = self.settings.moved
        if before is None or not s.enabled or not before.regions or not self.ledger.attempts:
            return
        attempt = self.ledger.attempts[-1]
        if attempt.result.outcome is not Outcome.PLACED or attempt.put_back or attempt.name != before.name:
            return  # (the lift held another cloth than the one meant: a region it left is that cloth)
        if not np.allclose(before.camera_pose, self._survey_camera_pose, atol=1e-6):
            return  # another view: its pixels are not the same places
        moved = moved_regions(before.regions, before.footprint, self._survey_sheet(), s)
        if not moved:
            return
        capture = self._survey_capture
        centres = {id(r): np.array(self.table.point(capture, r.centroid)) for r in before.regions}
        notes: list[str] = self.ledger.records[before.name]["notes"]  # type: ignore[assignment]
        self.ledger.moved_by.append(len(self.ledger.attempts))
        placed = set(self.ledger.placed_order)
        lost = {n: self.recognizers[n] for n in self.ledger.lost if n in self.recognizers and n not in placed}
        places = {n: self.ledger.lost[n] for n in lost}
        how = f"moved by the pick of {before.name}"
        for m in moved:
            centre = centres[id(m.region)]
            others = tuple((float(c[0]), float(c[1])) for key, c in centres.items() if key != id(m.region))
            where = LostPlace(LossKind.MOVED, how, centre, before.box_xy, others)
            named = match_lost(
                before.capture, (m.region,), [centre], lost, places, self.settings.lost, self.sort.box_for
            )
            at = f"the unknown region at ({centre[0]:.2f}, {centre[1]:.2f})"
            if named is not None:
                for name in (named.name, *named.alike):
                    self.ledger.lost[name] = replace(where, how=f"{how} ({places[name].how} before)")
                notes.append(
                    f"the pick moved {' or '.join((named.name, *named.alike))} (lost, {at} in its colours: "
                    f"the sheet shows at {m.bared:.0%} of it)"
                )
                continue
            self.ledger.unnamed.append(where)
            notes.append(
                f"the pick moved an unidentified cloth: the sheet shows at {m.bared:.0%} of {at} "
                "(came along, held by nothing)"
            )

    def _record_survey(self, ident: Identification, chosen: Detection | None) -> None:
        record = self.ledger.record_survey(self._survey_capture, self._survey_wall, ident, chosen, self.table)
        if self.on_survey is not None:
            self.on_survey(record)

    # ------------------------------------------------------------------ pick
    def _pick(self, target: Detection, ident: Identification) -> bool:
        """One loop run for `target`; True if the user stopped it."""
        capture = self._survey_capture
        box = self.boxes[self.sort.box_for(target.name)]
        self.look_into_box(box.name, stay=self.settings.straight_from_box)
        # away from where the survey was taken (a look into a box): the loop's search takes
        # the survey's frame (nothing on the table moved since) and goes straight to the cloth
        away = not np.allclose(self.motion.q, self._survey_joints, atol=1e-6)
        if away and self.loop_settings.strategy is Strategy.SERVO:
            self.motion.move_to_joints(self._survey_joints)  # the servo's search looks twice, anew
            away = False
        pose = to_world(capture, target.transform_model_to_camera)
        others = tuple(d for d in ident.detections if d.name != target.name)
        under = tuple(
            low for up, low in ident.above if up == target.name and any(d.name == low for d in others)
        )
        attempt = AttemptState(target, box, pose, self.cell.time, others, under)
        attempt.obstacles_xy = self._obstacles_of(target, ident)
        if self.settings.pile_grasp.enabled:
            model, K = self.recognizers[target.name].model, self.rig.right.camera_matrix
            obstacles = attempt.obstacles_xy
            spot = self._hidden_spots.get(target.name)
            if spot is not None:
                obstacles = np.concatenate([obstacles, disk_points(spot, self.settings.hidden_cloth_radius)])
                where = f"({spot[0]:.2f}, {spot[1]:.2f})"
                attempt.notes.append(f"grasp kept away from the cloth laid under {where}")
            if self.settings.layers.enabled:
                obstacles = np.concatenate([obstacles, self._raised(target, pose, attempt)])
            cpu = time.process_time()
            attempt.grasp = pile_grasp(
                target, pose, model, K, obstacles, self.settings.pile_grasp, self._grasps_at
            )
            self.motion.hold(time.process_time() - cpu)  # the IK checks' time
            if attempt.grasp is not None and attempt.grasp.moved_for_reach:
                xy = attempt.grasp.point_world
                attempt.notes.append(
                    f"grasp moved to ({xy[0]:.2f}, {xy[1]:.2f}): the best point was out of reach"
                )
            if attempt.grasp is not None and not self._clear_of_walls(attempt.grasp.point_world):
                xy = attempt.grasp.point_world
                reason = (
                    f"no grasp clear of the boxes: every point of {target.name} the survey saw lies within "
                    f"{self.settings.lost.wall_clearance * 100:.0f} cm of a box's walls (best at "
                    f"({xy[0]:.2f}, {xy[1]:.2f}))"
                )
                attempt.notes.append(f"unreachable: {reason}")
                result = EpisodeResult.not_started(Outcome.UNREACHABLE, reason, "pile")
                self.ledger.record_attempt(attempt, result, self.cell.time, self.weights.get(target.name))
                return False
        recognizer = pick_recognizer(self.recognizers[target.name], target, self.settings.pick_depth_window)
        truth = self.ground_truth(target.name) if self.ground_truth is not None else None
        loop = PickPlaceLoop(
            self.cell,
            self.kinematics,
            recognizer,
            self.limits,
            self._survey_camera_pose,
            box.centre,
            self.table_z,
            self._loop_settings(target.name),
            self.filter_settings,
            on_phase=lambda record: self._loop_phase(record, attempt, loop),
            on_step=lambda _cell, _capture: self._loop_step(loop, target.name),
            on_recognition=lambda cycle: self._loop_vision(cycle, attempt, loop),
            ground_truth=truth,
            posture_seed=self._survey_joints,
            expected_pose=pose,
            box_heap=self.box_heap(box.name),
            first_look=capture if away else None,
        )
        self._before_pick = _BeforePick(
            target.name,
            ident.unknown,
            footprint(self.recognizers[target.name].model, self.rig.right, target.transform_model_to_camera),
            self._survey_camera_pose.copy(),
            box.centre[:2].copy(),
            capture,
        )
        self._phase, self._meant = "observe", target.name
        result = loop.run()
        self._collisions += result.collisions
        # attempt.name: the cloth it held, after a wrong lift named by the look (`_held_instead`)
        self.ledger.record_attempt(attempt, result, self.cell.time, self.weights.get(attempt.name))
        return result.outcome is Outcome.INTERRUPTED

    def _loop_settings(self, name: str) -> LoopSettings:
        """The loop's settings for the next attempt at `name`: deeper after empty grasps."""
        misses = self.ledger.misses(name)
        if misses == 0 or self.settings.deeper_after_miss == 0:
            return self.loop_settings
        height = max(0.0, self.loop_settings.grasp_height - misses * self.settings.deeper_after_miss)
        return self.loop_settings.model_copy(update={"grasp_height": height})

    def _loop_step(self, loop: PickPlaceLoop, name: str) -> None:
        self._phase, self._meant = loop.current_phase.value, name
        self._step()

    def _loop_vision(self, cycle: VisionCycle, attempt: AttemptState, loop: PickPlaceLoop) -> None:
        if self.on_recognition is not None:
            self.on_recognition(cycle, attempt.name)
        record = cycle.record
        if record.mode == "search" and record.accepted:
            check_found_in_place(record, attempt, self.settings.same_place)
            self._use_pile_grasp(loop, cycle.transform_model_to_world, attempt)

    def _loop_phase(self, record: PhaseRecord, attempt: AttemptState, loop: PickPlaceLoop) -> None:
        if self.on_phase is not None:
            self.on_phase(record, attempt.name)
        if record.phase == "approach":
            self._aim_at_surface(attempt, loop)
        elif record.phase == "lift" and record.note.startswith(LIFTED):
            self._after_lift(attempt, loop)
        elif record.phase == "transfer" and not self.cell.holding():
            attempt.dropped = True
            attempt.notes.append("dropped during the transfer (gripper empty over the box)")
            fell_in = self.fell_into_box(attempt)
            loop.arm.resume_at(self.motion.q)
            if fell_in:
                raise EpisodeAbortError(Outcome.PLACED, FELL_INTO_BOX)
            raise EpisodeAbortError(
                Outcome.LOST, f"{DROPPED} during the transfer: the gripper came empty over the box"
            )
        elif record.phase == "transfer":
            self.check_carried(attempt)
        elif record.phase == "release":
            self._after_release(attempt, loop)

    def _lost_to_pick(self, ident: Identification) -> LostMatch | None:
        """A cloth the job lost and no survey recognised since, with attempts left, whose
        colours an unknown region of `ident` shows (`table_lost.match_lost`).

        After a double pick whose other cloth was not named, the guesses for that cloth are
        asked in two rounds: first the *suspects* alone, the cloths a survey saw on the table
        that no survey sees now (not placed); then, if no region matches, every known cloth
        not placed and not seen now. With the whole catalogue as guesses a dark heap fits the
        white cloths' palettes as well as the lost black one's (a white cloth's folds lie in
        shade), and no region is ever taken (bench episode 60, session 20: No.20 laid back
        with No.15, seen before and gone since; the heap, in No.20's colours, stayed on the
        table as the whites No.17 and No.18, never seen, tied with it)."""
        if not self.settings.lost.enabled:
            return None
        seen = {d.name for d in ident.detections}
        lost = {
            name: self.recognizers[name]
            for name in self.ledger.lost
            if name not in seen and self.untried(name)
        }
        # lost cloths with no attempts left still explain their regions (`match_lost`'s `spent`)
        spent = {
            name: self.recognizers[name]
            for name in self.ledger.lost
            if name not in seen and name not in lost and name in self.recognizers
        }
        places = {name: self.ledger.lost[name] for name in (*lost, *spent)}
        rounds: list[tuple[str, ...]] = [()]
        suspects: tuple[str, ...] = ()
        if self.ledger.unnamed:
            # a cloth that came up with a double pick and was not named: one of the known
            # cloths not placed and not seen now, laid back where that pick let go. Not only
            # the never identified ones: bench episode 19's No.5, seen once at confidence 0.24,
            # came up with No.8, was laid back with it and was never picked (its heap stayed
            # an unknown region by the put-back spot)
            placed = set(self.ledger.placed_order)
            guesses = tuple(
                name
                for name in self.recognizers
                if name not in lost and name not in placed and name not in seen and self.untried(name)
            )
            suspects = tuple(name for name in guesses if name in self.ledger.last_seen)
            rounds = [suspects, guesses] if suspects and len(suspects) < len(guesses) else [guesses]
        for guessed in rounds:
            candidates = {**lost, **spent, **{name: self.recognizers[name] for name in guessed}}
            where = {**places, **{name: self.ledger.unnamed[-1] for name in guessed}}
            found = self._lost_among(ident, candidates, where, frozenset(guessed), frozenset(spent))
            taken = self._with_doubts(found, seen, suspects, places)
            if taken is not None:
                return taken
        # none alone: a heap of several of them (`table_lost.match_heap`)
        regions, centres = self._regions_to_try(ident.unknown)
        suspected = {name: self.recognizers[name] for name in suspects}
        where = {**places, **{name: self.ledger.unnamed[-1] for name in suspects}}
        heap = match_heap(
            self._survey_capture,
            regions,
            centres,
            lost,
            suspected,
            where,
            self.settings.lost,
            self.sort.box_for,
        )
        if heap is not None:
            return heap
        tie = self._with_doubts(self._tie_to_pick(ident, lost, spent, places), seen, suspects, places)
        if tie is not None:
            return tie
        found = self._placed_unsure_to_pick(ident, seen, {**lost, **spent}, places)
        return self._with_doubts(found, seen, suspects, places)

    def _tie_to_pick(
        self,
        ident: Identification,
        lost: Mapping[str, Recognizer],
        spent: Mapping[str, Recognizer],
        places: Mapping[str, LostPlace],
    ) -> LostMatch | None:
        """After every other round of `_lost_to_pick`: a region whose colours fit lost
        cloths of both boxes within `lost.margin` (`match_lost(ties=True)`; none guessed),
        picked blind as the best, the others its `rivals`. The lift goes into the box of
        the one whose weight the load cell reads and whose colours a look at it shows alone,
        or back (`table_lost._carry`); without the look (`held_look.enabled` off), no such
        region is taken. Held-out 1771 (session 49): No.19 (colours) and No.6 (whites), put
        back together, fit their heap at 0.50 and 0.42; neither was picked, and the job
        stopped with both on the table."""
        if not self.settings.held_look.enabled or not lost:
            return None
        regions, centres = self._regions_to_try(ident.unknown)
        return match_lost(
            self._survey_capture,
            regions,
            centres,
            {**lost, **spent},
            places,
            self.settings.lost,
            self.sort.box_for,
            spent=frozenset(spent),
            ties=True,
        )

    def _with_doubts(
        self,
        found: LostMatch | None,
        seen: set[str],
        suspects: tuple[str, ...],
        places: Mapping[str, LostPlace],
    ) -> LostMatch | None:
        """`found` carrying the cloths of another box its lift may hold instead (`_doubts`);
        None where nothing was found, or where no look may settle them."""
        doubted = None if found is None else self._doubts(found, seen, suspects, places)
        return None if found is None or doubted is None else replace(found, doubted=doubted)

    def _doubts(
        self, found: LostMatch, seen: set[str], suspects: tuple[str, ...], places: Mapping[str, LostPlace]
    ) -> tuple[str, ...] | None:
        """The cloths of another box a blind lift at `found` may hold instead
        (`_suspects_under`: the `suspects`, the cloths not `seen` and not lost that may lie
        under it, the lost ones near it); None where there are some and no look at the lift
        may tell (`held_look.enabled` off): the region is not picked."""
        unseen = tuple(n for n in self.recognizers if n not in seen and n not in self.ledger.lost)
        doubted = self._suspects_under(
            found, (*suspects, *self._unseen_under(found, unseen)), self._lost_near(found, places)
        )
        # the lifted cloth is looked at before it goes anywhere (`table_lost._carry`)
        return doubted if not doubted or self.settings.held_look.enabled else None

    def _placed_unsure_to_pick(
        self,
        ident: Identification,
        seen: set[str],
        lost: Mapping[str, Recognizer],
        places: Mapping[str, LostPlace],
    ) -> LostMatch | None:
        """The last resort of `_lost_to_pick`: a cloth booked placed by a blind lift that
        could have been another cloth of its box not placed since
        (`TableLedger.placed_unsure`), whose colours an unknown region shows ahead of every
        lost cloth's (`match_lost`, anywhere on the table): that lift held the other cloth,
        and this one lies there. The booking is swapped (`TableLedger.swap_placed`) and the
        cloth booked lost there (`LossKind.HIDDEN`), picked blind as every lost cloth.
        Replay of held-out 1438 (session 49): a blind lift meant for No.14, named No.2 by
        its weight, held No.15 and went in as No.2; No.2, crumpled, stayed an unknown region
        in its colours that no lost cloth's fit, and the job stopped."""
        placed = set(self.ledger.placed_order)
        still = self.ledger.still_unsure()
        unsure = {
            name: self.recognizers[name]
            for name in still
            if name not in seen and name in self.recognizers and self.untried(name)
        }
        if not unsure or not ident.unknown:
            return None
        found = self._lost_among(ident, {**lost, **unsure}, places, frozenset())
        if found is None or found.name not in unsure:
            return None
        name = found.name
        others = still[name]
        earlier = next((o for o in found.alike if o in others), others[0])  # one it fits as well, first
        how = f"its colours seen on the table by survey {len(self.ledger.surveys) + 1}"
        self.ledger.swap_placed(name, earlier, how)
        xy = np.array(self.table.point(self._survey_capture, found.region.centroid))
        booked = f"booked placed by a blind lift, {how}"
        self.ledger.lost[name] = LostPlace(LossKind.HIDDEN, booked, xy, xy.copy(), ())
        return replace(found, alike=tuple(a for a in found.alike if a not in placed and a != earlier))

    def _suspects_under(
        self, found: LostMatch, suspects: tuple[str, ...], lost_near: tuple[str, ...] = ()
    ) -> tuple[str, ...]:
        """The suspects (`_lost_to_pick`: seen on the table, gone since a double pick laid
        back with an unnamed companion) a blind lift at `found` could hold instead, hidden
        under the region, of another box and weighing as much (`weight_verdict`), so that
        neither the region's colours nor the weight would tell. Bench episode 60 (session
        21): the heap in No.20's colours was lifted as No.20 and held the suspect No.15 (same
        box, 26 g for 24 g). Such a lift is looked at (`held_look`) or, without the look,
        not made: held-out episodes 116, 120 and 161 (session 24) each ended with a
        put-back heap matched to its lost cloth and never lifted for such a suspect.

        `lost_near`: the cloths the job lost (named) that may lie at the region
        (`near_the_loss`), doubted alike when `found` is only a guess, or was laid back under
        its name by a lift that doubted others (`TableLedger.unsure`). Held-out episode 233
        (session 24): the heap where No.9 (colours) had just been laid back showed 28 % of
        its colours, too few to rule out a guess, and 93 % of the guessed white No.6's;
        the blind lift weighed 18 g, No.6's 21 g and No.9's 17 g, and No.9 went into the
        whites box. In its replay (session 25) the look put that lift back, and the heap,
        now "No.6 laid back", was lifted again unlooked and went into whites."""
        box = self.sort.box_for(found.name)
        own = self.weights.get(found.name)
        doubted = []
        if found.name in found.guessed or found.name in self.ledger.unsure:
            suspects = (*suspects, *(n for n in lost_near if n not in suspects))
        for name in suspects:
            if name in (found.name, *found.alike) or self.sort.box_for(name) == box:
                continue
            weight = self.weights.get(name)
            if own is None or weight is None or weight_verdict(weight, own, name, self.settings)[0] == "ok":
                doubted.append(name)
        return tuple(doubted)

    def _unseen_under(self, found: LostMatch, unseen: tuple[str, ...]) -> tuple[str, ...]:
        """Of the known cloths `unseen` (not seen by this survey, not lost), those not placed
        whose main colours explain `found`'s region as well as the lost cloths' must
        (`colour_fit.ColourFit`: `lost.min_share` of it, at their lightness), when `found` is
        only a guess: `_suspects_under` doubts those of another box that weigh as much.
        Held-out episode 327 (session 26): a double pick's companion, never seen, was guessed
        the grey melange No.19 (its region 98 % in its grey and white) and placed in colours
        by its weight (18.3 g, No.19's 18.2 g); it was the white No.18 (20.9 g), never
        seen. (Its region was 99 % DARK, lit value 67: No.18 lay face down, which the
        renderer drew unlit until session 27, so this test alone, with No.18's `shows_light`
        0 there, would not have doubted it then; drawn lit, its back shows white.)"""
        if found.name not in found.guessed:
            return ()
        placed = set(self.ledger.placed_order)
        candidates = {n: self.recognizers[n] for n in unseen if n not in placed and n != found.name}
        if not candidates:
            return ()
        fits = colour_shares(self._survey_capture, found.region.mask, candidates)
        return tuple(
            n for n, fit in fits.items() if fit.share * fit.lightness >= self.settings.lost.min_share
        )

    def _lost_near(self, found: LostMatch, places: Mapping[str, LostPlace]) -> tuple[str, ...]:
        """Of the lost cloths (lost at `places`), those other than `found`'s that may lie at
        its region (`near_the_loss`), there or where a lift that could have held them was put
        back (`TableLedger.maybe`). Replay of held-out episode 233 (session 25): the guess No.6
        doubted for No.9 was looked at and put back (what hung showed No.9's colours), then
        lifted again from where it was laid, far from No.9's loss, unlooked, into whites."""
        centre = np.array(self.table.point(self._survey_capture, found.region.centroid))
        return tuple(
            name
            for name, place in places.items()
            if name not in (found.name, *found.alike)
            and any(
                near_the_loss(centre, where, self.settings.lost)
                for where in (place, *self.ledger.maybe.get(name, ()))
            )
        )

    def _lost_among(
        self,
        ident: Identification,
        lost: Mapping[str, Recognizer],
        places: Mapping[str, LostPlace],
        guessed: frozenset[str],
        spent: frozenset[str] = frozenset(),
    ) -> LostMatch | None:
        """`match_lost` over `ident`'s unknown regions for the candidates `lost` (lost at
        `places`; `guessed`: those of them only guessed), then over their pieces in one
        candidate's colours (`colour_patches`)."""
        capture, s = self._survey_capture, self.settings.lost

        def match(regions: tuple[UnknownRegion, ...]) -> LostMatch | None:
            regions, centres = self._regions_to_try(regions)
            return match_lost(capture, regions, centres, lost, places, s, self.sort.box_for, guessed, spent)

        whole = match(ident.unknown)
        if whole is not None or not ident.unknown:
            return whole
        # else their pieces in one lost cloth's colours: a heap of several laid back together
        # shows each one's colours only where it lies on top
        smallest = self.identify_settings.min_unknown_area * ident.unknown[0].mask.size
        piece = match(colour_patches(capture, ident.unknown, lost, smallest))
        return None if piece is None else replace(piece, piece=True)

    def _regions_to_try(
        self, regions: tuple[UnknownRegion, ...]
    ) -> tuple[tuple[UnknownRegion, ...], list[FloatArray]]:
        """`regions` of the last survey and their centres on the table [m], without those
        where blind grasps closed on nothing (`_grasped_empty`) and those whose every point
        a hand could grasp lies within `lost.empty_reach` of such a grasp
        (`_grasped_all_over`)."""
        centres = [np.array(self.table.point(self._survey_capture, r.centroid)) for r in regions]
        kept = [
            i
            for i, c in enumerate(centres)
            if not self._grasped_empty(c) and not self._grasped_all_over(regions[i])
        ]
        return tuple(regions[i] for i in kept), [centres[i] for i in kept]

    def _grasped_all_over(self, region: UnknownRegion) -> bool:
        """Does every point of `region` a hand could grasp blind (`graspable`) lie within
        `lost.empty_reach` of a blind grasp that closed on nothing (`away_from`)? A blind
        pick would have nowhere left to aim (`pick_lost`: "closed on nothing all over its
        region"), whatever cloth it is matched to. Held-out 1122 (session 39): the cloths
        hanging out of the colours box over its wall made a region beside it; three blind
        grasps there lifted nothing (the box held them), and seven more attempts under
        three guessed names were each booked "no blind grasp" there, a survey apiece, until
        the job's 15 attempts were used (its centre lay beyond `empty_reach` of the grasps,
        so `_grasped_empty` kept it)."""
        s = self.settings.lost
        if not self.ledger.empty_grasps:
            return False
        capture = self._survey_capture
        aims = graspable(
            region.mask,
            capture,
            self.table,
            self.table_top,
            self.boxes.values(),
            s.edge_inset,
            s.wall_clearance,
        )
        if not np.any(aims):
            return False  # no grasp was ever possible there: `pick_lost` reports why
        return not np.any(away_from(aims, capture, self.table, self.ledger.empty_grasps, s.empty_reach))

    def _grasped_empty(self, centre: FloatArray) -> bool:
        """Did `lost.empty_grasps` blind grasps within `lost.empty_reach` of `centre` ((2,)
        [m]) close on nothing? Then what lies there is no cloth the fingers take."""
        s = self.settings.lost
        near = [xy for xy in self.ledger.empty_grasps if float(np.hypot(*(xy - centre))) <= s.empty_reach]
        return len(near) >= s.empty_grasps

    # ------------------------------------------------------------------ looking around
    def _back_to_observation(self) -> None:
        if not np.allclose(self.motion.q, self.observation_joints, atol=1e-6):
            self._phase, self._meant = "observe", None
            self.motion.move_to_joints(self.observation_joints)

    def _places_to_look(self, ident: Identification) -> list[FloatArray]:
        placed = set(self.ledger.placed_order)
        # a cloth dropped on the way to its box: the middle of that way, then nearer the box;
        # so does one a placed pick moved (dragged along, held by nothing: bench episode 12,
        # session 21, three cloths gone from the view after the pick of No.16, never looked for)
        moving = (LossKind.DROPPED, LossKind.MOVED)
        ways = [place for place in self.ledger.lost.values() if place.kind in moving]
        ways += [place for place in self.ledger.unnamed if place.kind is LossKind.MOVED]
        dropped_on = tuple(place.start + f * (place.end - place.start) for place in ways for f in (0.5, 0.75))
        return self.recovery.places_to_look(
            self._survey_capture,
            ident,
            self.ledger.last_seen,
            lambda name: name not in placed and self.untried(name),
            dropped_on,
            len(self.ledger.attempts),
        )

    def _look_from(self, place: FloatArray) -> bool:
        self.recovery.looked.append(place)
        offset = self.camera_offset()
        self._phase, self._meant = "look around", None
        observation = self.observation_camera_pose[:2, 3]
        return self.recovery.look_from(place, offset, self.observation_camera_pose[2, 3], observation)

    # ------------------------------------------------------------------ grasp point
    def _grasps_at(self, point: FloatArray) -> bool:
        """Can the loop grasp at `point` (Σ_W [m], on the cloth)? Its TCP over the point
        before the grasp, at the grasp and at the lift's height all have IK solutions (cameras
        looking down, as the loop keeps them)."""
        s, cloth_z = self.loop_settings, float(point[2])
        if not self._clear_of_walls(point):
            return False
        heights = (cloth_z + s.pregrasp_height, cloth_z + s.grasp_height, self.table_z + s.lift_height)
        return all(self.motion.reaches([point[0], point[1], h]) for h in heights)

    def _clear_of_walls(self, point: FloatArray) -> bool:
        """Does the open hand come down at `point` (Σ_W [m]) clear of every box's walls
        (`table_furniture.clear_of_walls`, `lost.wall_clearance`)? Held-out bench episode 107
        (session 22): a cloth laid back against the colours box's wall was grasped 9 mm from
        it, and the finger touched the wall (4 collisions)."""
        return bool(clear_of_walls(point[:2], self.boxes.values(), self.settings.lost.wall_clearance)[0])

    def _raised(self, target: Detection, pose: FloatArray, attempt: AttemptState) -> FloatArray:
        """(M, 2) [m] the points of `target`'s seen part whose surface the survey's pair shows
        over another cloth (`table_layers.layer_map`); the arm holds for the time measured."""
        cpu = time.process_time()
        recognizer = self.recognizers[target.name]
        model, K = recognizer.model, self.rig.right.camera_matrix
        seen = points_in_mask(model.points_in, target.transform_model_to_camera, K, target.explained)
        layers = layer_map(
            self._survey_capture, self.rig, model, recognizer.settings.depth, target.explained,
            transform_points(pose, model.points_in[seen]), self.table_z, self.settings.layers,
            self.settings.surface,
        )  # fmt: skip
        self.motion.hold(time.process_time() - cpu)
        raised = layers.raised
        if len(raised):
            attempt.notes.append(
                f"grasp kept off {len(raised)} of {layers.trusted} measured points lying over something "
                f"(surface above {(layers.limit - self.table_z) * 1000:.0f} mm)"
            )
        return raised

    def _use_pile_grasp(
        self, loop: PickPlaceLoop, transform_model_to_world: FloatArray, attempt: AttemptState
    ) -> None:
        """Hands the job's grasp point to the loop, in the frame of the loop's own recognition
        (a symmetric cloth may have been seen turned), if it lies on the recognised cloth."""
        if attempt.grasp is not None:
            model, gap = self.recognizers[attempt.name].model, self.settings.pile_grasp.min_edge_gap
            point = grasp_in_model(attempt.grasp.point_world, transform_model_to_world, model, gap)
            if point is not None:
                loop.tracker.grasp_point_model = point
                attempt.grasp_used = True
        attempt.grasp_point_model = loop.tracker.grasp_point_model.copy()

    def _aim_at_surface(self, attempt: AttemptState, loop: PickPlaceLoop) -> None:
        """Moves the loop's grasp point onto the top surface the survey's pair shows there
        (`table_surface`), when that is measured and trusted; the notes say what was found."""
        estimate, settings = loop.tracker.filter.estimate, self.settings.surface
        if not settings.enabled or attempt.target is None or estimate is None:
            return
        pose = estimate.as_transform()
        point = pose[:3, :3] @ loop.tracker.grasp_point_model + pose[:3, 3]
        recognizer = self.recognizers[attempt.name]
        depth = recognizer.settings.depth
        found = surface_height(
            self._survey_capture, self.rig, recognizer.model, depth, attempt.target.explained,
            point, self.table_z, settings,
        )  # fmt: skip
        seen = f"surface at {found.z * 1e3:.0f} mm (correlation {found.correlation:.2f}, {found.samples} px)"
        if not found.trusted:
            attempt.notes.append(f"grasp on the pose's plane ({point[2] * 1e3:.0f} mm): {seen} not trusted")
            return
        loop.tracker.grasp_point_model = aimed_at(pose, loop.tracker.grasp_point_model, found.z)
        attempt.notes.append(f"grasp aimed at the {seen}; the pose's plane was at {point[2] * 1e3:.0f} mm")

    # ------------------------------------------------------------------ checks
    def _after_lift(self, attempt: AttemptState, loop: PickPlaceLoop) -> None:
        """Did the meant cloth, and only it, leave the table? Else put it back (the loop's
        abort then goes home from where the put-back ended)."""
        self._phase = "lift check"
        attempt.lifted_at = self.motion.tcp_position()
        capture = self.cell.capture()
        wall, cpu = time.perf_counter(), time.process_time()
        name = attempt.name
        recognizer = self.recognizers[name]
        stayed = still_there(recognizer, capture, attempt.transform_target_to_world, self.settings.same_place)
        attempt.check_wall_s += time.perf_counter() - wall
        self._wait(time.process_time() - cpu, 1)
        expected = self.weights.get(name)
        verdict, what = "ok", ""
        if self.weigh is not None and expected is not None:
            attempt.weighed = float(self.weigh())
            verdict, what = weight_verdict(attempt.weighed, expected, name, self.settings, lift=True)
        heavier = verdict == "double"  # whatever else: more than the meant cloth came up
        dragged: tuple[str, ...] = ()
        regions = 0
        if verdict == "ok" and not stayed and attempt.weighed is not None and expected is not None:
            dragged, regions = self._dragged(attempt, capture, attempt.weighed - expected, loop)
            if dragged or regions:
                verdict, heavier = "double", True
                gone = [*dragged, *(["an unidentified cloth"] if regions == 1 else [])]
                gone += [f"{regions} unidentified cloths"] if regions > 1 else []
                how = (
                    "seen hanging with it"
                    if attempt.looked
                    else f"left where the survey saw it beside {name}"
                )
                what = (
                    f"{attempt.weighed * 1000:.0f} g lifted, {name} weighs {expected * 1000:.0f} g, "
                    f"and {' and '.join(gone)} {how}"
                )
        if stayed:
            verdict, what = "wrong", f"{name} still in its place" + (f"; {what}" if what else "")
        attempt.lift_check = verdict
        if verdict == "ok":
            return
        if stayed and not heavier:
            if self._held_instead(attempt, what, loop):
                return
            weighed = attempt.weighed
            if (
                self.settings.unnamed_wrong_lift
                and weighed is not None
                and self._not_placed(attempt, lambda _n, w: weighs_extra(weighed, w, self.settings))
            ):
                # it holds a cloth of a known one's weight that no look named: booked laid back
                # unnamed, where later surveys guess it (held-out 1633, session 46: No.14, never
                # seen, lifted for No.15 and put back, stayed an unknown region to the end)
                attempt.unnamed_along = 1
        if dragged or regions:
            # partly lifted, it hangs from the held cloth: back down with it, booked laid back
            attempt.laid_back_too, attempt.unnamed_along = dragged, regions
            attempt.named_by = ("look" if attempt.looked else "drag") if dragged else ""
        elif verdict == "double" and attempt.weighed is not None and expected is not None:
            grasp = self.motion.tcp_position()
            grasp[2] = self.table_z
            extra = attempt.weighed - expected
            other = companion(
                self._survey_capture,
                self.rig.right,
                grasp,
                attempt.others,
                extra,
                self.weights,
                self.settings,
            )
            if other is not None and self._stayed(other, attempt, capture):
                attempt.notes.append(f"{other} weighs the extra but still lies where the survey saw it")
                other = None  # the extra weight is another cloth's
            attempt.named_by = "grasp" if other is not None else ""
            source = ""
            if other is None:
                other = self._companion_under(attempt, capture, extra)
                if other is not None:
                    attempt.named_by = "under"
                    source = " (identity: the one cloth it lay on that weighs the extra, gone from there)"
                    if self._doubted(attempt, capture, extra, other, source, loop):
                        other, source, attempt.named_by = None, "", ""
            if other is None:
                other = self._remembered_companion(attempt, capture, grasp, extra)
                if other is not None:
                    attempt.named_by = "memory"
                    survey = self.ledger.last_survey[other]
                    source = (
                        f" (identity from memory: seen by survey {survey}, hidden since, gone from there)"
                    )
                    if self._doubted(attempt, capture, extra, other, source, loop):
                        other, source, attempt.named_by = None, "", ""
            if other is None and self.settings.held_look.name_companion:
                other, looked = self._companion_seen_hanging(attempt, extra)
                if looked:  # the look may have moved the hand
                    loop.arm.resume_at(self.motion.q)
                if other is not None:
                    attempt.named_by = "look"
                    source = f" (identity from its colours seen hanging: {looked})"
                elif looked:
                    attempt.notes.append(
                        f"double pick: looked at what hangs, no other cloth named ({looked})"
                    )
            # a laid-back cloth near the grasp could weigh the extra instead; not one seen hanging
            laid = self._laid_near(grasp[:2]) if other is not None and attempt.named_by != "look" else None
            if laid is not None:
                attempt.notes.append(
                    f"double pick: {other} would weigh the extra{source}, but the fingers closed "
                    f"{laid[1] * 1000:.0f} mm from where {laid[0]} was laid back: identity not sure"
                )
                other, source, attempt.named_by = None, "", ""
            if other is not None and self.sort.box_for(other) == attempt.box.name:
                attempt.came_along = (other,)
                attempt.remembered = (other,) if attempt.named_by == "memory" else ()
                loop.extra_reach = self.hanging_reach(other)  # it hangs from the meant cloth
                attempt.notes.append(
                    f"double pick ({what}): {other} came along{source}, same box: both placed"
                )
                return
            if other is not None:
                attempt.notes.append(f"double pick: {other} came along{source}, belongs in another box")
                attempt.laid_back_too = (other,)
            else:
                attempt.unnamed_along = self.count_unnamed(attempt, extra)
            if self.settings.put_back.shed and self._shed(attempt, expected, what):
                loop.arm.resume_at(self.motion.q)
                return
        attempt.notes.append(f"{'double pick' if verdict == 'double' else 'wrong lift'} ({what}): put back")
        self.put_back(attempt, attempt.grasp_point_model)
        loop.arm.resume_at(self.motion.q)
        if heavier and self.settings.hidden_cloth_radius > 0:
            # the other cloth hung from the same fingers: it lies under the spot let go at,
            # where no survey may see it (the meant cloth covers it again)
            self._hidden_spots[name] = self.recovery.put_back_spots[-1].copy()
        raise EpisodeAbortError(Outcome.GRASP_FAILED, f"{PUT_BACK}: {what}")

    def count_unnamed(self, attempt: AttemptState, extra: float) -> int:
        """How many cloths at least a double pick's `extra` [kg], put back with no name, holds
        (`cloths_in_extra` among the cloths not placed; two or more: each may be found and
        placed alone), noted when more than one. The ledger books an unnamed place for each
        (`TableLedger.unnamed`), where a later survey's guesses look for them."""
        could_be = [self.weights[n] for n in self._not_placed(attempt, lambda _n, _w: True)]
        count = min(cloths_in_extra(extra, could_be, self.settings), max(1, len(could_be)))
        if count > 1:
            attempt.notes.append(f"double pick: the {extra * 1000:.0f} g extra is {count} cloths at least")
        return count

    def _held_instead(self, attempt: AttemptState, what: str, loop: PickPlaceLoop) -> bool:
        """A wrong lift (the meant cloth still in its place, `what`) named by its colours
        seen hanging (`look_at_held`, two looks, colour fits): among the cloths not placed
        whose weight is the reading and that the pick's survey did not see away from the
        grasp, the best fit, if it reaches `held_look.name_instead` and no cloth of another
        box fits within `held_look.margin` of it or shows its own colours (or, when the best
        is a cloth of tones only, its shade) at `doubt_share`: the lift goes on into the
        meant cloth's box, booked as that cloth (`AttemptState.held_instead`). Whether it
        goes on (else the caller puts it back).
        Held-out episode 796 (session 33): four grasps meant for No.15 lifted No.13 (same
        colours, lying on it, never identified), each put back, No.13 over No.15 again;
        held-out 776: a grasp meant for No.8 lifted No.12 (both of colours)."""
        hl, s, weighed = self.settings.held_look, self.settings, attempt.weighed
        if hl.name_instead is None or weighed is None:
            return False
        grasp = self.motion.tcp_position()[:2]
        survey = self._survey_capture
        seen_at = {d.name: to_world(survey, d.transform_model_to_camera) for d in attempt.others}

        def apart(name: str) -> bool:  # seen by the pick's survey away from the grasp
            if name not in seen_at:
                return False
            footprint = transform_points(seen_at[name], self.recognizers[name].model.points_in)[:, :2]
            return not comes_within(footprint, grasp, s.remembered_reach)

        weighing = self._not_placed(attempt, lambda n, w: weighs_extra(weighed, w, s) and not apart(n))
        if not weighing:
            return False
        self._phase = "look at lift"
        seen, where = look_at_held(self, attempt.name, weighing, looks=2, fit=True)
        loop.arm.resume_at(self.motion.q)  # the look may have moved the hand
        if seen is None or seen.pixels < hl.min_pixels or not seen.fits:
            attempt.notes.append(f"wrong lift: what it holds not seen well enough ({where})")
            return False
        fits = {n: seen.fits[n].score for n in weighing if n in seen.fits}
        best = max(fits, key=lambda n: fits[n])
        close = sorted((n for n in fits if fits[n] >= fits[best] - hl.margin), key=lambda n: -fits[n])
        box = attempt.box.name
        # a white cloth hanging in shade reads DARK, as a cloth of tones does; never as a hue
        # (held-out 796's rerun: No.13, violet, its shaded side DARK, doubted for two whites)
        toned = self.tones_only(best)
        doubted = [
            n
            for n in weighing
            if self.sort.box_for(n) != box
            and (
                n in close
                or seen.own[n] >= hl.doubt_share
                or (toned and seen.shaded.get(n, 0.0) >= hl.doubt_share)
            )
        ]
        told = ", ".join(f"{n}'s {fits[n]:.2f}" for n in close)
        note = f"{seen.pixels} px seen hanging, colour fit {told}; {where}"
        if fits[best] < hl.name_instead or doubted or not names_weight(weighed, self.weights.get(best), s):
            why = (
                f"cloths of another box too ({', '.join(doubted)})"
                if doubted
                else "no cloth fits"
                if fits[best] < hl.name_instead
                else f"{best} weighs {self.weights[best] * 1000:.0f} g, {weighed * 1000:.0f} g read"
            )
            attempt.notes.append(f"wrong lift, looked at ({note}): {why}")
            return False
        meant, alike = attempt.name, close[1:]
        also = f" (or {', '.join(alike)}, same box)" if alike else ""
        attempt.notes.append(f"wrong lift ({what}): it holds {best}{also} by its colours ({note})")
        self.ledger.note(meant, f"a grasp meant for it lifted {best} instead, placed as {best}")
        attempt.held_instead = best
        loop.extra_reach = self.hanging_reach(best)  # held anywhere: it may hang below the meant one's reach
        return True

    def _companion_under(self, attempt: AttemptState, capture: StereoCapture, extra: float) -> str | None:
        """The double pick's other cloth when it is the one cloth of those the pick's survey
        saw the target lie on (`AttemptState.under`) whose weight is the `extra` [kg] that the
        check after the lift (`capture`) no longer finds where the survey saw it (`_stayed`).
        The fingers close on the top cloth, away from the others (`pile_grasp`), so the cloth
        dragged along is mostly one it lay on, hanging inside it where no look sees it: the
        held-out runs 116-237 (sessions 23-24) had 25 double picks whose one such cloth
        weighing the extra was the other cloth and 8 where it was not (another one, hidden,
        came along). `_stayed` tells some of those apart, not all (replay of 216, session 25:
        No.17 stayed and was not found, a hanging cloth hid it), so one of the meant cloth's
        box goes along only if no cloth of another box shows hanging (`_other_box_hanging`),
        and if, seen again from where the hand looked (the hanging cloth no longer between
        the camera and the table there), it is not found in its place either: held-out
        episode 401 (session 28): No.13 lifted with No.17 (whites, hidden inside it, never
        identified), named No.8 "under" (gone, by the check after the lift: it had stayed),
        and No.17 went into colours with it."""
        s = self.settings
        fits = [name for name in attempt.under if weighs_extra(extra, self.weights.get(name), s)]
        gone = [name for name in fits if not self._stayed(name, attempt, capture)]
        return gone[0] if len(gone) == 1 and names_weight(extra, self.weights.get(gone[0]), s) else None

    def _doubted(
        self,
        attempt: AttemptState,
        capture: StereoCapture,
        extra: float,
        named: str,
        source: str,
        loop: PickPlaceLoop,
    ) -> bool:
        """Is the double pick's other cloth `named` "under" or from memory (`source` says
        how) of the meant cloth's box doubted by a look at what hangs (`_other_box_hanging`,
        `capture` the check after the lift; a cloth of another box is never placed along, so
        not looked for)? The loop resumes where a look left the hand. A name from memory is
        weaker than one from under: held-out episode 722 (session 33): No.7, named from memory
        with No.1, and No.6 of whites, dragged along unseen, hung partly into colours."""
        if self.sort.box_for(named) != attempt.box.name:
            return False
        doubt, moved = self._other_box_hanging(attempt, capture, extra, named)
        if moved:  # the look moved the hand
            loop.arm.resume_at(self.motion.q)
        if doubt:
            attempt.notes.append(f"double pick: {named} would be the other cloth{source}, but {doubt}")
        return bool(doubt)

    def _other_box_hanging(
        self, attempt: AttemptState, capture: StereoCapture, extra: float, named: str
    ) -> tuple[str, bool]:
        """Before a double pick named `under` goes into the box with the meant cloth: the
        cloths of another box, not placed, that weigh the `extra` [kg] or less
        (`could_be_in`: one, or two lighter ones, could hang hidden in its place: held-out
        episode 216, session 25: No.2's lift held No.10, never seen, and the check after the
        lift missed No.17, which No.2 lay on and which stayed), looked for hanging
        (`held_look`, two looks): ("" when none could be there or none shows `doubt_share`
        of the held pixels in its own colours and, from where the hand looked, the `named`
        cloth (one the pick's survey saw; not one named from memory) is not found where the
        survey saw it, else why not; whether the hand moved to look). A look that saw fewer
        than `held_look.min_pixels` held pixels rules nothing out (as `held_verdict`): held-out
        1259 (session 41) placed a pair after a look of 270 px. No look is made where it could
        not tell a never-seen rival beside the lift from the meant and named cloths, or where
        the check after the lift (`capture`) saw such a rival's place left bare
        (`_hidden_beside`)."""
        s = self.settings
        box = attempt.box.name
        rivals = self._not_placed(
            attempt, lambda name, weight: self.sort.box_for(name) != box and could_be_in(extra, weight, s)
        )
        if not rivals or not s.held_look.enabled:
            return "", False
        hidden = self._remembered_under_lift(attempt, rivals) or self._hidden_beside(
            attempt, capture, named, rivals
        )
        if hidden:
            return hidden, False
        self._phase = "look at lift"
        seen, where = look_at_held(self, attempt.name, rivals, looks=2, along=(named,))
        if seen is None:
            return f"no look at what hangs ({where})", bool(where)
        if seen.pixels < s.held_look.min_pixels:  # too little seen to rule a rival out (held-out 1259)
            return f"too little of what hangs seen against free table ({seen.pixels} px; {where})", True
        showing = [f"{n}'s own {seen.own[n]:.0%}" for n in rivals if seen.own[n] >= s.held_look.doubt_share]
        if showing:
            return (
                f"what hangs shows cloths of another box ({seen.pixels} px: {', '.join(showing)}; {where})",
                True,
            )
        if any(d.name == named for d in attempt.others) and self._stayed(named, attempt, self.cell.capture()):
            return STILL_IN_PLACE, True  # seen from beside the lift
        attempt.notes.append(f"looked at what hangs: no cloth of another box ({seen.pixels} px; {where})")
        return "", True

    def _remembered_under_lift(self, attempt: AttemptState, rivals: list[str]) -> str:
        """Why no look can rule out the `rivals` (of another box, weighing the extra or
        less) before a name goes along with the meant cloth ("" if it can): with
        `clear.remembered_rival`, one of them lay where the fingers closed (the hand is still
        over the grasp) when an earlier survey saw it, its footprint there within
        `remembered_reach` of the grasp, and the pick's survey did not see it
        (`TableLedger.remembered_poses`): it may hang inside the held cloth, where no look
        sees it. Held-out 1722 (session 48): No.18 (white, whites), seen under No.8 by the
        first survey and not since, came up with No.8; No.14, 17 cm away and still there,
        was named "under" (the check after the lift missed it), the look at what hangs saw
        no cloth of another box, and No.18 went into colours."""
        s = self.settings
        if not s.remembered_rival or s.remembered_reach <= 0:
            return ""
        poses = self.ledger.remembered_poses({attempt.name, *(d.name for d in attempt.others)})
        grasp = self.motion.tcp_position()[:2]
        under = [
            name
            for name in rivals
            if name in poses
            and comes_within(
                transform_points(poses[name], self.recognizers[name].model.points_in)[:, :2],
                grasp,
                s.remembered_reach,
            )
        ]
        if not under:
            return ""
        seen = ", ".join(f"{name} by survey {self.ledger.last_survey[name]}" for name in under)
        return (
            f"{_any_of(under)} (another box) lay where the fingers closed when last seen ({seen}), "
            "not seen since: it may hang inside the held cloth, where no look sees it"
        )

    def _hidden_beside(
        self, attempt: AttemptState, capture: StereoCapture, named: str, rivals: list[str]
    ) -> str:
        """Why no look could rule out the `rivals` (of another box, weighing the extra or
        less) before `named` goes along with the meant cloth ("" if it could): one of them
        was never seen by a survey, a cloth nobody identified lay beside the meant one when
        the pick's survey chose it (`_regions_touching`), and either every main colour of
        that rival is among the meant and named cloths' own (`held_look.hidden_in`: the look
        counts a cloth only by colours of its own), or the check after the lift (`capture`)
        sees that cloth's place bared (`_regions_bared`): it left with the lift, and the
        extra weight is one cloth's. Held-out 1283 (session 41): No.17 (white towel, whites,
        never identified, an unknown region beside No.7) came up with No.7 (purple and
        white), was named No.4 "under" (still on the table), the look saw no cloth of another
        box, and No.17 went into colours; its replay with the colour rule cleared. Held-out
        1270: No.2 (colours, never identified, an unknown region beside No.6) has a blue of
        its own against No.6 and No.18, hung with No.6 unseen all the same, was named No.18
        "under" (still on the table) and went into whites; the survey after it found its
        region bare (session 42)."""
        never_seen = self._never_seen(rivals)
        if not never_seen:
            return ""
        held = transform_points(
            attempt.transform_target_to_world, self.recognizers[attempt.name].model.points_in
        )[:, :2]
        touching = self._regions_touching(attempt, held)
        if not touching:
            return ""
        holders = [self.recognizers[n].model for n in (attempt.name, named)]
        hidden = [n for n in never_seen if hidden_in(self.recognizers[n].model, holders)]
        if hidden:
            return (
                f"{_any_of(hidden)} (another box, never seen) may be the unidentified cloth beside "
                f"{attempt.name}, and no look tells its colours from {attempt.name}'s and {named}'s"
            )
        bared, _ = self._regions_bared(attempt, capture, held, touching)
        if not bared:
            return ""
        return (
            f"{_any_of(never_seen)} (another box, never seen) may be the unidentified cloth "
            f"beside {attempt.name}, whose place the lift bared"
        )

    def _hid_from_look(self, attempt: AttemptState, looked_for: Sequence[str]) -> tuple[str, ...]:
        """Of the cloths a look at what hangs was `looked_for`, those of another box than the
        meant cloth's, never seen by a survey, whose main colours are all among the held
        cloth's own (`hidden_in`): the look counts a cloth only by colours of its own, so it
        could not show them (`AttemptState.hid`). Held-out 1819 and 1820 (session 49)."""
        box, holder = attempt.box.name, [self.recognizers[attempt.name].model]
        return tuple(
            n
            for n in self._never_seen(looked_for)
            if self.sort.box_for(n) != box and hidden_in(self.recognizers[n].model, holder)
        )

    def _never_seen(self, names: Iterable[str]) -> list[str]:
        """Of `names`, the cloths no survey saw and the job never lost."""
        ledger = self.ledger
        return [n for n in names if n not in ledger.last_seen and n not in ledger.lost]

    def _not_placed(self, attempt: AttemptState, keep: Callable[[str, float], bool]) -> list[str]:
        """The cloths other than the meant one, with a model and not placed, that `keep`
        (name, weight [kg]) takes, in the catalogue's order."""
        placed = set(self.ledger.placed_order)
        return [
            name
            for name, weight in self.weights.items()
            if name != attempt.name and name not in placed and name in self.recognizers and keep(name, weight)
        ]

    def _companion_seen_hanging(self, attempt: AttemptState, extra: float) -> tuple[str | None, str]:
        """The double pick's other cloth named by its own colours seen hanging (`held_look`,
        two looks): among the cloths not placed whose weight is the `extra` [kg] the load
        cell read (seen by a survey, lost, or never seen: one that lay hidden under the
        meant cloth from the start comes up with it and is seen first hanging, held-out
        episode 384, session 28: No.2, never identified, came up with No.7 at three lifts,
        each put back unlooked, as no cloth seen weighed the extra), those that show at
        least `name_share` of the held pixels in their own colours (none of the meant
        cloth's); the one that shows most, or of those within `name_margin` of it the one
        whose weight is nearest the extra (cloths of one hue family show alike: replay of
        held-out episode 139, No.9 and No.11 at 0.385 and 0.376; until session 35 such a pair
        went back unnamed, as booking the wrong one placed left the other on the table for
        good; a companion is booked placed unconfirmed, and one a survey sees on the table
        since is picked again), if all that show go into one box, and if no cloth of another box
        that weighs the extra or less (a part of it) shows `doubt_share` of its own (a white
        one: or of its shade, `HeldColours.shaded`); and a
        note ("" when no cloth weighs the extra, and nothing was looked at). Held-out run
        116-165 (session 23): 61 double picks put back with the other cloth unnamed."""
        s, hl = self.settings, self.settings.held_look
        weighing = self._not_placed(attempt, lambda name, weight: weighs_extra(extra, weight, s))
        if not weighing:
            return None, ""
        # lighter cloths may be the extra two or more at a time (held-out episode 412,
        # session 28: 39 g extra, No.6 and No.18 of whites; No.16, crimson, weighing 39 g
        # and never seen, was named by 13 % of red, No.6's motifs): looked at too
        parts = self._not_placed(attempt, lambda name, weight: name not in weighing and weight < extra)
        self._phase = "look at lift"
        seen, where = look_at_held(self, attempt.name, [*weighing, *parts], looks=2)
        if seen is None:
            return None, where
        attempt.looked = True
        attempt.showed = tuple(n for n in (*weighing, *parts) if seen.own[n] >= hl.doubt_share)
        attempt.hid = self._hid_from_look(attempt, (*weighing, *parts))
        showing = sorted((n for n in weighing if seen.own[n] >= hl.name_share), key=lambda n: -seen.own[n])
        note = (
            f"{seen.pixels} px, {seen.meant:.0%} in {attempt.name}'s colours"
            + "".join(f", {n}'s own {seen.own[n]:.0%}" for n in showing)
            + f"; {where}"
        )
        if seen.pixels < hl.min_pixels or not showing:
            return None, note
        if len({self.sort.box_for(n) for n in showing}) > 1:
            return None, note + ": cloths of both boxes"
        tied = [n for n in showing if seen.own[showing[0]] - seen.own[n] < hl.name_margin]
        if len(tied) > 1:
            # one box, which one is not told by the colours: the nearest the extra weight
            # (booked placed unconfirmed, it is picked again if a survey sees it on the
            # table). Held-out 883 (session 35): No.19 (grey, 20 g, never identified) came
            # up with No.14, showing 31 % of its own against No.4's 22 % (black checks, 23 g,
            # the grey's shade), and the pair went back unnamed and stayed on the table
            showing = sorted(tied, key=lambda n: abs(self.weights[n] - extra))
            others = ", ".join(showing[1:])
            note += f": {showing[0]} not told from {others} by its colours, nearest the extra weight"
        box = self.sort.box_for(showing[0])
        # a white cloth hanging in its own shade reads DARK: held-out episode 688 (session
        # 32), No.18 (white, whites) came up under No.15 and showed 71 % DARK, "No.19's own"
        # (grey melange, colours), and went into colours named No.19
        doubted = [
            f"{n}'s own {share:.0%}"
            for n in (*weighing, *parts)
            if self.sort.box_for(n) != box
            and (share := max(seen.own[n], seen.shaded.get(n, 0.0))) >= hl.doubt_share
        ]
        if doubted:
            return None, note + f": cloths of another box show too ({', '.join(doubted)})"
        if not names_weight(extra, self.weights.get(showing[0]), s):
            grams = self.weights[showing[0]] * 1000
            return None, note + f": {showing[0]} weighs {grams:.0f} g, the extra {extra * 1000:.0f} g"
        return showing[0], note

    def _shed(self, attempt: AttemptState, expected: float, what: str) -> bool:
        """A double pick laid down along a lay-out path without letting go, then lifted
        straight up to where it was and weighed again (`PutBackSettings.shed`): True when
        the meant cloth then weighs alone (the other one stayed on the table, booked as laid
        there); else the caller puts back from where the hand is."""
        self._phase = "shed"
        model = self.recognizers[attempt.name].model
        above = self.motion.tcp_position()
        laid = self.recovery.lay_down(
            self._survey_capture, model, attempt.grasp_point_model, attempt.obstacles_xy, attempt.notes
        )
        if not laid or self.weigh is None:
            return False
        end = self.motion.tcp_position()
        up = end.copy()
        up[2] = above[2]
        self.motion.move_tcp(up)
        weighed = float(self.weigh())
        verdict, again = weight_verdict(weighed, expected, attempt.name, self.settings, lift=True)
        if verdict != "ok":
            attempt.notes.append(f"double pick ({what}): laid down and lifted again, still {again}")
            return False
        attempt.shed_at = (above[:2].copy(), end[:2].copy())
        self._laid.append((attempt, *attempt.shed_at))
        attempt.notes.append(
            f"double pick ({what}): laid down and lifted again, {weighed * 1000:.0f} g: "
            f"{attempt.name} alone, the other cloth left on the table"
        )
        return True

    def _laid_near(self, grasp_xy: FloatArray) -> tuple[str, float] | None:
        """A cloth the job laid back and has not seen since (`TableLedger.lost`, `unnamed`)
        whose laid strip (from the lay-out's start to where it was let go) comes within
        `put_back.free_distance` of `grasp_xy` [m]: (which, how far [m]), or None. Such a
        cloth may be the double pick's other one, whatever else weighs the extra."""
        unnamed_ends = [place.end for place in self.ledger.unnamed]
        for attempt, start, end in self._laid:
            names = [n for n in (attempt.name, *attempt.laid_back_too) if n in self.ledger.lost]
            if attempt.unnamed_along and any(np.allclose(end, e) for e in unnamed_ends):
                names.append(f"the unnamed cloth that came up with {attempt.name}")
            if not names:
                continue
            distance = off_way(grasp_xy, start, end)
            if distance <= self.settings.put_back.free_distance:
                return " and ".join(names), distance
        return None

    def _stayed(self, name: str, attempt: AttemptState, capture: StereoCapture) -> bool:
        """Does the check after the lift (`capture`) still find `name`, one of the pick's
        survey's other cloths, where that survey saw it (then it did not come along)?"""
        seen = next(d for d in attempt.others if d.name == name)
        pose = to_world(self._survey_capture, seen.transform_model_to_camera)
        wall, cpu = time.perf_counter(), time.process_time()
        stayed = still_there(self.recognizers[name], capture, pose, self.settings.same_place)
        attempt.check_wall_s += time.perf_counter() - wall
        self._wait(time.process_time() - cpu, 1)
        return stayed

    def _dragged(
        self, attempt: AttemptState, capture: StereoCapture, extra: float, loop: PickPlaceLoop
    ) -> tuple[tuple[str, ...], int]:
        """When the load cell read `extra` [kg] over the meant cloth, at least `drag_extra`:
        the cloths the pick's survey saw touching the meant one (`drag_reach`) that the
        check after the lift (`capture`) no longer finds where they were, and how many of
        that survey's unknown regions touching it the check sees bared (`_regions_bared`);
        where it sees none gone but some touched it, with `drag_look`, what the look at the
        lifted cloth shows hanging with it (`_drag_look`)."""
        s = self.settings
        if attempt.target is None or s.drag_extra is None or extra < s.drag_extra:
            return (), 0
        held = transform_points(
            attempt.transform_target_to_world, self.recognizers[attempt.name].model.points_in
        )[:, :2]
        touching = [
            d.name
            for d in attempt.others
            if d.name in self.recognizers
            and footprints_touch(
                held,
                transform_points(
                    to_world(self._survey_capture, d.transform_model_to_camera),
                    self.recognizers[d.name].model.points_in,
                )[:, :2],
                s.drag_reach,
            )
        ]
        gone = tuple(name for name in touching if not self._stayed(name, attempt, capture))
        bared, regions = self._regions_bared(attempt, capture, held)
        if gone or bared or not (touching or regions) or not s.drag_look:
            return gone, bared
        apart = {d.name for d in attempt.others} - set(touching)
        return self._drag_look(attempt, extra, apart, loop)

    def _drag_look(
        self, attempt: AttemptState, extra: float, apart: set[str], loop: PickPlaceLoop
    ) -> tuple[tuple[str, ...], int]:
        """A cloth dragged along hangs in part from the lifted one, its part on the scale
        the `extra` [kg] or less: the look at what hangs (`held_look`, two looks) at the
        not-placed cloths that could weigh that much, or more, but those the pick's survey
        saw `apart` from it; any showing `doubt_share` of the held pixels in its own colours
        (none of the meant cloth's) came along. That one (named if it alone shows
        `name_share`, `name_margin` ahead of the rest) and none, or one unnamed cloth: as
        `_dragged`."""
        s, hl = self.settings, self.settings.held_look
        candidates = self._not_placed(
            attempt, lambda name, weight: name not in apart and weight + s.weight_floor >= extra
        )
        if not candidates:
            return (), 0
        self._phase = "look at lift"
        seen, where = look_at_held(self, attempt.name, candidates, looks=2)
        loop.arm.resume_at(self.motion.q)
        if seen is None:
            attempt.notes.append(f"looked for a cloth dragged along: {where}")
            return (), 0
        attempt.looked = True
        showing = sorted((n for n in candidates if seen.own[n] >= hl.doubt_share), key=lambda n: -seen.own[n])
        attempt.showed = tuple(showing)
        attempt.hid = self._hid_from_look(attempt, candidates)
        shown = "".join(f", {n}'s own {seen.own[n]:.0%}" for n in showing)
        attempt.notes.append(
            f"looked for a cloth dragged along: {seen.pixels} px, {seen.meant:.0%} in {attempt.name}'s "
            f"colours{shown}; {where}"
        )
        if seen.pixels < hl.min_pixels or not showing:
            return (), 0
        first = seen.own[showing[0]]
        ahead = len(showing) == 1 or first - seen.own[showing[1]] >= hl.name_margin
        return ((showing[0],), 0) if first >= hl.name_share and ahead else ((), 1)

    def _regions_bared(
        self,
        attempt: AttemptState,
        capture: StereoCapture,
        held_xy: FloatArray,
        touching: list[UnknownRegion] | None = None,
    ) -> tuple[int, int]:
        """Of the unknown regions of the survey that chose the pick touching the meant
        cloth's footprint (`held_xy` (N, 2) [m], within `drag_reach`), how many the check
        after the lift (`capture`, another camera pose) sees bared: at least
        `moved.min_bared` of their inner pixels' table points, outside the meant cloth's
        grown footprint, show the sheet (`table_moved.bared_from_elsewhere`; the pixels
        shrunk by `moved.grow_px` too, for the parallax of a heap's top). Held-out episodes
        1108, 1121 and 1159: the cloth dragged along was an unknown region (a put-back heap,
        a crumpled cloth) beside the one lifted; the notes say what was seen. Also: how many
        touched it. `touching`: those regions where the caller found them already
        (`_regions_touching`)."""
        before, m = self._before_pick, self.settings.moved
        if before is None or before.name != attempt.name or not before.regions:
            return 0, 0
        wall, cpu = time.perf_counter(), time.process_time()
        survey, outside = before.capture, ~grown(before.footprint, m.grow_px)
        points, centres = [], []
        for region in self._regions_touching(attempt, held_xy) if touching is None else touching:
            inner_v, inner_u = np.nonzero(grown(region.mask, m.grow_px, shrink=True) & outside)
            step = max(1, len(inner_u) // 1500)
            inner = self.table.pixels(survey, inner_u[::step], inner_v[::step])
            points.append(np.column_stack([inner, np.full(len(inner), self.table_z)]))
            centres.append(self.table.point(survey, region.centroid))
        if not points:
            self.motion.hold(time.process_time() - cpu)
            return 0, 0
        shares = bared_from_elsewhere(
            points, capture.transform_right_camera_to_world, self.rig.right.camera_matrix,
            self._sheet(capture), m.min_pixels,
        )  # fmt: skip
        attempt.check_wall_s += time.perf_counter() - wall
        self.motion.hold(time.process_time() - cpu)
        bared = 0
        for share, (x, y) in zip(shares, centres, strict=True):
            seen = "out of view" if share is None else f"the sheet shows at {share:.0%} of it"
            attempt.notes.append(f"the unknown region at ({x:.2f}, {y:.2f}) beside {attempt.name}: {seen}")
            bared += int(share is not None and share >= m.min_bared)
        return bared, len(points)

    def _regions_touching(self, attempt: AttemptState, held_xy: FloatArray) -> list[UnknownRegion]:
        """The unknown regions of the survey that chose the pick (`_BeforePick`) whose pixels
        outside the meant cloth's grown footprint come within `drag_reach` of its footprint
        on the table (`held_xy` (N, 2) [m]): cloths nobody identified lying beside it."""
        before, s = self._before_pick, self.settings
        if before is None or before.name != attempt.name or not before.regions:
            return []
        outside = ~grown(before.footprint, s.moved.grow_px)
        touching = []
        for region in before.regions:
            v, u = np.nonzero(region.mask & outside)
            step = max(1, len(u) // 1500)
            if footprints_touch(
                held_xy, self.table.pixels(before.capture, u[::step], v[::step]), s.drag_reach
            ):
                touching.append(region)
        return touching

    def _remembered_companion(
        self, attempt: AttemptState, capture: StereoCapture, grasp: FloatArray, extra: float
    ) -> str | None:
        """The double pick's other cloth among those an earlier survey saw and the pick's
        survey did not (`pick_checks.remembered_companion`), if the check after the lift
        (`capture`) no longer finds it where it was last seen; never a cloth the job moved
        since (`TableLedger.remembered_poses`)."""
        seen = {attempt.name, *(d.name for d in attempt.others)}
        footprints = {
            name: transform_points(pose, self.recognizers[name].model.points_in)[:, :2]
            for name, pose in self.ledger.remembered_poses(seen).items()
            if name in self.recognizers
        }
        name = remembered_companion(grasp[:2], extra, footprints, self.weights, self.settings)
        if name is None:
            return None
        wall, cpu = time.perf_counter(), time.process_time()
        stayed = still_there(
            self.recognizers[name], capture, self.ledger.last_pose[name], self.settings.same_place
        )
        attempt.check_wall_s += time.perf_counter() - wall
        self._wait(time.process_time() - cpu, 1)
        return None if stayed else name

    def check_carried(self, attempt: AttemptState) -> None:
        """Over the box, before the release: does the hand still carry the cloths that came
        along with the meant one (`AttemptState.came_along`)? Those the load cell no longer
        reads (`fell_on_the_way`) fell on the way: not placed, booked lost along the way
        (`AttemptState.fell`, `TableLedger.record_attempt`)."""
        expected = self.weights.get(attempt.name)
        if not attempt.came_along or self.weigh is None or expected is None:
            return
        weighed = float(self.weigh())
        along = {name: self.weights.get(name) for name in attempt.came_along}
        fell = fell_on_the_way(weighed, expected, along, self.settings)
        if fell:
            attempt.fell = fell
            attempt.came_along = tuple(name for name in attempt.came_along if name not in fell)
            attempt.notes.append(f"{weighed * 1000:.0f} g over the box: {' and '.join(fell)} fell on the way")

    def _after_release(self, attempt: AttemptState, loop: PickPlaceLoop) -> None:
        """Checks the box (`check_box`); the loop's HOME then starts from the look."""
        self.check_box(attempt)
        loop.arm.resume_at(self.motion.q)

    # ------------------------------------------------------------------ hand-over (also `table_lost`)
    @property
    def survey_capture(self) -> StereoCapture:
        """The capture of the job's last survey."""
        return self._survey_capture

    def set_phase(self, phase: str, meant: str | None) -> None:
        """Names what the job's next motions do, and for which cloth (its callbacks)."""
        self._phase, self._meant = phase, meant

    def check_box(self, attempt: AttemptState, shadow_proof: bool = False) -> None:
        """After a release: looks into the box from above it (`box_check.look_tcp`, as
        `_look_at_boxes`: the release pose's camera saw a quarter of the floor; out of
        reach: from the release pose, noted) and checks it (`check_release`). Not
        `shadow_proof` (a release, not a drop): where the look sees a cloth over a wall's
        rim, lays it again (`_check_rim`)."""
        self._phase = "box check"
        height = self.settings.box_view_height
        at_look = True
        try:
            self.motion.move_tcp(look_tcp(attempt.box.centre, height, self.camera_offset()))
        except IKError:
            at_look = False
            attempt.notes.append("box looked into from the release pose: the look above it is out of reach")
        capture = self.cell.capture()
        recognizer = self.recognizers[attempt.name]
        check_release(attempt, capture, self.rig, recognizer, self._views, self.box_settings, shadow_proof)
        self._measure_heap(attempt, capture)
        if at_look and not shadow_proof:
            self._check_rim(attempt, capture)

    def _measure_heap(self, attempt: AttemptState, capture: StereoCapture) -> None:
        """How high the box's cloths heap up, from the check's pair (`clear.box_heap`)."""
        if self.settings.box_heap:
            cpu = time.process_time()
            recognizer = self.recognizers[attempt.name]
            model, depth = recognizer.model, recognizer.settings.depth
            top = contents_top(capture, self.rig, attempt.box, model, depth, self.settings.surface)
            self._box_heaps[attempt.box.name] = top
            self._wait(time.process_time() - cpu, 1)

    def _rim_view(self, box: BoxPlace, capture: StereoCapture) -> RimView:
        return rim_view(
            capture,
            self.rig,
            box.centre,
            box.inner_size,
            box.wall_height,
            box.wall_thickness,
            self.box_settings,
        )

    def _check_rim(self, attempt: AttemptState, capture: StereoCapture) -> None:
        """Compares the box's rim in the check's look with the look before the release
        (`box_check.rim_runs`); while a run of a wall's rim changed by `rim_run` or more
        (a cloth hangs over it), lays the box's top cloth again (`box_rim.lay_again`, at most
        `clear.rim_tries` times: first from the box's middle, then from inside that wall
        where the cloth crosses it, `clear.rim_grasp_inset`) and looks again; notes each.
        The last look's rim is the next check's reference, so a cloth left over a wall is
        not blamed on the next."""
        box = attempt.box
        rim = self._rim_view(box, capture)
        before = self._rims.get(box.name)
        tries = 0
        while before is not None:
            covered, along = rim_runs(before, rim, self.box_settings)
            if float(covered.max()) < self.box_settings.rim_run:
                if tries:
                    attempt.notes.append(f"laid again {tries} time(s): the rim is clear")
                break
            note = over_wall_note(covered, box.name)
            if tries >= self.settings.rim_tries:
                attempt.notes.append(
                    note + (": left so" if tries else ": not laid again (clear.rim_tries 0)")
                )
                break
            attempt.notes.append(note + ": laid again")
            tries += 1
            wall = int(np.argmax(covered))
            inset = self.settings.rim_grasp_inset if tries > 1 else None  # the middle first
            again = lay_again(self, attempt, wall, capture, float(along[wall]), inset)
            if again is None:
                break
            capture = again
            rim = self._rim_view(box, again)
            view = box_view(again, self.rig, box.centre, box.inner_size, self.box_settings)
            if float(np.mean(view.in_view)) >= self.box_settings.min_in_view:
                self._views[box.name] = view
            self._measure_heap(attempt, again)
        self._rims[box.name] = rim

    def box_heap(self, box: str) -> float:
        """How high the cloths in `box` heap over its floor [m], as its last check measured
        (`clear.box_heap`; 0 before any, or off)."""
        return self._box_heaps.get(box, 0.0)

    def fell_into_box(self, attempt: AttemptState) -> bool:
        """After the gripper came empty over the box: did the cloth fall into its box on the
        way (`check_box`: the box changed in its colours)? Then it is placed, not lost. In
        the held-out bench runs 384-737 (sessions 28-32), 8 cloths booked dropped ended in
        their box with no attempt after the drop: booked lost all the same, looked for
        around the table, and their colours kept the region of a cloth never identified from
        being guessed (724: No.15 in colours, No.14, same hue, left on the table)."""
        if not self.settings.drop_box_check or attempt.came_along:
            return False  # of several held, the look could not tell which fell in
        self.check_box(attempt, shadow_proof=True)  # a moved shadow is no dark cloth
        check = attempt.box_check
        if check is None or not check.confirmed:
            return False
        attempt.notes.append(f"it lies in {attempt.box.name}: fell into its box on the way")
        return True

    def put_back(self, attempt: AttemptState, grasp_point_model: FloatArray | None) -> None:
        """Lays a rejected lift back onto free table (`TableRecovery.put_back`, from over where
        it was lifted if a look took it out of a blind grasp's reach) and books where it let
        go; the arm stays above the laid cloth (a loop run then resumes there,
        `ArmMotion.resume_at`)."""
        self._phase = "put back"
        model = self.recognizers[attempt.name].model
        start, end = self.recovery.put_back(
            self._survey_capture,
            model,
            grasp_point_model,
            attempt.obstacles_xy,
            attempt.notes,
            attempt.lifted_at,
        )
        attempt.put_back = True
        attempt.put_back_at = end.copy()
        self._laid.append((attempt, start, end))

    def _first_boxes(self) -> tuple[str, ...]:
        """The boxes the first survey's look goes into: every box, or with
        `clear.boxes_when_needed` the one the sort rule sends most known cloths to (the
        first of the cell's boxes among equals)."""
        if not self.settings.boxes_when_needed:
            return tuple(self.boxes)
        counts = Counter(self.sort.box_for(name) for name in self.recognizers)
        return (max(self.boxes, key=lambda box: counts[box]),)

    def _boxes_ahead(self, last: Identification) -> Callable[[], None] | None:
        """With `clear.boxes_when_needed`, the look into the boxes not looked into yet that
        cloths `last` saw go to (their reference views, as `look_into_box` makes them before
        such a pick), to make while the computer identifies the next survey's cloths: the
        arm is free then, and a look before a pick is time the arm does nothing else in."""
        s = self.settings
        if not (s.look_at_boxes and s.boxes_when_needed):
            return None
        boxes = tuple(dict.fromkeys(self.sort.box_for(d.name) for d in last.detections))
        ahead = tuple(box for box in boxes if box not in self._looked_into)
        return (lambda: self._look_at_boxes(ahead, stay=s.straight_from_box)) if ahead else None

    def look_into_box(self, box: str, stay: bool = False) -> None:
        """Before a pick meant for `box`: with `clear.boxes_when_needed`, looks into it if
        no look has yet (its reference view), and returns to where the arm was (`stay`:
        stays there; the pick goes straight on from the box)."""
        s = self.settings
        if s.look_at_boxes and s.boxes_when_needed and box not in self._looked_into:
            self._meant = None
            self._look_at_boxes((box,), back=self.motion.q.copy(), stay=stay)

    def _look_at_boxes(
        self, names: Iterable[str], back: FloatArray | None = None, stay: bool = False
    ) -> None:
        """Looks into the boxes `names` once (the reference of the checks after placing),
        then moves to the joints `back` (None: the observation pose), or with `stay` stays
        over the last box (`clear.straight_from_box`)."""
        camera_offset = self.camera_offset()
        for name in names:
            box = self.boxes[name]
            self._phase = f"look into {box.name}"
            self.motion.move_tcp(look_tcp(box.centre, self.settings.box_view_height, camera_offset))
            capture = self.cell.capture()
            view = box_view(capture, self.rig, box.centre, box.inner_size, self.box_settings)
            self._views[box.name] = (
                view if float(np.mean(view.in_view)) >= self.box_settings.min_in_view else None
            )
            self._rims[box.name] = self._rim_view(box, capture)
            self._looked_into.add(box.name)
        if stay:
            return
        self._phase = "observe"
        self.motion.move_to_joints(self.observation_joints if back is None else back)

    # ------------------------------------------------------------------ helpers
    def camera_offset(self) -> FloatArray:
        """Right camera minus TCP in Σ_W at the observation pose [m] (the hand keeps its orientation)."""
        q = self.observation_joints
        return (
            self.kinematics.frame_pose(q, "camera_right_optical")[:3, 3]
            - self.kinematics.frame_pose(q, "tcp")[:3, 3]
        )

    def _wait(self, seconds: float, recognitions: int, meanwhile: Callable[[], None] | None = None) -> None:
        """Holds the arm while the computer recognises: `clear.survey_latency` if set;
        else, as the loop's own vision (`loop.vision_latency` per recognition, one-shot
        search or check alike), `recognitions` times that; else the measured CPU time
        `seconds`. `meanwhile` (moves of the arm) runs first; the hold is what is left."""
        latency = self.settings.survey_latency
        if latency is None and self.loop_settings.vision_latency is not None:
            latency = recognitions * self.loop_settings.vision_latency
        duration = seconds if latency is None else latency
        if meanwhile is None:
            self.motion.hold(duration)
            return
        ready = self.cell.time + duration
        meanwhile()
        self.motion.hold(max(0.0, ready - self.cell.time))

    def _step(self) -> None:
        if self.on_step is not None:
            self.on_step(self._phase, self._meant)

    def _obstacles_of(self, target: Detection, ident: Identification) -> FloatArray:
        step = self.settings.pile_grasp.obstacle_step_px
        return obstacles_on_table(target, ident, self._survey_capture, self.recognizers, self.table, step)

    def _left(self, last: Identification, seen_by: str = "left at the end") -> dict[str, tuple[str, ...]]:
        """Per known cloth not placed, the unknown regions of the last survey that show its
        colours and the gates the evidence closes (`table_left.left_notes`)."""
        placed = set(self.ledger.placed_order)
        candidates = {n: r for n, r in self.recognizers.items() if n not in placed}
        centres = [np.array(self.table.point(self._survey_capture, r.centroid)) for r in last.unknown]
        notes = left_notes(
            self._survey_capture,
            last.unknown,
            centres,
            candidates,
            self.ledger.lost,
            self.settings.lost,
            self.untried,
            self._grasped_empty,
            seen_by,
        )
        return {name: tuple(texts) for name, texts in notes.items()}

    def _result(
        self,
        last: Identification | None,
        stop_reason: str,
        interrupted: bool,
        start: float,
        wall_start: float,
    ) -> TableResult:
        left = self._left(last) if last is not None and last.unknown and not interrupted else {}
        if not interrupted:
            for name, notes in self._looked_left.items():
                left[name] = (*left.get(name, ()), *notes)
        cloths = self.ledger.cloths(last, self.sort.box_for, self.settings.max_attempts)
        unknown = self.ledger.surveys[-1].unknown if self.ledger.surveys else ()
        cleared = self.ledger.cleared(last, interrupted, cloths)
        return TableResult(
            cloths=cloths,
            attempts=tuple(self.ledger.attempts),
            surveys=tuple(self.ledger.surveys),
            stop_reason=stop_reason,
            cleared=cleared,
            unknown=unknown,
            limit_report=self.cell.limit_report(self.limits),
            collisions=self._collisions + self.motion.collisions,
            sim_time=self.cell.time - start,
            wall_s=time.perf_counter() - wall_start,
            interrupted=interrupted,
            moved_by=tuple(self.ledger.moved_by),
            left=left,
        )


__all__ = ["TableClearer"]
