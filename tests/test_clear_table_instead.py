"""A blind lift named by its weight after cloths of one box (`weighed_as`) is doubted
for the cloths of another box that would weigh as much in their stead
(`table_lost.weighs_instead`): held-out episode 304, session 26."""

from __future__ import annotations

from dataclasses import replace
from types import SimpleNamespace

import numpy as np

from robot_app.control.clear_table_records import ClearTableSettings
from robot_app.control.table_lost import weighs_instead, with_the_meant
from robot_app.geometry import make_transform

WEIGHTS = {"No.18": 0.0209, "No.17": 0.0201, "No.9": 0.0162, "No.4": 0.0160, "No.2": 0.0163, "No.7": 0.080}
BOXES = {name: "whites" for name in ("No.18", "No.17", "No.4")} | {
    name: "colours" for name in ("No.9", "No.2", "No.7")
}
# every model a 0.2 m square of points around its origin
SQUARE = np.array([[x, y, 0.0] for x in np.linspace(-0.1, 0.1, 11) for y in np.linspace(-0.1, 0.1, 11)])
GRASP = (0.58, -0.20)


def _at(x: float, y: float) -> np.ndarray:
    return make_transform(np.eye(3), [x, y, 0.0])


def _job(lost=(), seen=None, placed=(), surveys=7) -> SimpleNamespace:
    """`seen`: name -> (the number of the last survey that saw it, where)."""
    seen = seen or {}
    ledger = SimpleNamespace(
        placed_order=list(placed),
        surveys=[None] * surveys,
        last_survey={name: survey for name, (survey, _) in seen.items()},
        last_pose={name: pose for name, (_, pose) in seen.items()},
        lost=dict.fromkeys(lost),
        unnamed=[],
        placed_unsure={},  # no blind lift booked unsure
        still_unsure=dict,
        records={},  # no attempts spent
    )
    return SimpleNamespace(
        ledger=ledger,
        untried=lambda name: True,
        weights=WEIGHTS,
        recognizers={name: SimpleNamespace(model=SimpleNamespace(points_in=SQUARE)) for name in WEIGHTS},
        sort=SimpleNamespace(box_for=BOXES.__getitem__),
        settings=ClearTableSettings(),
        tones_only=lambda name: name in ("No.17", "No.18", "No.19", "No.20"),  # the catalogue's
    )


def test_a_cloth_of_the_other_box_that_weighs_as_much_as_one_of_the_lift_is_named() -> None:
    # No.18 and No.17 read 41 g; No.9 (colours) with No.17 weighs as much: lost, or a
    # candidate of the last survey 4 cm from the grasp (episode 304)
    assert weighs_instead(
        _job(lost=("No.18", "No.9", "No.4")), "whites", ("No.18", "No.17"), 0.041, GRASP
    ) == ("No.9",)
    near = _job(lost=("No.18",), seen={"No.9": (7, _at(0.54, -0.196))})
    assert weighs_instead(near, "whites", ("No.18", "No.17"), 0.041, GRASP) == ("No.9",)
    # hidden since an earlier survey, wherever it was seen; a single cloth named by its weight
    hidden = _job(seen={"No.2": (3, _at(0.2, 0.3))})
    assert weighs_instead(hidden, "whites", ("No.17",), 0.0170, GRASP) == ("No.2",)


def test_cloths_that_cannot_be_in_the_lift_are_not_named() -> None:
    lift = ("No.18", "No.17")
    # same box (No.4), heavier than the whole lift (No.7), placed (No.9)
    assert weighs_instead(_job(lost=("No.4", "No.7")), "whites", lift, 0.041, GRASP) == ()
    assert weighs_instead(_job(lost=("No.9",), placed=("No.9",)), "whites", lift, 0.041, GRASP) == ()
    # seen by the last survey with its footprint 10 cm from the grasp: it lies apart
    apart = _job(seen={"No.9": (7, _at(0.58, 0.0))})
    assert weighs_instead(apart, "whites", lift, 0.041, GRASP) == ()
    # one cloth named by its weight: a cloth heavier than the reading cannot be in it
    assert weighs_instead(_job(lost=("No.7",)), "whites", ("No.17",), 0.0280, GRASP) == ()


def test_a_lift_named_as_one_cloth_is_doubted_for_the_other_box_cloths_that_could_be_in_it() -> None:
    # held-out episode 328 (session 27): a blind lift meant for No.8 read 43 g, the weight of
    # its alike No.16 alone (colours); it held No.8 and the dragged No.17 (whites, 24 g), lost
    # nearby after a put-back, and No.17 went into colours
    weights = {"No.8": 0.0212, "No.16": 0.0430, "No.17": 0.0240, "No.6": 0.080}
    job = _job(lost=("No.8", "No.17", "No.6"))
    job.weights = weights
    job.recognizers = dict.fromkeys(weights)
    job.sort = SimpleNamespace(box_for=lambda name: "whites" if name in ("No.17", "No.6") else "colours")
    assert weighs_instead(job, "colours", ("No.16",), 0.0427, GRASP) == ("No.17",)  # not No.6: 80 g


def test_a_heap_named_as_several_cloths_is_doubted_for_the_other_box_cloths_that_could_be_in_it() -> None:
    # episode 299 on 7941f33: 65 g named "No.16 and No.3" (colours) held No.19, No.3 and
    # No.17 (whites, 24 g): no one-for-one swap weighs 65 g, but No.17 could be in it
    whites = {"No.16": 0.0308, "No.3": 0.0224, "No.17": 0.0240, "No.18": 0.120}
    job = _job(lost=("No.17", "No.18"))
    job.weights = whites
    job.recognizers = dict.fromkeys(whites)
    job.sort = SimpleNamespace(box_for=lambda name: "whites" if name in ("No.17", "No.18") else "colours")
    assert weighs_instead(job, "colours", ("No.16", "No.3"), 0.0653, GRASP) == ("No.17",)  # not No.18: 120 g


def test_a_lift_that_weighs_the_meant_cloth_with_one_of_the_other_box_is_not_named() -> None:
    # held-out episode 328 (session 27): meant No.8 (21 g), read 43 g: No.16's weight alone,
    # or No.8 with the dragged No.17 (24 g, whites), hidden inside it from the look
    weights = {"No.8": 0.0212, "No.16": 0.0430, "No.17": 0.0240, "No.12": 0.0109, "No.6": 0.045}
    s = ClearTableSettings()
    assert with_the_meant(0.0427, ("No.8",), ("No.17", "No.6"), weights, s) == ("No.17",)
    assert with_the_meant(0.0427, ("No.8",), ("No.12",), weights, s) == ()  # 11 g: not the 21 g added
    assert with_the_meant(0.0427, ("No.5",), ("No.17",), weights, s) == ()  # meant weight unknown
    # its replay: the match was the guess No.16 (32 g), No.8 one of its alike; 45 g
    weights["No.16"] = 0.032
    assert with_the_meant(0.0452, ("No.16",), ("No.17",), weights, s) == ()
    assert with_the_meant(0.0452, ("No.16", "No.8", "No.12"), ("No.17",), weights, s) == ("No.17",)


def test_a_lift_that_weighs_its_named_cloths_with_one_of_the_other_box_is_not_named() -> None:
    # replay of held-out episode 540 (session 30): a blind lift meant for No.11 (27.5 g) read
    # 67 g, named "No.11 and No.4" (50 g: within the tolerance); it held No.17 of whites
    # (24 g) too, hidden inside, which no single meant cloth's weight explains with it
    weights = {"No.11": 0.0275, "No.4": 0.0224, "No.17": 0.0238}
    s = ClearTableSettings()
    assert with_the_meant(0.0672, ("No.11", "No.4"), ("No.17",), weights, s) == ()
    assert with_the_meant(0.0672, ("No.11", "No.4"), ("No.17",), weights, s, ("No.11", "No.4")) == ("No.17",)
    # a lighter cloth of the other box is not what is left over (17 g is not 8 g's)
    weights["No.12"] = 0.008
    assert with_the_meant(0.0672, ("No.11", "No.4"), ("No.12",), weights, s, ("No.11", "No.4")) == ()
    # a named cloth of unknown weight: no sum to add to
    assert with_the_meant(0.0672, ("No.11",), ("No.17",), weights, s, ("No.11", "No.5")) == ()


def test_lost_cloths_of_the_box_that_may_lie_at_the_grasp_join_the_lift_s_naming() -> None:
    """Held-out episode 407 (session 28): No.8 and No.2, both colours, came up together at
    five lifts; the region showed only No.8's orange (No.2 hung inside), so No.2 was no
    alike of it, and every 45 g lift went back. `lost_with` gives the lost cloths of the
    lift's box that may lie at the grasp, and `weighed_as` names the lift after both."""
    from robot_app.control.clear_table_records import LossKind, LostPlace
    from robot_app.control.table_lost import lost_with, weighed_as

    def place(start, end):
        return LostPlace(LossKind.PUT_BACK, "put back", np.array(start), np.array(end), (), True)

    job = _job()
    job.ledger.lost = {
        "No.9": place((0.55, -0.20), (0.60, -0.20)),  # colours, laid back where the grasp is
        "No.2": place((0.55, -0.20), (0.58, -0.10)),  # colours, there too
        "No.18": place((0.55, -0.20), (0.58, -0.20)),  # whites: another box, never with it
        "No.7": place((0.10, 0.40), (0.10, 0.50)),  # colours, lost far from the grasp
    }
    partners = lost_with(job, "No.9", "colours", GRASP)
    assert partners == ("No.2",)
    assert weighed_as(0.0325, "No.9", partners, WEIGHTS, job.settings) == ("No.9", "No.2")
    job.ledger.placed_order.append("No.2")  # placed since: not in any lift
    assert lost_with(job, "No.9", "colours", GRASP) == ()


def test_suspects_of_an_unnamed_companion_put_back_where_the_grasp_is_join_the_lift_s_naming() -> None:
    """Held-out episode 415 (session 29): No.12 came up with No.20 (colours both, 38 g) at
    four blind lifts, each put back; No.20 was seen by the first survey only and had come up,
    unnamed, with the put-back double pick the grasp's region lay at. It may be the lift's
    second cloth as a lost cloth of its box may."""
    from robot_app.control.clear_table_records import LossKind, LostPlace
    from robot_app.control.table_lost import lost_with, weighed_as

    weights = WEIGHTS | {"No.12": 0.0109, "No.20": 0.0235}
    job = _job(seen={"No.20": (1, _at(0.5, 0.1)), "No.2": (7, _at(0.5, 0.1)), "No.4": (2, _at(0.5, 0.1))})
    job.weights = weights
    job.sort = SimpleNamespace(box_for=lambda name: BOXES.get(name, "colours"))
    unnamed = LostPlace(
        LossKind.PUT_BACK, "came up with No.15, not named", np.array(GRASP), np.array(GRASP), ()
    )
    assert lost_with(job, "No.12", "colours", GRASP) == ()  # no unnamed companion laid there
    job.ledger.unnamed.append(unnamed)
    # No.20: hidden since survey 1; No.2 is seen by the last survey (7); No.4 is of whites
    partners = lost_with(job, "No.12", "colours", GRASP)
    assert partners == ("No.20",)
    assert weighed_as(0.0384, "No.12", partners, weights, job.settings) == ("No.12", "No.20")
    far = LostPlace(
        LossKind.PUT_BACK, "came up with No.15, not named", np.array((0.1, 0.5)), np.array((0.1, 0.6)), ()
    )
    job.ledger.unnamed[:] = [far]  # laid back far from this grasp
    assert lost_with(job, "No.12", "colours", GRASP) == ()


def test_a_guess_that_may_lie_at_the_grasp_may_be_named_with_the_meant_cloth() -> None:
    # replay of held-out episode 475 (session 29): No.17 and No.6 (whites) came up together,
    # 46 g; No.6 was the match's alike as a guess (seen by survey 3, hidden since), taken
    # only alone, and every lift went back
    from robot_app.control.table_lost import LostMatch, lift_candidates, weighed_as

    weights = {"No.17": 0.0241, "No.6": 0.0225}
    match = LostMatch("No.17", None, 0.88, alike=("No.6",), guessed=frozenset({"No.6"}))  # type: ignore[arg-type]
    s = ClearTableSettings()
    along, only_alone = lift_candidates(match, ())
    assert weighed_as(0.046, "No.17", along, weights, s, alone_only=only_alone) == ()  # a guess: alone
    along, only_alone = lift_candidates(match, ("No.6",))  # a suspect of an unnamed put-back there
    assert along == ("No.6",) and only_alone == frozenset()
    assert weighed_as(0.046, "No.17", along, weights, s, alone_only=only_alone) == ("No.17", "No.6")


def test_a_never_seen_cloth_that_showed_hanging_from_an_unnamed_put_back_nearby_is_doubted() -> None:
    # held-out episode 514 (session 29): No.1 (colours, never identified) came up with No.18
    # (whites) and showed 11 % of its own colours hanging; the pair was put back unnamed, and a
    # blind lift there, named "No.6 and No.18" by its weight, took No.1 into whites
    from robot_app.control.clear_table_records import LossKind, LostPlace

    job = _job(lost=("No.18",))
    lift = ("No.18", "No.17")
    assert weighs_instead(job, "whites", lift, 0.041, GRASP) == ()  # No.9 never seen: not doubted
    showed = LostPlace(
        LossKind.PUT_BACK,
        "came up with No.18, not named",
        np.array(GRASP),
        np.array(GRASP),
        (),
        True,
        ("No.9", "No.4"),
        looked=True,
    )
    job.ledger.unnamed.append(showed)
    assert weighs_instead(job, "whites", lift, 0.041, GRASP) == ("No.9",)  # No.4: same box
    assert with_the_meant(0.041, ("No.18",), ("No.9",), WEIGHTS, job.settings) == ("No.9",)  # 21 + 16 g
    far = LostPlace(
        LossKind.PUT_BACK,
        "came up with No.18, not named",
        np.array((0.1, 0.5)),
        np.array((0.1, 0.6)),
        (),
        True,
        ("No.9",),
        looked=True,
    )
    job.ledger.unnamed[:] = [far]
    assert weighs_instead(job, "whites", lift, 0.041, GRASP) == ()


def test_never_seen_cloths_may_be_in_a_blind_lift_where_a_double_pick_was_put_back_unlooked() -> None:
    # held-out episode 615 (session 31): No.16 came up with No.5 and No.18 (whites, never
    # identified): 79 g, 47 g extra, which no one cloth weighs, so no one looked at what hung;
    # put back unnamed, a blind lift there of No.16's weight held No.18 and went into colours
    from robot_app.control.clear_table_records import LossKind, LostPlace

    job = _job(lost=("No.2",), seen={"No.9": (3, _at(0.2, 0.3))})
    unlooked = LostPlace(
        LossKind.PUT_BACK, "came up with No.2, not named", np.array(GRASP), np.array(GRASP), (), True
    )
    assert weighs_instead(job, "colours", ("No.2",), 0.0210, GRASP) == ()
    job.ledger.unnamed.append(unlooked)
    # never seen, of another box and not heavier than the reading: No.17, No.18 and No.4,
    # to be looked for (`unlooked`), not to put a lift back unlooked (`with_the_meant`)
    assert weighs_instead(job, "colours", ("No.2",), 0.0210, GRASP, unlooked=True) == (
        "No.17",
        "No.18",
        "No.4",
    )
    assert weighs_instead(job, "colours", ("No.2",), 0.0210, GRASP) == ()
    looked = replace(unlooked, looked=True)  # looked at: only what showed hanging
    job.ledger.unnamed[:] = [looked]
    assert weighs_instead(job, "colours", ("No.2",), 0.0210, GRASP, unlooked=True) == ()
    job.ledger.unnamed[:] = [replace(looked, showed=("No.18",))]
    assert weighs_instead(job, "colours", ("No.2",), 0.0210, GRASP) == ("No.18",)
    # a never-seen cloth that look could not show (`hid`, session 49): to be looked for only
    job.ledger.unnamed[:] = [replace(looked, hid=("No.18",))]
    assert weighs_instead(job, "colours", ("No.2",), 0.0210, GRASP, unlooked=True) == ("No.18",)
    assert weighs_instead(job, "colours", ("No.2",), 0.0210, GRASP) == ()


def _carrying_job(lost: tuple[str, ...], reading: float) -> tuple[SimpleNamespace, list]:
    """A job holding a blind lift that reads `reading` [kg], recording its put-backs and
    placings."""
    from robot_app.control.clear_table_records import BoxPlace

    events: list = []
    job = _job(lost=lost)
    job.weigh = lambda: reading
    job.loop_settings = SimpleNamespace(gripper_open=0.08)
    job.table_z = 0.0
    job.put_back = lambda attempt, _: events.append(("put back", attempt.lost_name))
    job.set_phase = lambda *a: None
    job.motion = SimpleNamespace(tcp_position=lambda: np.zeros(3))
    job.cell = SimpleNamespace(holding=lambda: True, time=0.0)
    job.check_carried = lambda attempt: None
    job.check_box = lambda attempt: events.append(("placed", attempt.box.name))
    job.hanging_reach = lambda name: 0.1
    job.box_heap = lambda box: 0.0
    job.on_phase = None
    job.box = BoxPlace("colours", np.array([0.3, -0.56, 0.0]), 0.22, 0.1, 0.01)
    return job, events


def _carrying_looked(monkeypatch, look, meant: str):
    """Patches `table_lost` so that a carry looks by `look` and moves nothing; returns the
    put-back place of a double pick with `meant`, its other cloth unnamed and unlooked."""
    from robot_app.control import table_lost
    from robot_app.control.clear_table_records import LossKind, LostPlace

    monkeypatch.setattr(table_lost, "look_at_held", look)
    monkeypatch.setattr(table_lost, "carry_over_box", lambda *a: None)
    monkeypatch.setattr(table_lost, "release_into_box", lambda *a: None)
    how = f"came up with {meant}, not named"
    return LostPlace(LossKind.PUT_BACK, how, np.array(GRASP), np.array(GRASP), (), True)


def test_a_blind_lift_of_the_meant_cloth_s_weight_is_looked_at_for_another_box_s_cloth(monkeypatch) -> None:
    # held-out episode 622 (session 31): a blind lift meant for No.2 (16 g here) read its
    # weight; it held No.18 (whites, 21 g, lost after put-backs of its own) and went into colours
    from robot_app.control import table_lost
    from robot_app.control.episode import Outcome
    from robot_app.control.held_look import HeldColours
    from robot_app.control.pick_checks import AttemptState
    from robot_app.control.table_lost import LostMatch, _carry

    looks: list = []

    def look(job, name, doubted, fit=False, along=()):
        looks.append((name, doubted))
        return HeldColours(2000, 0.2, dict.fromkeys(doubted, 0.7)), "looked from 20 cm aside"

    monkeypatch.setattr(table_lost, "look_at_held", look)
    monkeypatch.setattr(table_lost, "carry_over_box", lambda *a: None)
    monkeypatch.setattr(table_lost, "release_into_box", lambda *a: None)
    job, events = _carrying_job(("No.2", "No.18"), 0.0170)
    attempt = AttemptState(None, job.box, _at(*GRASP), 0.0, lost_name="No.2")
    outcome, why = _carry(job, attempt, LostMatch("No.2", None, 0.9))  # type: ignore[arg-type]
    assert looks == [("No.2", ("No.18",))]
    assert outcome is Outcome.GRASP_FAILED and "not sure" in why
    assert events == [("put back", "No.2")]

    # nothing of another box could be in it (No.18 placed): no look, into the box
    looks.clear()
    job, events = _carrying_job(("No.2",), 0.0170)
    job.ledger.placed_order.append("No.18")
    attempt = AttemptState(None, job.box, _at(*GRASP), 0.0, lost_name="No.2")
    outcome, _ = _carry(job, attempt, LostMatch("No.2", None, 0.9))  # type: ignore[arg-type]
    assert outcome is Outcome.PLACED
    assert looks == [] and events == [("placed", "colours")]


def test_a_never_seen_cloth_must_show_its_own_colours_a_lost_one_only_fit_as_well(monkeypatch) -> None:
    # held-out 651 on fe0a83a: No.7 (a print with white) fit 0.63, the never-seen white No.6
    # 0.75 with none of its own colours showing: put back at every lift. A cloth the job knows
    # may lie there (lost) still puts the lift back on a fit as close (episode 315)
    from robot_app.control.colour_fit import ColourFit
    from robot_app.control.episode import Outcome
    from robot_app.control.held_look import HeldColours
    from robot_app.control.pick_checks import AttemptState
    from robot_app.control.table_lost import LostMatch, _carry

    def look(job, name, doubted, fit=False, along=()):
        close = {n: ColourFit(0.75, 1.0) for n in doubted}
        return HeldColours(5000, 0.95, dict.fromkeys(doubted, 0.0), ColourFit(0.63, 1.0), close), "here"

    unlooked = _carrying_looked(monkeypatch, look, "No.2")
    results = {}
    for lost in (("No.2",), ("No.2", "No.18")):  # No.18 never seen / lost nearby
        job, _ = _carrying_job(lost, 0.0170)
        job.ledger.unnamed.append(unlooked)
        job.ledger.placed_order += ["No.17", "No.4"]
        attempt = AttemptState(None, job.box, _at(*GRASP), 0.0, lost_name="No.2")
        results[lost] = _carry(job, attempt, LostMatch("No.2", None, 0.9))[0]  # type: ignore[arg-type]
    assert results[("No.2",)] is Outcome.PLACED
    assert results[("No.2", "No.18")] is Outcome.GRASP_FAILED


def test_a_never_seen_cloth_the_look_could_not_show_is_looked_for_and_weighed(monkeypatch) -> None:
    # held-out 1819 (session 49): No.17 (white towel, whites, 24 g, never identified) came up
    # with No.16 (a print with white, colours, 31.9 g); the look saw 98 % in No.16's colours
    # and the pair went back unnamed, no cloth booked as showing. A blind lift there named
    # No.16 read 24.5 g, held No.17 alone, and went into colours unlooked
    from robot_app.control.colour_fit import ColourFit
    from robot_app.control.episode import Outcome
    from robot_app.control.held_look import HeldColours
    from robot_app.control.pick_checks import AttemptState
    from robot_app.control.table_lost import LostMatch, _carry

    looks: list = []

    def look(job, name, doubted, fit=False, along=()):
        looks.append(tuple(doubted))
        fits = {n: ColourFit(0.9, 1.0) for n in doubted}  # the white fits white better
        return HeldColours(5000, 0.98, dict.fromkeys(doubted, 0.0), ColourFit(0.6, 1.0), fits), "here"

    looked = replace(_carrying_looked(monkeypatch, look, "No.16"), looked=True)
    weights = {"No.16": 0.0319, "No.17": 0.0240, "No.4": 0.0600}
    results = {}
    for hid, reading in (((), 0.0245), (("No.17",), 0.0245), (("No.17",), 0.0315)):
        job, events = _carrying_job(("No.16",), reading)
        job.weights = weights
        job.recognizers = {n: SimpleNamespace(model=SimpleNamespace(points_in=SQUARE)) for n in weights}
        job.sort = SimpleNamespace(box_for=lambda name: "whites" if name == "No.17" else "colours")
        job.ledger.unnamed.append(replace(looked, hid=hid))
        attempt = AttemptState(None, job.box, _at(*GRASP), 0.0, lost_name="No.16")
        looks.clear()
        outcome = _carry(job, attempt, LostMatch("No.16", None, 0.9))[0]  # type: ignore[arg-type]
        results[(hid, reading)] = (outcome, tuple(looks), " ".join(attempt.notes), tuple(events))
    # booked as showing nothing: no look, into colours (the case)
    assert results[((), 0.0245)][0] is Outcome.PLACED and results[((), 0.0245)][1] == ()
    # booked as hidden there: looked for, and the scale reads No.17's weight: put back
    outcome, looked_for, notes, events = results[(("No.17",), 0.0245)]
    assert outcome is Outcome.GRASP_FAILED and looked_for == (("No.17",),), notes
    assert "the weight is nearer No.17's" in notes and events == (("put back", "No.16"),)
    # the print alone reads its own weight: its colours hold, into colours
    outcome, looked_for, notes, events = results[(("No.17",), 0.0315)]
    assert outcome is Outcome.PLACED and looked_for == (("No.17",),), notes
    assert events == (("placed", "colours"),)


def test_a_tie_across_boxes_goes_as_the_cloth_whose_weight_it_reads_and_whose_colours_show_alone(
    monkeypatch,
) -> None:
    # held-out 1771 (session 49): No.19 (colours) and No.6 (whites), put back together, fit
    # their heap alike and neither was picked. Here No.9 (colours, 16.2 g) ties with No.18
    # (whites, 20.9 g); the look shows the colours of whichever is held
    from robot_app.control.clear_table_records import BoxPlace
    from robot_app.control.colour_fit import ColourFit
    from robot_app.control.episode import Outcome
    from robot_app.control.held_look import HeldColours
    from robot_app.control.pick_checks import AttemptState
    from robot_app.control.table_lost import LostMatch, _carry

    truth = {"held": ""}
    looks: list = []

    def look(job, name, doubted, fit=False, along=()):
        looks.append(name)
        mine = name == truth["held"]
        own = {n: 0.3 if n == truth["held"] else 0.0 for n in doubted}
        fits = {n: ColourFit(0.9 if n == truth["held"] else 0.3, 1.0) for n in doubted}
        return HeldColours(
            5000, 0.95 if mine else 0.2, own, ColourFit(0.9 if mine else 0.3, 1.0), fits
        ), "here"

    _carrying_looked(monkeypatch, look, "No.9")
    whites = BoxPlace("whites", np.array([0.3, 0.56, 0.0]), 0.22, 0.1, 0.01)
    tie = LostMatch("No.9", None, 0.9, rivals=("No.18",))  # type: ignore[arg-type]
    results = {}
    for held, reading in (("No.18", 0.0255), ("No.9", 0.0165), ("No.18", 0.0165), ("No.2", 0.0165)):
        truth["held"] = held
        job, events = _carrying_job(("No.9", "No.18"), reading)
        job.boxes = {"colours": job.box, "whites": whites}
        job.ledger.placed_order += ["No.17", "No.4", "No.2"]  # nothing else of whites to doubt
        attempt = AttemptState(None, job.box, _at(*GRASP), 0.0, lost_name="No.9")
        looks.clear()
        outcome = _carry(job, attempt, tie)[0]
        results[(held, reading)] = (
            outcome,
            attempt.name,
            tuple(events),
            tuple(looks),
            " ".join(attempt.notes),
        )
    # 25.5 g is No.18's weight (20.9 g), not No.9's: taken as No.18, looked at, into whites
    outcome, name, events, looked, notes = results[("No.18", 0.0255)]
    assert outcome is Outcome.PLACED and name == "No.18" and events == (("placed", "whites"),), notes
    assert looked == ("No.18",) and "taken as No.18" in notes
    # 16.5 g is either's: the look for No.9 shows it alone, into colours
    outcome, name, events, looked, notes = results[("No.9", 0.0165)]
    assert outcome is Outcome.PLACED and name == "No.9" and events == (("placed", "colours"),), notes
    assert looked == ("No.9",)
    # ... it does not show No.9 alone, the look for No.18 does: into whites
    outcome, name, events, looked, notes = results[("No.18", 0.0165)]
    assert outcome is Outcome.PLACED and name == "No.18" and events == (("placed", "whites"),), notes
    assert looked == ("No.9", "No.18")
    # ... neither alone: put back
    outcome, name, events, looked, notes = results[("No.2", 0.0165)]
    assert outcome is Outcome.GRASP_FAILED and events == (("put back", "No.9"),), notes
    assert looked == ("No.9", "No.18")


def test_a_guess_s_colours_outweigh_a_never_seen_cloth_s_nearer_weight_only_where_it_fits_far_worse(
    monkeypatch,
) -> None:
    # held-out 862 (session 34): a blind lift guessed No.18 (whites) showed 99 % white, fit
    # 1.00, and weighed nearer the never-seen red No.1 (colours), whose fit the colour verdict
    # drops for a never-seen cloth: the scale overruled the guess, and it went back twice
    from robot_app.control.clear_table_records import BoxPlace
    from robot_app.control.colour_fit import ColourFit
    from robot_app.control.episode import Outcome
    from robot_app.control.held_look import HeldColours
    from robot_app.control.pick_checks import AttemptState
    from robot_app.control.table_lost import LostMatch, _carry

    other_fit = 0.0

    def look(job, name, doubted, fit=False, along=()):
        fits = {n: ColourFit(other_fit, 1.0) for n in doubted}
        return HeldColours(9000, 0.99, dict.fromkeys(doubted, 0.0), ColourFit(1.0, 1.0), fits), "here"

    unlooked = _carrying_looked(monkeypatch, look, "No.18")
    guess = LostMatch("No.18", None, 0.9, guessed=frozenset({"No.18"}))
    results = {}
    for other_fit in (0.0, 0.8):  # No.2 and No.9 (colours, never seen) weigh nearer 17.5 g
        job, events = _carrying_job(("No.18",), 0.0175)
        job.box = BoxPlace("whites", np.array([0.3, 0.56, 0.0]), 0.22, 0.1, 0.01)
        job.ledger.unnamed.append(unlooked)
        attempt = AttemptState(None, job.box, _at(*GRASP), 0.0, lost_name="No.18")
        results[other_fit] = (_carry(job, attempt, guess)[0], " ".join(attempt.notes))  # type: ignore[arg-type]
        results[other_fit] += (events,)
    assert results[0.0][0] is Outcome.PLACED, results[0.0][1]
    assert results[0.0][2] == [("placed", "whites")]
    assert results[0.8][0] is Outcome.GRASP_FAILED
    assert "the weight is nearer No.2's" in results[0.8][1]


def test_a_blind_lift_heavier_than_its_cloth_goes_back_with_its_extra_booked_unnamed(monkeypatch) -> None:
    # held-out 1339 (session 42): a blind lift guessed No.18 (19 g) read 53 g, held the
    # never-seen No.14 too and went back; the guess was placed later, no unnamed place was
    # left, and No.14's region (in its colours) was never taken
    from robot_app.control import table_lost
    from robot_app.control.clear_table_records import LossKind, LostPlace
    from robot_app.control.episode import Outcome
    from robot_app.control.pick_checks import AttemptState
    from robot_app.control.table_clearer import TableClearer
    from robot_app.control.table_lost import LostMatch, _carry

    monkeypatch.setattr(table_lost, "carry_over_box", lambda *a: None)
    monkeypatch.setattr(table_lost, "release_into_box", lambda *a: None)
    for extra, count in ((0.0201, 1), (0.25, 3), (0.0, 0)):
        job, events = _carrying_job(("No.2",), WEIGHTS["No.2"] + extra)
        job.ledger.placed_order.append("No.18")  # nothing of whites to look for in a lift read right
        at = np.array(GRASP)
        job.ledger.lost["No.2"] = LostPlace(LossKind.PUT_BACK, "put back", at, at, (), True)
        job._not_placed = lambda attempt, keep, job=job: TableClearer._not_placed(job, attempt, keep)
        job.count_unnamed = lambda attempt, extra, job=job: TableClearer.count_unnamed(job, attempt, extra)
        attempt = AttemptState(None, job.box, _at(*GRASP), 0.0, lost_name="No.2")
        outcome, why = _carry(job, attempt, LostMatch("No.2", None, 0.9))  # type: ignore[arg-type]
        assert attempt.unnamed_along == count
        if count:
            assert outcome is Outcome.GRASP_FAILED and "put back" in why
            assert events == [("put back", "No.2")] and attempt.lift_check == "double"
            assert any(f"is {count} cloths at least" in n for n in attempt.notes) == (count > 1)
        else:  # its own weight: placed, nothing booked
            assert outcome is Outcome.PLACED and events == [("placed", "colours")]
