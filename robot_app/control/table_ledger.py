"""The clear-table job's books over one run: each cloth's attempts, time and notes, the
pick attempts and surveys in order, where each cloth was last seen, what was placed and
what was seen in its box; from them, each cloth's final record (`ClothRecord`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np

from robot_app.arrays import FloatArray
from robot_app.control.cell import StereoCapture
from robot_app.control.clear_table_records import (
    ClothOutcome,
    ClothRecord,
    LossKind,
    LostPlace,
    PickAttempt,
    SurveyRecord,
)
from robot_app.control.episode import EpisodeResult, Outcome
from robot_app.control.pick_checks import AttemptState
from robot_app.control.pick_place import EMPTY_GRASP
from robot_app.control.table_survey import TablePlane, to_world
from robot_app.vision.identify import Detection, Identification

STAYED = 0.03  # [m] a cloth seen again this near where it lay before a lift was not in it


def _new_entry() -> dict[str, object]:
    return {"attempts": 0, "sim_time": 0.0, "notes": []}


class TableLedger:
    """What the job did and saw in one run.

    Attributes:
        records: cloth name -> "attempts", "sim_time" [s], "notes", and once known
            "unconfirmed" (the loop's search did not confirm it), "misses" (empty grasps),
            "confirmed" (seen in its box after placing).
        attempts: every pick attempt, in order.
        surveys: every survey, in order.
        seen_in_box: cloths confirmed in their box (no longer searched for).
        placed_order: cloths released over their box, in order.
        last_seen: cloth name -> (x, y) in Σ_W where the last survey saw it [m].
        last_pose: cloth name -> (4, 4) its pose in Σ_W where the last survey saw it [m].
        last_survey: cloth name -> the number (from 1) of the last survey that saw it.
        lost: cloth name -> how and where the job lost it (dropped in a transfer, laid
            back after a lift), for the cloths no survey recognised since and not placed
            since.
        unnamed: where double picks whose other cloth was not named were laid back (that
            cloth is one of the known cloths not placed), once per cloth the extra weight
            held (`AttemptState.unnamed_along`), and wrong lifts no look named
            (`clear.unnamed_wrong_lift`).
        maybe: lost cloth name -> other places it may lie: where blind lifts that could have
            held it (`AttemptState.doubted`) were put back.
        unsure: lost cloth name -> the cloths its last put-back lift could have held instead
            (`AttemptState.doubted`): laid back under its name, it may be one of them.
        seen_again: lost cloth name -> where it was lost, for the lost cloths a survey
            recognised since and no pick has confirmed: a pick whose own search does not
            find it (`not_present`) books it lost there again (`record_attempt`).
        moved_by: numbers (from 1) of the placed attempts that moved a cloth nobody
            identified (`TableClearer._notice_moved`).
        placed_unsure: cloth name -> the other cloths of its box, not placed then, that the
            blind lift which placed it could have been (its region's colours fit them as
            well: `AttemptState.taken_for`); `table_lost.booked_in_stead` may find it later.
    """

    def __init__(self) -> None:
        self.records: dict[str, dict[str, object]] = {}
        self.attempts: list[PickAttempt] = []
        self.surveys: list[SurveyRecord] = []
        self.seen_in_box: set[str] = set()
        self.placed_order: list[str] = []
        self.last_seen: dict[str, FloatArray] = {}
        self.last_pose: dict[str, FloatArray] = {}
        self.last_survey: dict[str, int] = {}
        self.lost: dict[str, LostPlace] = {}
        self.unnamed: list[LostPlace] = []
        self.maybe: dict[str, list[LostPlace]] = {}
        self.unsure: dict[str, tuple[str, ...]] = {}
        self.seen_again: dict[str, LostPlace] = {}
        self.empty_grasps: list[FloatArray] = []  # (2,) where blind grasps closed on nothing [m]
        self.moved_by: list[int] = []
        self.placed_unsure: dict[str, tuple[str, ...]] = {}
        self.placements = 0  # placed attempts so far

    def untried(self, name: str, max_attempts: int) -> bool:
        """Has `name` attempts left? `max_attempts`, and one more (up to twice as many in all)
        whenever a cloth was placed since its last attempt: the pile it failed in is not the
        pile it lies in now. Held-out episodes 415 and 464 (session 29): No.12 and No.18 came
        up with another cloth at every lift and went back until their four attempts were
        spent; then that other cloth was picked alone and placed, and they lay alone on the
        table, seen, and the job stopped ("every cloth still seen has used its attempts")."""
        entry = self.records.get(name, {})
        tried = int(entry.get("attempts", 0))  # type: ignore[call-overload]
        since = self.placements - int(entry.get("placements_at", 0))  # type: ignore[call-overload]
        return tried < max_attempts or (since > 0 and tried < 2 * max_attempts)

    def misses(self, name: str) -> int:
        """Empty grasps at `name` so far."""
        return int(self.records.get(name, {}).get("misses", 0))  # type: ignore[call-overload]

    def remembered_poses(self, seen: set[str]) -> dict[str, FloatArray]:
        """Cloth name -> (4, 4) its pose in Σ_W where a survey last saw it [m], for the cloths
        that may still lie there: not in `seen` (the names the pick's own survey saw), not
        placed, and not moved by the job since (dropped or laid back: `lost`; where such a
        cloth was seen last says nothing of where it lies, nor does its absence from there;
        a cloth booked lost only as hidden there, `hide`, was not moved)."""
        return {
            name: pose
            for name, pose in self.last_pose.items()
            if name not in seen
            and name not in self.placed_order
            and (name not in self.lost or self.lost[name].kind is LossKind.HIDDEN)
        }

    def hide(self, keep: Callable[[str], bool]) -> list[str]:
        """Books lost where a survey last saw them (`LossKind.HIDDEN`) the cloths seen by a
        survey that `keep` takes, neither placed, seen in a box nor lost; returns them."""
        hidden = [
            name
            for name in self.last_seen
            if name not in self.placed_order
            and name not in self.seen_in_box
            and name not in self.lost
            and keep(name)
        ]
        for name in hidden:
            xy = self.last_seen[name].copy()
            how = f"seen by survey {self.last_survey[name]}, not since"
            self.lost[name] = LostPlace(LossKind.HIDDEN, how, xy, xy.copy(), ())
        return hidden

    def _named_wrongly(self, name: str, seen_xy: FloatArray) -> None:
        """`name`, named as a double pick's other cloth and put back with it, seen again
        within `STAYED` of where a survey saw it before that lift: it never came up, and
        the pick's other cloth, put back there, is unnamed (held-out episode 632, session 31:
        No.15, named from under No.6, lay on 11 mm from where it was; No.1, never identified,
        had come up instead and stayed an unknown region by the put-back spot)."""
        place, before = self.lost.get(name), self.last_seen.get(name)
        if place is None or not place.companion_of or before is None:
            return
        if float(np.hypot(*(np.asarray(seen_xy) - before))) <= STAYED:
            how = f"came up with {place.companion_of}, not named ({name} was named for it, and stayed)"
            self.unnamed.append(replace(place, how=how, companion_of=""))

    def record_survey(
        self,
        capture: StereoCapture,
        wall_s: float,
        ident: Identification,
        chosen: Detection | None,
        table: TablePlane,
    ) -> SurveyRecord:
        """Books a survey (its capture, computation time [s], identification, the cloth
        chosen) and where it saw each cloth."""
        detections = []
        for d in ident.detections:
            pose = to_world(capture, d.transform_model_to_camera)
            detections.append((d.name, float(d.confidence), *(float(v) for v in pose[:3, 3])))
            self._named_wrongly(d.name, pose[:2, 3])
            self.last_seen[d.name] = pose[:2, 3].copy()
            self.last_pose[d.name] = pose.copy()
            self.last_survey[d.name] = len(self.surveys) + 1
            if d.name in self.lost:  # recognised again (until a pick's search does not find it)
                self.seen_again.setdefault(d.name, self.lost.pop(d.name))
            self.maybe.pop(d.name, None)
            self.unsure.pop(d.name, None)
            entry = self.records.setdefault(d.name, _new_entry())
            if d.name in self.placed_order and d.name not in self.seen_in_box:
                # booked placed (a double pick's companion, a release not seen in the box),
                # yet on the table: it is not placed, and may be picked again
                self.placed_order.remove(d.name)
                entry["confirmed"] = False
                notes: list[str] = entry["notes"]  # type: ignore[assignment]
                notes.append(f"booked placed, yet seen on the table by survey {len(self.surveys) + 1}")
        record = SurveyRecord(
            capture.time,
            wall_s,
            tuple(detections),  # type: ignore[arg-type]
            ident.dropped,
            ident.above,
            tuple(table.point(capture, region.centroid) for region in ident.unknown),
            None if chosen is None else chosen.name,
        )
        self.surveys.append(record)
        return record

    def record_attempt(
        self, attempt: AttemptState, result: EpisodeResult, end_time: float, expected_weight: float | None
    ) -> None:
        """Books a finished loop run (ended at cell time `end_time` [s])."""
        name, box = attempt.name, attempt.box
        entry = self.records.setdefault(name, _new_entry())
        entry["attempts"] = int(entry["attempts"]) + 1  # type: ignore[call-overload]
        self.placements += int(result.outcome is Outcome.PLACED)
        entry["placements_at"] = self.placements
        entry["sim_time"] = float(entry["sim_time"]) + (end_time - attempt.start_time)  # type: ignore[arg-type]
        notes: list[str] = entry["notes"]  # type: ignore[assignment]
        notes.extend(attempt.notes)
        if result.outcome is not Outcome.PLACED:
            notes.append(f"{result.outcome.value}: {result.reason}")
        if result.outcome is Outcome.NOT_PRESENT:
            entry["unconfirmed"] = True
        again = self.seen_again.pop(name, None)
        if again is not None and result.outcome is Outcome.NOT_PRESENT and name not in self.lost:
            # a survey's recognition the pick's own searches did not confirm is no sign that
            # it left the place it was lost at. Held-out episode 974 (session 36): No.18 (white
            # napkin), put back with No.10, was "recognised" 0.81 by the next survey 16 cm from
            # that heap, not found there by the pick, and, no longer lost, never looked for in
            # the heap, which held it; the job stopped with attempts left
            how = f"{again.how}; a survey recognised it since, the pick's search did not find it"
            self.lost[name] = replace(again, how=how)
        if result.outcome is Outcome.GRASP_FAILED and not attempt.put_back:
            entry["misses"] = int(entry.get("misses", 0)) + 1  # type: ignore[call-overload]
            if attempt.target is None and result.reason.startswith(EMPTY_GRASP):
                self.empty_grasps.append(attempt.transform_target_to_world[:2, 3].copy())
        self.attempts.append(
            PickAttempt(
                name,
                box.name,
                attempt.start_time,
                end_time,
                result,
                attempt.came_along,
                attempt.lift_check,
                attempt.weighed,
                expected_weight,
                attempt.put_back,
                attempt.dropped,
                attempt.box_check,
                attempt.check_wall_s,
                attempt.grasp.clearance if attempt.grasp is not None and attempt.grasp_used else None,
                attempt.remembered,
                attempt.named_by,
                attempt.laid_back_too,
            )
        )
        # a drop seen in its box after all (`TableClearer.fell_into_box`) is placed, not lost
        lost = (attempt.dropped and result.outcome is not Outcome.PLACED) or attempt.put_back
        if lost:
            start = attempt.transform_target_to_world[:2, 3].copy()
            end = (
                box.centre[:2].copy()
                if attempt.dropped or attempt.put_back_at is None
                else attempt.put_back_at
            )
            before = self.surveys[-1].unknown if self.surveys else ()
            if attempt.from_region is not None:
                # the region a blind lift was taken from held the cloth itself: no other
                # cloth lay there for it (replay of held-out 1159, session 40: No.18, in a heap
                # with No.20, was lifted blind, put back, and its region, where it still lay,
                # was taken for another cloth's; the job stopped with it on the table)
                before = tuple(
                    xy for xy in before if float(np.hypot(*(np.asarray(xy) - attempt.from_region))) > 1e-6
                )
            kind = LossKind.DROPPED if attempt.dropped else LossKind.PUT_BACK
            how = "dropped in transfer" if attempt.dropped else "put back after the lift"
            laid = attempt.put_back and attempt.put_back_at is not None  # let go where the job chose
            if attempt.guessed and attempt.put_back and self.unnamed:
                # a guess laid back stays unnamed where it now lies, not lost by that name: a
                # later blind lift of it is a guess again (held-out episode 769, session 33:
                # a lift guessed No.6 went back, its next lift was taken for No.6 by name and
                # No.19 of colours went into whites)
                self.unnamed[-1] = LostPlace(
                    kind, f"laid back after a lift guessed {name}, not named", start, end, before, laid
                )
            else:
                self.lost[name] = LostPlace(kind, how, start, end, before, laid)
            put_back = LossKind.PUT_BACK
            for companion in attempt.came_along if attempt.dropped else ():
                # it hung from the same fingers (held-out episode 404, session 28: No.4, to go
                # into colours with No.10, fell with it, was never looked for and stayed)
                with_it = LostPlace(kind, f"dropped with {name}", start, end, before, laid)
                self.lost.setdefault(companion, with_it)
            for companion in attempt.laid_back_too if attempt.put_back else ():
                self.lost.setdefault(
                    companion,
                    LostPlace(put_back, f"put back with {name}", start, end, before, laid, companion_of=name),
                )
            if attempt.put_back and attempt.doubted:
                self.unsure[name] = attempt.doubted
            elif name in self.unsure:
                del self.unsure[name]
            for doubted in attempt.doubted if attempt.put_back else ():
                if doubted in self.lost:  # the lift may have held it: it may lie there now
                    where = LostPlace(
                        put_back, f"maybe held by {name}'s lift, put back", start, end, before, laid
                    )
                    self.maybe.setdefault(doubted, []).append(where)
            if attempt.put_back and attempt.unnamed_along:
                lifted = "lifted instead of" if attempt.lift_check == "wrong" else "came up with"
                place = LostPlace(
                    put_back,
                    f"{lifted} {name}, not named",
                    start,
                    end,
                    before,
                    laid,
                    attempt.showed,
                    attempt.looked,
                    attempt.hid,
                )
                self.unnamed += [place] * attempt.unnamed_along  # one per cloth the extra weighed
        if attempt.shed_at is not None:  # the other cloth was left lying along the strip
            start, end = attempt.shed_at
            before = self.surveys[-1].unknown if self.surveys else ()
            for companion in attempt.laid_back_too:
                self.lost.setdefault(
                    companion,
                    LostPlace(
                        LossKind.LEFT_BY_LIFT, f"left on the table by {name}'s lift", start, end, before, True
                    ),
                )
            if attempt.unnamed_along:
                how = f"came up with {name}, not named, left on the table"
                self.unnamed += [
                    LostPlace(LossKind.LEFT_BY_LIFT, how, start, end, before, True)
                ] * attempt.unnamed_along
        for companion in attempt.fell:  # it came up with the lift and was gone over the box
            self.lost[companion] = LostPlace(
                LossKind.DROPPED,
                f"fell from {name}'s lift on the way to the box",
                attempt.transform_target_to_world[:2, 3].copy(),
                box.centre[:2].copy(),
                self.surveys[-1].unknown if self.surveys else (),
            )
        if result.outcome is Outcome.PLACED:
            confirmed = attempt.box_check is not None and attempt.box_check.confirmed
            self.placed(name, confirmed)
            unsure = tuple(
                other
                for other in attempt.taken_for
                if other != name and other not in attempt.came_along and other not in self.placed_order
            )
            if unsure:
                self.placed_unsure[name] = unsure
            for companion in attempt.came_along:  # placed too, but looked for again until seen gone
                self.placed(companion, False)
                other: list[str] = self.records[companion]["notes"]  # type: ignore[assignment]
                remembered = companion in attempt.remembered
                source = "; its identity from memory, not from vision" if remembered else ""
                other.append(f"placed with {name}, lifted with it{source}")

    def placed(self, name: str, confirmed: bool) -> None:
        """Books `name` released over its box (`confirmed`: seen there)."""
        entry = self.records.setdefault(name, _new_entry())
        entry["confirmed"] = confirmed
        self.lost.pop(name, None)
        self.maybe.pop(name, None)
        self.unsure.pop(name, None)
        self.seen_again.pop(name, None)
        if name not in self.placed_order:
            self.placed_order.append(name)
        if confirmed:
            self.seen_in_box.add(name)

    def still_unsure(self) -> dict[str, tuple[str, ...]]:
        """Cloth name -> the cloths not placed yet that the blind lift which placed it could
        have been (`placed_unsure`), for the cloths still booked placed with one at least."""
        placed = set(self.placed_order)
        unsure = {
            name: tuple(other for other in others if other not in placed)
            for name, others in self.placed_unsure.items()
            if name in placed
        }
        return {name: others for name, others in unsure.items() if others}

    def swap_placed(self, placed: str, instead: str, how: str) -> None:
        """`placed`, booked placed by a blind lift that could have been `instead`
        (`placed_unsure`), is on the table (`how`): that lift was `instead`."""
        confirmed = bool(self.records.get(placed, {}).get("confirmed", False))
        self.placed_unsure.pop(placed, None)
        self.reopen(placed, how)
        self.placed(instead, confirmed)
        self.note(instead, f"placed earlier by a blind lift booked as {placed} ({how})")

    def note(self, name: str, text: str) -> None:
        """Adds `text` to `name`'s notes."""
        notes: list[str] = self.records.setdefault(name, _new_entry())["notes"]  # type: ignore[assignment]
        notes.append(text)

    def reopen(self, name: str, how: str) -> None:
        """`name`, booked placed and seen in its box, is on the table (`how`): not placed."""
        self.seen_in_box.discard(name)
        if name in self.placed_order:
            self.placed_order.remove(name)
        entry = self.records.setdefault(name, _new_entry())
        entry["confirmed"] = False
        notes: list[str] = entry["notes"]  # type: ignore[assignment]
        notes.append(how)

    def cloths(
        self, last: Identification | None, box_for: Callable[[str], str], max_attempts: int
    ) -> tuple[ClothRecord, ...]:
        """Each cloth's final record, given the last survey's identification."""
        records = []
        still_seen = {d.name for d in last.detections} if last is not None else set()
        for name, entry in self.records.items():
            order = self.placed_order.index(name) + 1 if name in self.placed_order else None
            if order is not None and name not in still_seen:
                outcome = ClothOutcome.PLACED if entry.get("confirmed") else ClothOutcome.PLACED_UNSEEN
            elif not self.untried(name, max_attempts):
                outcome = ClothOutcome.FAILED
            else:
                outcome = ClothOutcome.LEFT
            if order is not None and name in still_seen:
                order = None  # released over its box, yet seen on the table again
            records.append(
                ClothRecord(
                    name,
                    box_for(name),
                    order,
                    int(entry["attempts"]),  # type: ignore[call-overload]
                    float(entry["sim_time"]),  # type: ignore[arg-type]
                    outcome,
                    tuple(entry["notes"]),  # type: ignore[arg-type]
                )
            )
        return tuple(records)

    def cleared(
        self, last: Identification | None, interrupted: bool, cloths: tuple[ClothRecord, ...]
    ) -> bool:
        """Did the job end with the table cleared: not stopped, the last survey chose
        nothing and saw no known cloth, every cloth placed?"""
        return (
            not interrupted
            and bool(self.surveys)
            and self.surveys[-1].chosen is None
            and not (last.detections if last is not None else ())
            and all(r.outcome in (ClothOutcome.PLACED, ClothOutcome.PLACED_UNSEEN) for r in cloths)
        )


__all__ = ["TableLedger"]
