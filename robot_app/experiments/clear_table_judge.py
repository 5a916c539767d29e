"""The simulator's verdict on a clear-table job: where every cloth of the pile really is.

A known cloth is right when at least `SUCCESS_FRACTION` of its nodes lie inside the walls of
the box the sort rule gives it (at any height: a heap over the rim is the simulated cloth's
thickness, `final_place`); a cloth the robot has no model of is right where it was, on the
table. The verdict also holds what the robot should have noticed and did or did not:
lifts that took two cloths (or the wrong one) and transfers that lost their cloth
(`PickWitness`), and, for an episode not cleared, its cause in words; a cloth not where it
belongs that the simulator flung (`PickWitness.flung`, a soft-body blow-up) says so.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import numpy as np

from robot_app.control.clear_table_records import ClothOutcome, ClothRecord, TableResult
from robot_app.control.sort_rule import SortSettings, cloth_name
from robot_app.experiments.clear_table_faults import Flung, LiftTruth
from robot_app.experiments.pick_place_episode import SUCCESS_FRACTION
from robot_app.sim import World
from robot_app.sim.cloth_body import ClothBody
from robot_app.sim.pile import Pile

TABLE = "table"


@dataclass(frozen=True)
class ClothVerdict:
    """One cloth of the pile at the end.

    Attributes:
        number: catalogue number; name: its model name.
        known: the robot has its model.
        expected: its box (by the sort rule), or "table" for a cloth the robot does not know.
        final: the box holding it, "table", "floor", or "partly in <box>".
        correct: final == expected.
        problem: what went wrong, in words ("" if correct).
        over_rim: share of its nodes over the rim of the box holding it (heaped above the
            walls, inside them) [-]; 0 for a cloth in no box.
    """

    number: int
    name: str
    known: bool
    expected: str
    final: str
    correct: bool
    problem: str = ""
    over_rim: float = 0.0


@dataclass(frozen=True)
class TableVerdict:
    """The whole job against the truth.

    Attributes:
        cloths: one verdict per cloth of the pile, in drop order.
        cleared: every known cloth lies in its box.
        wrong_box: cloths in a box not theirs (an unknown cloth in any box counts).
        double_picks, double_picks_detected: lifts that took two or more cloths; of those,
            the ones the robot noticed (at the lift: weight, check).
        double_picks_noticed_after: of the double picks not noticed at the lift, those
            after which the next survey saw an unidentified cloth moved (`TableResult.moved_by`).
        wrong_lifts, wrong_lifts_detected: lifts without the meant cloth; noticed.
        false_alarms: lifts the robot took for double or wrong that were neither.
        drops, drops_detected: transfers that lost their cloth; noticed.
        unknown_cloths: cloths of the pile the robot has no model of; unknown_reported:
            unknown regions the last survey reported.
        cause: why the episode is not cleared (None when cleared).
        flung: catalogue numbers of the cloths the simulator flung (a node faster than
            `BLOW_UP_SPEED`), wherever they ended.
    """

    cloths: tuple[ClothVerdict, ...]
    cleared: bool
    wrong_box: int
    double_picks: int
    double_picks_detected: int
    wrong_lifts: int
    wrong_lifts_detected: int
    false_alarms: int
    drops: int
    drops_detected: int
    unknown_cloths: int
    unknown_reported: int
    cause: str | None
    flung: tuple[int, ...] = ()
    double_picks_noticed_after: int = 0


def judge(
    world: World,
    pile: Pile,
    result: TableResult,
    lifts: Iterable[LiftTruth],
    sort: SortSettings,
    known: set[str],
    flung: Mapping[int, Flung] | None = None,
) -> TableVerdict:
    """The verdict on the job's end (see the module docstring)."""
    flung = {} if flung is None else flung
    records = {r.name: r for r in result.cloths}
    verdicts = []
    for cloth in pile.cloths:
        name = cloth_name(cloth.number)
        is_known = name in known
        expected = sort.box_for(name) if is_known else TABLE
        final, over_rim = final_place(world, cloth.body)
        problem = (
            "" if final == expected else _problem(name, is_known, expected, final, records.get(name), result)
        )
        if problem and cloth.number in flung:
            f = flung[cloth.number]
            problem += f" [flung by the simulator: a node at {f.speed:.0f} m/s at {f.time:.1f} s, {f.phase}]"
        verdicts.append(
            ClothVerdict(cloth.number, name, is_known, expected, final, final == expected, problem, over_rim)
        )
    double = detected_double = wrong = detected_wrong = alarms = drops = detected_drops = after = 0
    for lift in lifts:
        attempt = next((a for a in result.attempts if a.start_time <= lift.time <= a.end_time), None)
        meant = int(lift.meant.removeprefix("No."))
        noticed = attempt is not None and attempt.not_meant_alone
        if lift.lifted:
            if len(lift.lifted) > 1:
                double += 1
                detected_double += int(noticed)
                number = result.attempts.index(attempt) + 1 if attempt is not None else 0
                after += int(not noticed and number in result.moved_by)
            if meant not in lift.lifted:
                wrong += 1
                detected_wrong += int(noticed)
            if len(lift.lifted) == 1 and meant in lift.lifted and noticed:
                alarms += 1
        if lift.dropped:
            drops += 1
            detected_drops += int(attempt is not None and attempt.dropped)
    known_wrong = [v for v in verdicts if not v.correct]
    cleared = all(v.correct for v in verdicts if v.known)
    causes = [v.problem for v in known_wrong]
    if result.interrupted:
        causes.insert(0, "interrupted")
    return TableVerdict(
        cloths=tuple(verdicts),
        cleared=cleared and not result.interrupted,
        wrong_box=sum(
            1 for v in verdicts if v.final not in (TABLE, v.expected) and v.final in _box_names(world)
        ),
        double_picks=double,
        double_picks_detected=detected_double,
        wrong_lifts=wrong,
        wrong_lifts_detected=detected_wrong,
        false_alarms=alarms,
        drops=drops,
        drops_detected=detected_drops,
        unknown_cloths=sum(1 for v in verdicts if not v.known),
        unknown_reported=len(result.unknown),
        cause="; ".join(causes) if causes else None,
        flung=tuple(c.number for c in pile.cloths if c.number in flung),
        double_picks_noticed_after=after,
    )


def _box_names(world: World) -> set[str]:
    return {box.name for box in world.boxes}


def final_place(world: World, body: ClothBody) -> tuple[str, float]:
    """Where the cloth lies, and the share of its nodes heaped over that box's rim.

    A cloth lies in a box when `SUCCESS_FRACTION` of its nodes are inside the box's walls, at
    any height: the simulated cloth is about 16 mm thick where it touches another (twice
    `world.cloth.collision_margin`, ten times a real one), so three or four crumpled cloths
    heap over the 0.10 m walls of a 0.22 m box (bench episode 3: the third cloth wholly inside
    the walls, 11 % of its nodes up to 20 mm over the rim). That is the box's capacity in the
    simulator, not a cloth outside it; it is reported (`over_rim`), not counted as a miss. A
    cloth the hand still holds (an interrupted job) is in no box."""
    nodes = body.nodes()
    if body.is_grasped:
        return "in the hand", 0.0
    fractions = {box.name: float(np.mean(box.over_floor(nodes))) for box in world.boxes}
    name, best = max(fractions.items(), key=lambda item: item[1])
    if best >= SUCCESS_FRACTION:
        box = next(b for b in world.boxes if b.name == name)
        return name, best - float(np.mean(box.contains(nodes)))
    if best > 0.1:
        return f"partly in {name}", 0.0
    if float(np.median(nodes[:, 2])) < world.config.table.top_z - 0.05:
        return "floor", 0.0
    return TABLE, 0.0


def _problem(
    name: str, known: bool, expected: str, final: str, record: ClothRecord | None, result: TableResult
) -> str:
    if not known:
        return f"{name} (no model) ended in {final}: taken for a known cloth"
    if record is None:
        where = f"left on the {final}" if final == TABLE else f"ended in {final}"
        return f"{name} {where}: never identified"
    last = f": {record.notes[-1]}" if record.notes else ""
    if final == TABLE:
        if record.outcome in (ClothOutcome.PLACED, ClothOutcome.PLACED_UNSEEN):
            return f"{name} released over {expected} but lies on the table"
        attempts = f"{record.attempts} attempt(s) ({record.outcome.value})"
        return f"{name} left on the table after {attempts}{last}"
    return f"{name} ended in {final}, belongs in {expected}{last}"


__all__ = ["ClothVerdict", "TableVerdict", "final_place", "judge"]
