"""After a detected double pick: both placed only when the other cloth's identity is sure.

Bench episode 2 (s8 baseline, main a342089): No.12 came up with No.11 and the pair was laid
back; the next pick, No.19, came up with that pair, and the job named No.10 (seen by an
earlier survey, hidden since, about the extra weight) as the one other cloth and placed
"both". A cloth the job laid back near the grasp may as well be what weighs the extra: the
identity is then not sure, and the lift is put back.
"""

from __future__ import annotations

import contextlib
from types import SimpleNamespace

import numpy as np
import pytest

from robot_app.control import table_clearer
from robot_app.control.clear_table_records import ClearTableSettings, LossKind, LostPlace
from robot_app.control.episode import EpisodeAbortError
from robot_app.control.held_look import HeldColours
from robot_app.control.sort_rule import SortSettings
from robot_app.control.table_ledger import TableLedger

CORNERS = np.array([[-0.1, -0.1, 0.0], [0.1, -0.1, 0.0], [0.1, 0.1, 0.0], [-0.1, 0.1, 0.0]])  # a 0.2 m square


def _job(monkeypatch: pytest.MonkeyPatch, put_back: list[str]) -> table_clearer.TableClearer:
    job = table_clearer.TableClearer.__new__(table_clearer.TableClearer)
    job.settings = ClearTableSettings(survey_latency=0.0, held_look={"name_companion": False})
    job.weights = {"No.19": 0.021, "No.10": 0.029, "No.12": 0.011, "No.11": 0.024}
    job.recognizers = {
        n: SimpleNamespace(name=n, model=SimpleNamespace(points_in=CORNERS, grasp_point=np.zeros(3)))
        for n in job.weights
    }  # type: ignore[misc]
    job.ledger = TableLedger()
    job.table_z = 0.0
    job.weigh = lambda: 0.056  # No.19 with the laid pair (11 + 24 g)
    job.cell = SimpleNamespace(capture=lambda: None)  # type: ignore[assignment]
    job.motion = SimpleNamespace(  # type: ignore[assignment]
        hold=lambda seconds: None, tcp_position=lambda: np.array([0.50, 0.00, 0.4]), q=np.zeros(7)
    )
    job.rig = SimpleNamespace(right=None)  # type: ignore[assignment]
    job._survey_capture = SimpleNamespace(transform_right_camera_to_world=np.eye(4))  # type: ignore[assignment]
    job.sort = SortSettings(default="colours", boxes={"whites": (6, 17, 18)})
    job._hidden_spots = {}
    job._laid = []
    job._before_pick = None  # no unknown region seen
    job.recovery = SimpleNamespace(  # type: ignore[assignment]
        put_back=lambda *args: (put_back.append("No.19"), (np.zeros(2), np.zeros(2)))[1],
        put_back_spots=[np.zeros(2)],
        lay_down=lambda *args: False,  # no lay-out path: no shedding (tests below give one)
    )
    monkeypatch.setattr(table_clearer, "companion", lambda *args: None)  # no surveyed cloth by the grasp
    monkeypatch.setattr(table_clearer, "remembered_companion", lambda *args: "No.10")  # memory names No.10
    monkeypatch.setattr(table_clearer, "still_there", lambda recognizer, *args: False)  # all gone from there
    job.ledger.last_pose["No.10"] = np.eye(4)
    job.ledger.last_survey["No.10"] = 1
    return job


def _attempt() -> table_clearer.AttemptState:
    return table_clearer.AttemptState(
        SimpleNamespace(name="No.19"),  # type: ignore[arg-type]
        SimpleNamespace(name="colours"),  # type: ignore[arg-type]
        np.eye(4),
        0.0,
    )


def _lay_back(job: table_clearer.TableClearer, start: tuple[float, float], end: tuple[float, float]) -> None:
    """No.12 came up with a cloth no survey identified; the pair was laid from `start` to `end`."""
    earlier = _attempt()
    earlier.target = SimpleNamespace(name="No.12")  # type: ignore[assignment]
    earlier.unnamed_along, earlier.put_back = True, True
    a, b = np.array(start), np.array(end)
    job._laid.append((earlier, a, b))
    job.ledger.lost["No.12"] = LostPlace(LossKind.PUT_BACK, "put back after the lift", a, b, ())
    job.ledger.unnamed.append(LostPlace(LossKind.PUT_BACK, "came up with No.12, not named", a, b, ()))


def test_without_a_laid_back_cloth_near_the_grasp_both_go_into_the_box(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    put_back: list[str] = []
    job = _job(monkeypatch, put_back)
    _lay_back(job, (0.20, -0.20), (0.30, -0.25))  # laid far from the grasp at (0.50, 0.00)
    attempt = _attempt()
    loop = SimpleNamespace(arm=SimpleNamespace(resume_at=lambda q: None), extra_reach=0.0)
    job._after_lift(attempt, loop)  # type: ignore[arg-type]
    assert attempt.came_along == ("No.10",) and put_back == [] and attempt.named_by == "memory"
    assert attempt.remembered == ("No.10",)
    assert loop.extra_reach == pytest.approx(0.1 * np.sqrt(2.0))  # No.10 hangs from No.19: carried higher


def test_a_laid_back_pair_near_the_grasp_makes_the_other_cloth_unsure(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    put_back: list[str] = []
    job = _job(monkeypatch, put_back)
    _lay_back(job, (0.40, 0.05), (0.55, 0.05))  # the laid strip passes 50 mm from the grasp
    attempt = _attempt()
    with pytest.raises(EpisodeAbortError):
        job._after_lift(attempt, SimpleNamespace(arm=SimpleNamespace(resume_at=lambda q: None)))  # type: ignore[arg-type]
    assert attempt.came_along == () and attempt.unnamed_along and put_back == ["No.19"]
    assert attempt.named_by == ""  # the name withdrawn: picks.csv must not say it was named
    assert any("identity not sure" in note and "No.12" in note for note in attempt.notes)


def test_a_laid_back_cloth_seen_again_since_no_longer_counts(monkeypatch: pytest.MonkeyPatch) -> None:
    put_back: list[str] = []
    job = _job(monkeypatch, put_back)
    _lay_back(job, (0.40, 0.05), (0.55, 0.05))
    job.ledger.lost.clear()  # No.12 recognised again by a survey
    job.ledger.unnamed.clear()  # and its companion picked (placed) since
    attempt = _attempt()
    job._after_lift(attempt, SimpleNamespace(arm=SimpleNamespace(resume_at=lambda q: None)))  # type: ignore[arg-type]
    assert attempt.came_along == ("No.10",)


def _shedding_job(monkeypatch: pytest.MonkeyPatch, put_back: list[str], readings: list[float]):
    """No.19's lift weighs the extra and no cloth is named; the hand can lay it down along a
    path (it then stands at (0.60, 0.10)) and lift it again, weighing `readings` in turn."""
    job = _job(monkeypatch, put_back)
    job.settings = ClearTableSettings(
        survey_latency=0.0, put_back={"shed": True}, held_look={"name_companion": False}
    )
    monkeypatch.setattr(table_clearer, "remembered_companion", lambda *args: None)
    where = {"tcp": np.array([0.50, 0.00, 0.40])}
    moves: list[np.ndarray] = []

    def lay_down(*args) -> bool:
        where["tcp"] = np.array([0.60, 0.10, 0.05])
        return True

    def move_tcp(position, speed=1.0) -> None:
        moves.append(np.array(position, dtype=float))
        where["tcp"] = np.array(position, dtype=float)

    job.recovery.lay_down = lay_down  # type: ignore[attr-defined]
    job.motion = SimpleNamespace(  # type: ignore[assignment]
        hold=lambda seconds: None, tcp_position=lambda: where["tcp"].copy(), q=np.zeros(7), move_tcp=move_tcp
    )
    weights = iter(readings)
    job.weigh = lambda: next(weights)
    return job, moves


def test_a_double_pick_that_weighs_alone_after_being_laid_down_goes_on_to_the_box(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    put_back: list[str] = []
    job, moves = _shedding_job(monkeypatch, put_back, [0.056, 0.022])  # then No.19 alone (21 g)
    attempt = _attempt()
    job._after_lift(attempt, SimpleNamespace(arm=SimpleNamespace(resume_at=lambda q: None)))  # type: ignore[arg-type]
    assert put_back == [] and attempt.lift_check == "double"  # noticed, not put back
    assert moves and moves[-1][2] == pytest.approx(0.40)  # lifted again to the lift's height
    assert moves[-1][:2] == pytest.approx([0.60, 0.10])  # straight up from where it was laid
    assert attempt.shed_at is not None and attempt.shed_at[1] == pytest.approx([0.60, 0.10])
    assert attempt.unnamed_along and any("left on the table" in n for n in attempt.notes)
    # the unnamed cloth is booked as lying along the laid strip, for a blind pick later
    job.ledger.record_attempt(
        attempt, SimpleNamespace(outcome=table_clearer.Outcome.PLACED, reason=""), 9.0, 0.021
    )
    assert job.ledger.unnamed[-1].end == pytest.approx([0.60, 0.10])


def test_a_double_pick_still_heavy_after_being_laid_down_is_put_back(monkeypatch: pytest.MonkeyPatch) -> None:
    put_back: list[str] = []
    job, _ = _shedding_job(monkeypatch, put_back, [0.056, 0.050])  # both hang from the fingers
    attempt = _attempt()
    with pytest.raises(EpisodeAbortError):
        job._after_lift(attempt, SimpleNamespace(arm=SimpleNamespace(resume_at=lambda q: None)))  # type: ignore[arg-type]
    assert put_back == ["No.19"] and attempt.shed_at is None
    assert any("still 50 g lifted" in n for n in attempt.notes)


# --------------------------------------- the other cloth named by its colours seen hanging
def _looking_job(monkeypatch: pytest.MonkeyPatch, put_back: list[str], own: dict[str, float]):
    """No.19's lift weighs No.19 and a cloth of 24-29 g (50 g); neither the survey nor memory
    names it; the look at what hangs shows `own` (cloth -> share of the held pixels in its own
    colours)."""
    from robot_app.control.held_look import HeldColours

    job = _job(monkeypatch, put_back)
    job.settings = ClearTableSettings(survey_latency=0.0)
    job.weigh = lambda: 0.050
    job.ledger.last_seen.update({"No.10": np.array([0.3, 0.1]), "No.11": np.array([0.5, 0.05])})
    job.weights["No.7"] = 0.027  # weighs the extra too; no survey has seen it (it may lie hidden)
    job.recognizers["No.7"] = job.recognizers["No.10"]
    monkeypatch.setattr(table_clearer, "remembered_companion", lambda *args: None)
    monkeypatch.setattr(table_clearer, "hidden_in", lambda cloth, holders: False)  # models without colours
    looked: list[tuple[str, ...]] = []

    def look(job, meant, others, looks=1, along=()):
        looked.append(tuple(others))
        return HeldColours(4000, 0.7, {n: own.get(n, 0.0) for n in others}), "looked from 12 cm aside"

    monkeypatch.setattr(table_clearer, "look_at_held", look)
    return job, looked


def _lift(job) -> table_clearer.AttemptState:
    attempt = _attempt()
    resumed: list[object] = []
    with contextlib.suppress(EpisodeAbortError):  # put back
        job._after_lift(attempt, SimpleNamespace(arm=SimpleNamespace(resume_at=resumed.append)))
    assert resumed, "the loop goes on from where the look left the hand"
    return attempt


def test_the_other_cloth_seen_hanging_in_its_own_colours_is_named_and_placed_along(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    put_back: list[str] = []
    job, looked = _looking_job(monkeypatch, put_back, {"No.11": 0.3})
    attempt = _lift(job)
    # the cloths not placed that weigh the extra (29 g), then those lighter (a part of it)
    assert looked == [("No.10", "No.11", "No.7", "No.12")]
    assert attempt.came_along == ("No.11",) and attempt.named_by == "look" and put_back == []


def test_a_cloth_never_seen_is_named_by_its_colours_seen_hanging(monkeypatch: pytest.MonkeyPatch) -> None:
    """Held-out episode 384 (session 28): No.2, never identified (it lay under No.7), came
    up with No.7 at every lift, and each lift was put back unlooked: no cloth a survey had
    seen weighed the extra. A cloth never seen is asked too; placed, it is booked."""
    put_back: list[str] = []
    job, looked = _looking_job(monkeypatch, put_back, {"No.7": 0.35})
    attempt = _lift(job)
    assert "No.7" in looked[0]
    assert attempt.came_along == ("No.7",) and attempt.named_by == "look" and put_back == []
    placed, looked = _looking_job(monkeypatch, [], {"No.11": 0.3})
    placed.ledger.placed_order.append("No.7")  # once placed, it is no one's companion any more
    _lift(placed)
    assert looked == [("No.10", "No.11", "No.12")]


def test_a_never_seen_cloth_of_another_box_hidden_in_the_held_colours_is_booked_as_unseen_hanging(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Held-out 1819 and 1820 (session 49): a white cloth never identified came up with a
    print with white, the look saw only the print's colours, and the pair went back unnamed
    with no cloth booked as showing; the white, lifted blind alone under the print's name,
    went into colours unlooked. Such a cloth is booked with the put-back (`LostPlace.hid`)."""
    for hidden, seen_before in ((True, False), (False, False), (True, True)):
        put_back: list[str] = []
        job, _ = _looking_job(monkeypatch, put_back, {})  # nothing of its own shows
        job.sort = SortSettings(default="colours", boxes={"whites": (7, 12)})  # No.7: 27 g, never seen
        if seen_before:
            job.ledger.last_seen["No.7"] = np.array([0.2, 0.3])
        monkeypatch.setattr(table_clearer, "hidden_in", lambda cloth, holders, h=hidden: h)
        attempt = _lift(job)
        assert put_back == ["No.19"] and attempt.unnamed_along and attempt.showed == ()
        # No.12 (whites, 11 g, a part of the extra) never seen too; No.10, No.11 of colours
        hid = ("No.7", "No.12") if not seen_before else ("No.12",)
        assert attempt.hid == (hid if hidden else ())
        job.ledger.record_attempt(
            attempt, SimpleNamespace(outcome=table_clearer.Outcome.GRASP_FAILED, reason="put back"), 9.0, None
        )
        assert job.ledger.unnamed[-1].hid == attempt.hid and job.ledger.unnamed[-1].looked


def test_the_other_cloth_seen_hanging_from_the_other_box_is_put_back_named(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    put_back: list[str] = []
    job, _ = _looking_job(monkeypatch, put_back, {"No.11": 0.3})
    job.sort = SortSettings(default="colours", boxes={"whites": (11,)})
    attempt = _lift(job)
    assert attempt.came_along == () and attempt.laid_back_too == ("No.11",) and put_back == ["No.19"]


def test_nothing_seen_hanging_or_cloths_of_both_boxes_name_no_one(monkeypatch: pytest.MonkeyPatch) -> None:
    cases = (
        ({"No.11": 0.05}, ()),  # too little of it
        ({"No.11": 0.3, "No.10": 0.2}, (10,)),  # cloths of both boxes
    )
    for own, whites in cases:
        put_back: list[str] = []
        job, _ = _looking_job(monkeypatch, put_back, own)
        job.sort = SortSettings(default="colours", boxes={"whites": whites})
        attempt = _lift(job)
        assert attempt.came_along == () and attempt.laid_back_too == () and attempt.unnamed_along
        assert put_back == ["No.19"] and attempt.named_by == ""


@pytest.mark.parametrize(("reading", "cloths"), [(0.050, 1), (0.074, 2)])
def test_an_unnamed_extra_is_booked_once_per_cloth_it_must_be(
    monkeypatch: pytest.MonkeyPatch, reading: float, cloths: int
) -> None:
    """Held-out 1102 (session 38): 79 g lifted for No.15 (26 g), No.1 and No.13 along; one
    unnamed cloth was booked, a later blind lift placed No.13 and used it up, and No.1 was
    never looked for. Here the heaviest cloth not placed, No.10, weighs 29 g: 29 g of extra is
    one cloth, 53 g two at least."""
    put_back: list[str] = []
    job, _ = _looking_job(monkeypatch, put_back, {"No.11": 0.05})  # nothing named by the look
    job.weigh = lambda: reading  # No.19 weighs 21 g
    attempt = _lift(job)
    assert attempt.came_along == () and put_back == ["No.19"] and attempt.unnamed_along == cloths
    result = SimpleNamespace(outcome=table_clearer.Outcome.GRASP_FAILED, reason="put back")
    job.ledger.record_attempt(attempt, result, 9.0, 0.021)  # type: ignore[arg-type]
    assert len(job.ledger.unnamed) == cloths
    assert all(p.how == "came up with No.19, not named" for p in job.ledger.unnamed)


def _under_job(monkeypatch: pytest.MonkeyPatch, put_back: list[str], stayed: set[str]):
    """No.19 lay on No.11 (24 g) and No.12 (11 g) in its survey; its lift weighs 45 g (No.19
    and 24 g more); neither a cloth by the grasp nor memory names the other one; after the
    lift the cloths in `stayed` are still found where the survey saw them."""
    job = _job(monkeypatch, put_back)
    job.weigh = lambda: 0.045
    monkeypatch.setattr(table_clearer, "remembered_companion", lambda *args: None)
    monkeypatch.setattr(table_clearer, "still_there", lambda recognizer, *args: recognizer.name in stayed)
    return job


def _lift_under(
    monkeypatch: pytest.MonkeyPatch, job, under: tuple[str, ...], resumed: list[object] | None = None
) -> table_clearer.AttemptState:
    attempt = _attempt()
    attempt.under = under
    attempt.others = tuple(SimpleNamespace(name=n, transform_model_to_camera=np.eye(4)) for n in under)  # type: ignore[misc]
    monkeypatch.setattr(
        table_clearer, "to_world", lambda capture, pose: pose
    )  # the survey's pose in the world
    with contextlib.suppress(EpisodeAbortError):  # put back
        job._after_lift(
            attempt,
            SimpleNamespace(arm=SimpleNamespace(resume_at=(resumed if resumed is not None else []).append)),
        )
    return attempt


def test_the_one_cloth_it_lay_on_that_weighs_the_extra_and_is_gone_is_named(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    put_back: list[str] = []
    job = _under_job(monkeypatch, put_back, stayed=set())
    attempt = _lift_under(monkeypatch, job, ("No.12", "No.11"))  # No.12 is too light for the extra
    assert attempt.came_along == ("No.11",) and attempt.named_by == "under" and put_back == []
    # another one that weighs the extra too but still lies where the survey saw it
    job = _under_job(monkeypatch, put_back, stayed={"No.10"})
    attempt = _lift_under(monkeypatch, job, ("No.10", "No.11"))
    assert attempt.came_along == ("No.11",) and attempt.named_by == "under" and put_back == []


def test_a_cloth_it_lay_on_still_in_its_place_or_two_that_weigh_the_extra_name_no_one(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    for stayed, under in (({"No.11"}, ("No.11",)), (set(), ("No.11", "No.10")), (set(), ())):
        put_back: list[str] = []
        job = _under_job(monkeypatch, put_back, stayed)
        attempt = _lift_under(monkeypatch, job, under)
        assert attempt.came_along == () and attempt.unnamed_along and attempt.named_by == ""
        assert put_back == ["No.19"]


def _under_job_with_a_white(monkeypatch: pytest.MonkeyPatch, put_back: list[str]):
    """`_under_job` where nothing stayed, and No.17 (whites) weighs the extra too."""
    job = _under_job(monkeypatch, put_back, stayed=set())
    job.weights["No.17"] = 0.025
    job.recognizers["No.17"] = job.recognizers["No.10"]
    return job


def _assert_under_named(attempt, put_back: list[str], named: bool, why: str) -> None:
    """No.11 named "under" and placed along, or no name, the lift put back, `why` noted."""
    if named:
        assert attempt.came_along == ("No.11",) and attempt.named_by == "under" and put_back == []
        assert attempt.remembered == ()  # seen by the pick's survey: not "from memory" in picks.csv
    else:
        assert attempt.came_along == () and attempt.named_by == "" and put_back == ["No.19"]
        assert any(why in note for note in attempt.notes)


def _look_showing(shown: float, looked: list[tuple[str, ...]], alongs: list[tuple[str, ...]] | None = None):
    """A `look_at_held` whose held pixels show `shown` of every asked cloth's own colours;
    the cloths asked are noted in `looked`, those taken to hang along in `alongs`."""
    from robot_app.control.held_look import HeldColours

    def look(job, meant, others, looks=1, along=()):
        looked.append(tuple(others))
        if alongs is not None:
            alongs.append(tuple(along))
        return HeldColours(5000, 0.8, {n: shown for n in others}), "looked from 20 cm aside"

    return look


def test_a_cloth_of_another_box_seen_hanging_withdraws_the_name_from_under(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # No.17 (whites) weighs the extra too: a look at what hangs must not show its colours
    for shown, named in ((0.0, True), (0.2, False)):
        put_back: list[str] = []
        job = _under_job_with_a_white(monkeypatch, put_back)
        looked: list[tuple[str, ...]] = []
        alongs: list[tuple[str, ...]] = []
        monkeypatch.setattr(table_clearer, "look_at_held", _look_showing(shown, looked, alongs))
        resumed: list[object] = []
        attempt = _lift_under(monkeypatch, job, ("No.11",), resumed)
        assert looked == [("No.17",)] and resumed, "the loop goes on from where the look left the hand"
        assert alongs == [("No.11",)]  # the named one's colours are the lift's (rerun of 807)
        _assert_under_named(attempt, put_back, named, "another box")


def test_a_look_at_what_hangs_that_saw_too_little_withdraws_the_name_from_under(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # held-out 1259 (session 41): a pair named "under" was placed after a look of 270 px
    from robot_app.control.held_look import HeldColours

    for pixels, named in ((5000, True), (270, False)):
        put_back: list[str] = []
        job = _under_job_with_a_white(monkeypatch, put_back)
        monkeypatch.setattr(
            table_clearer,
            "look_at_held",
            lambda job, meant, others, looks=1, along=(), pixels=pixels: (
                HeldColours(pixels, 0.8, dict.fromkeys(others, 0.0)),
                "aside",
            ),
        )
        attempt = _lift_under(monkeypatch, job, ("No.11",))
        _assert_under_named(attempt, put_back, named, "too little of what hangs seen")


def test_a_never_seen_cloth_no_look_can_tell_beside_the_lift_withdraws_the_name_from_under(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # held-out 1283 (session 41): No.17 (white towel, whites, never identified) lay beside
    # No.7 as an unknown region and came up with it; named No.4 "under", into colours.
    # Held-out 1270 (session 42): the never-seen rival had a colour of its own, but the
    # lift bared its place beside the meant cloth
    cases = (
        # beside, hidden in the held colours, its place bared by the lift, named
        (True, True, False, False),
        (False, True, False, True),
        (True, False, False, True),
        (True, False, True, False),
        (False, False, True, True),  # nothing unidentified beside the lift: no bared place asked
    )
    for beside, hidden, bared, named in cases:
        put_back: list[str] = []
        job = _under_job_with_a_white(monkeypatch, put_back)
        job.ledger.last_seen.pop("No.17", None)  # never seen by a survey
        monkeypatch.setattr(job, "_regions_touching", lambda attempt, held, b=beside: [object()] if b else [])
        asked: list[object] = []
        monkeypatch.setattr(
            job,
            "_regions_bared",
            lambda attempt, capture, held, touching=None, b=bared, asked=asked: (
                asked.append(capture),
                (int(b), 1),
            )[1],
        )
        monkeypatch.setattr(table_clearer, "hidden_in", lambda cloth, holders, h=hidden: h)
        looked: list[tuple[str, ...]] = []
        monkeypatch.setattr(table_clearer, "look_at_held", _look_showing(0.0, looked))
        attempt = _lift_under(monkeypatch, job, ("No.11",))
        why = "no look tells its colours" if hidden else "whose place the lift bared"
        _assert_under_named(attempt, put_back, named, why)
        assert looked == ([("No.17",)] if named else [])  # no look where none could tell
        assert len(asked) == int(beside and not hidden)  # the check after the lift's capture
        # a rival seen by a survey is not hidden beside: the look decides
        if bared and beside:
            put_back = []
            job = _under_job_with_a_white(monkeypatch, put_back)
            job.ledger.last_seen["No.17"] = np.array([0.2, -0.1])
            monkeypatch.setattr(job, "_regions_touching", lambda attempt, held: [object()])
            monkeypatch.setattr(job, "_regions_bared", lambda attempt, capture, held, touching=None: (1, 1))
            monkeypatch.setattr(table_clearer, "look_at_held", _look_showing(0.0, []))
            attempt = _lift_under(monkeypatch, job, ("No.11",))
            _assert_under_named(attempt, put_back, True, "")


def test_a_cloth_of_another_box_last_seen_where_the_fingers_closed_withdraws_the_name_from_under(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # held-out 1722 (session 48): No.18 (white, whites), seen under No.8 by the first survey
    # and not since, came up with No.8 inside it; No.14, still in its place, was named
    # "under", the look at what hangs saw no cloth of another box, and No.18 went into
    # colours. The footprints here are a 0.2 m square's corners
    cases = (
        # remembered_rival on, No.17 last seen at (x, y), named
        (True, (0.58, 0.08), False),  # a corner of its footprint there 28 mm from the grasp
        (True, (0.80, 0.30), True),  # seen far from the grasp: the look decides
        (False, (0.58, 0.08), True),  # off: the look decides
    )
    for on, xy, named in cases:
        put_back: list[str] = []
        job = _under_job_with_a_white(monkeypatch, put_back)
        job.settings = ClearTableSettings(
            survey_latency=0.0, held_look={"name_companion": False}, remembered_rival=on
        )
        job.ledger.last_pose["No.17"] = np.array(
            [[1.0, 0.0, 0.0, xy[0]], [0.0, 1.0, 0.0, xy[1]], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]]
        )
        job.ledger.last_seen["No.17"], job.ledger.last_survey["No.17"] = np.array(xy), 1
        looked: list[tuple[str, ...]] = []
        monkeypatch.setattr(table_clearer, "look_at_held", _look_showing(0.0, looked))
        attempt = _lift_under(monkeypatch, job, ("No.11",))
        _assert_under_named(attempt, put_back, named, "No.17 (another box) lay where the fingers closed")
        assert looked == ([("No.17",)] if named else [])  # no look where none could tell
        if not named:
            assert any("by survey 1" in note for note in attempt.notes)
    # seen by the pick's own survey (elsewhere, then): not hidden under the lift
    put_back = []
    job = _under_job_with_a_white(monkeypatch, put_back)
    job.settings = ClearTableSettings(
        survey_latency=0.0, held_look={"name_companion": False}, remembered_rival=True
    )
    job.ledger.last_pose["No.17"] = np.eye(4)
    job.ledger.last_pose["No.17"][:2, 3] = (0.58, 0.08)
    monkeypatch.setattr(table_clearer, "look_at_held", _look_showing(0.0, []))
    attempt = _lift_under(monkeypatch, job, ("No.11", "No.17"))
    assert "lay where the fingers closed" not in " ".join(attempt.notes)


def test_a_white_cloth_hides_in_a_print_with_white_and_not_in_a_cloth_without() -> None:
    from robot_app.config import load_config
    from robot_app.control.held_look import hidden_in
    from robot_app.experiments.clear_table import ClearTableConfig, _model

    config = load_config(ClearTableConfig, "configs/clear_table.yaml", [])
    towel, shirt, knit = (_model(config.world, config.model, n) for n in (17, 7, 4))
    assert hidden_in(towel, [shirt])  # No.7: purple with white
    assert not hidden_in(towel, [knit])  # No.4: no white among its colours
    assert not hidden_in(shirt, [towel]) and not hidden_in(towel, [])


def test_the_cloth_it_lay_on_seen_in_its_place_from_the_look_is_not_named(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Held-out episode 401 (session 28): the check after the lift missed No.8 in its place
    (the hanging cloth hid it), the look at what hangs showed no cloth of another box (No.17
    hung inside), and No.8 was named "under": No.17 went into colours. Seen again from where
    the hand looked, the cloth it lay on is still there: no name, put back."""
    from robot_app.control.held_look import HeldColours

    for seen_from_the_look, named in ((False, True), (True, False)):
        put_back: list[str] = []
        job = _under_job_with_a_white(monkeypatch, put_back)
        checks: list[str] = []

        def still_there(recognizer, *args, checks=checks, seen=seen_from_the_look):
            if recognizer.name != "No.11":
                return False  # the meant cloth left its place
            checks.append(recognizer.name)
            return seen and len(checks) > 1  # the check after the lift misses it

        monkeypatch.setattr(table_clearer, "still_there", still_there)
        monkeypatch.setattr(
            table_clearer,
            "look_at_held",
            lambda job, meant, others, looks=1, along=(): (
                HeldColours(5000, 0.8, dict.fromkeys(others, 0.0)),
                "aside",
            ),
        )
        attempt = _lift_under(monkeypatch, job, ("No.11",))
        assert checks == ["No.11", "No.11"]  # after the lift, and from where the hand looked
        _assert_under_named(attempt, put_back, named, "still lies where the survey saw it")


def test_a_cloth_named_hanging_is_not_named_where_lighter_cloths_of_another_box_show(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Held-out episode 412 (session 28): 39 g more than the meant cloth came up, No.6 and
    No.18 of whites; No.16 (colours, 39 g, never seen) was named by 13 % of red, No.6's
    motifs, and the whites went into colours. A cloth lighter than the extra may be part
    of it: one of another box showing `doubt_share` of its own colours withdraws the name."""
    for shown, named in ((0.0, True), (0.10, False)):
        put_back: list[str] = []
        job, looked = _looking_job(monkeypatch, put_back, {"No.11": 0.3, "No.12": shown})
        job.sort = SortSettings(default="colours", boxes={"whites": (12,)})  # No.12: 11 g, whites
        attempt = _lift(job)
        assert "No.12" in looked[0], "a lighter cloth is looked for too"
        if named:
            assert attempt.came_along == ("No.11",) and attempt.named_by == "look" and put_back == []
        else:
            assert attempt.came_along == () and attempt.named_by == "" and put_back == ["No.19"]


def test_a_white_cloth_of_another_box_that_may_hang_in_its_shade_withdraws_the_name(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Held-out episode 688 (session 32): No.18 (white, whites) came up under No.15; hanging,
    it read DARK, 71 % "No.19's own" (grey melange, colours) and none of its own LIGHT, and
    went into colours named No.19. A white cloth of another box that weighs the extra and
    whose shade (`HeldColours.shaded`) shows `doubt_share` withdraws the name."""
    from robot_app.control.held_look import HeldColours

    for shade, named in ((0.0, True), (0.71, False)):
        put_back: list[str] = []
        job, _ = _looking_job(monkeypatch, put_back, {"No.11": 0.71})
        job.sort = SortSettings(default="colours", boxes={"whites": (10,)})  # No.10 weighs the extra

        def look(job, meant, others, looks=1, along=(), shade=shade):
            own = {n: 0.71 if n == "No.11" else 0.0 for n in others}
            shaded = {**own, "No.10": shade}
            return HeldColours(4000, 0.05, own, shaded=shaded), "looked from 27 cm aside"

        monkeypatch.setattr(table_clearer, "look_at_held", look)
        attempt = _lift(job)
        if named:
            assert attempt.came_along == ("No.11",) and attempt.named_by == "look" and put_back == []
        else:
            assert attempt.came_along == () and attempt.named_by == "" and put_back == ["No.19"]


def test_a_cloth_of_another_box_seen_hanging_withdraws_the_name_from_memory(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # held-out episode 722 (session 33): memory named No.7 with No.1, and No.6 of whites came
    # along too; now what hangs is looked at as for a cloth named "under"
    for shown, named in ((0.0, True), (0.2, False)):
        put_back: list[str] = []
        job = _job(monkeypatch, put_back)
        job.weights["No.17"] = 0.024  # whites, could hang in the 35 g extra
        job.recognizers["No.17"] = job.recognizers["No.10"]
        looked: list[tuple[str, ...]] = []
        monkeypatch.setattr(table_clearer, "look_at_held", _look_showing(shown, looked))
        resumed: list[object] = []
        loop = SimpleNamespace(arm=SimpleNamespace(resume_at=resumed.append), extra_reach=0.0)
        attempt = _attempt()
        with pytest.raises(EpisodeAbortError) if not named else contextlib.nullcontext():
            job._after_lift(attempt, loop)  # type: ignore[arg-type]
        assert looked[:1] == [("No.17",)] and resumed, "the loop goes on from where the look left the hand"
        if named:
            assert attempt.came_along == ("No.10",) and attempt.named_by == "memory" and put_back == []
        else:
            assert attempt.came_along == () and attempt.named_by == "" and put_back == ["No.19"]
            assert any("No.10 would be the other cloth" in note for note in attempt.notes)


# --------------------------------------- a wrong lift named by its colours seen hanging
@pytest.mark.parametrize(
    ("fits", "shade", "toned", "named"),
    [
        ({"No.11": 0.9, "No.10": 0.3, "No.17": 0.1}, 0.0, False, "No.11"),  # one cloth of the box fits
        ({"No.11": 0.9, "No.10": 0.8, "No.17": 0.1}, 0.0, False, "No.11"),  # two of one box: the best
        ({"No.11": 0.9, "No.10": 0.3, "No.17": 0.75}, 0.0, False, ""),  # a white fits nearly as well
        ({"No.11": 0.4, "No.10": 0.3, "No.17": 0.1}, 0.0, False, ""),  # none fits well enough
        # the white's shade (DARK) shows: a doubt only where the best is a cloth of tones
        ({"No.11": 0.9, "No.10": 0.3, "No.17": 0.1}, 0.2, False, "No.11"),
        ({"No.11": 0.9, "No.10": 0.3, "No.17": 0.1}, 0.2, True, ""),
    ],
)
def test_a_wrong_lift_is_placed_as_the_cloth_its_colours_name_when_only_its_box_fits(
    monkeypatch: pytest.MonkeyPatch, fits: dict[str, float], shade: float, toned: bool, named: str
) -> None:
    """Held-out episode 796 (session 33): four grasps meant for No.15, still in its place
    after each lift, held No.13 (same colours, never identified); each was put back."""
    from robot_app.control.colour_fit import ColourFit
    from robot_app.control.held_look import HeldColours

    put_back: list[str] = []
    job = _job(monkeypatch, put_back)
    job.settings = ClearTableSettings(survey_latency=0.0)
    job.weights["No.17"] = 0.024  # whites
    job.recognizers["No.17"] = job.recognizers["No.11"]
    job.weigh = lambda: 0.024  # No.11's weight (No.10's and No.17's within the tolerance; not No.12's)
    monkeypatch.setattr(table_clearer, "still_there", lambda recognizer, *args: True)  # No.19 stayed
    looked: list[tuple[str, ...]] = []

    def look(job, meant, others, looks=1, fit=False, along=()):
        looked.append(tuple(others))
        scores = {n: ColourFit(fits[n], 1.0) for n in others}
        shaded = {n: shade if n == "No.17" else 0.0 for n in others}
        seen = HeldColours(5000, 0.8, dict.fromkeys(others, 0.0), fits=scores, shaded=shaded)
        return seen, "looked from 12 cm aside"

    monkeypatch.setattr(table_clearer, "look_at_held", look)
    palette = np.array([table_clearer.DARK if toned else 40])  # grey, or a hue
    monkeypatch.setattr(table_clearer, "main_codes", lambda model: palette)
    attempt, resumed = _attempt(), []
    loop = SimpleNamespace(arm=SimpleNamespace(resume_at=resumed.append), extra_reach=0.0)
    with contextlib.suppress(EpisodeAbortError):
        job._after_lift(attempt, loop)  # type: ignore[arg-type]
    assert looked == [("No.10", "No.11", "No.17")] and resumed  # the cloths that weigh the reading
    assert attempt.lift_check == "wrong"
    if named:
        assert attempt.name == named and attempt.meant == "No.19" and put_back == []
        assert loop.extra_reach > 0.0  # held anywhere: carried higher
        assert any("lifted No.11 instead" in n for n in job.ledger.records["No.19"]["notes"])
    else:
        assert attempt.name == "No.19" and put_back == ["No.19"]
    job.settings = ClearTableSettings(survey_latency=0.0, held_look={"name_instead": None})
    again = _attempt()
    with pytest.raises(EpisodeAbortError):
        job._after_lift(again, loop)  # type: ignore[arg-type]
    assert again.name == "No.19" and len(looked) == 1  # off: put back unlooked


@pytest.mark.parametrize(
    ("flag", "reading", "unnamed"),
    [(True, 0.024, 1), (False, 0.024, 0), (True, 0.008, 0)],  # 8 g: only No.12 (11 g), placed
)
def test_a_wrong_lift_no_look_names_is_laid_back_where_later_surveys_guess_it(
    monkeypatch: pytest.MonkeyPatch, flag: bool, reading: float, unnamed: int
) -> None:
    """Held-out 1633 (session 46): a grasp meant for No.15 (still in its place) lifted
    No.14, which no survey had seen; the look saw too little of it, it was put back, and its
    heap stayed an unknown region to the end, tied in colours between No.14 and No.10 (one
    box): nothing had booked a cloth there. A wrong lift of a cloth that weighs as one not
    placed is now booked unnamed where it was laid, as a double pick's unnamed other cloth."""
    from robot_app.control.held_look import HeldColours

    put_back: list[str] = []
    job = _job(monkeypatch, put_back)
    job.settings = ClearTableSettings(survey_latency=0.0, unnamed_wrong_lift=flag)
    job.ledger.placed("No.12", True)
    job.weigh = lambda: reading
    monkeypatch.setattr(table_clearer, "still_there", lambda recognizer, *args: True)  # No.19 stayed
    seen = HeldColours(200, 0.0, {}, fits={})  # too little seen to name it
    monkeypatch.setattr(table_clearer, "look_at_held", lambda *args, **kwargs: (seen, "looked 29 cm aside"))
    attempt = _attempt()
    loop = SimpleNamespace(arm=SimpleNamespace(resume_at=lambda q: None), extra_reach=0.0)
    with pytest.raises(EpisodeAbortError):
        job._after_lift(attempt, loop)  # type: ignore[arg-type]
    assert attempt.lift_check == "wrong" and put_back == ["No.19"] and attempt.unnamed_along == unnamed
    result = SimpleNamespace(outcome=table_clearer.Outcome.GRASP_FAILED, reason="put back")
    job.ledger.record_attempt(attempt, result, 9.0, 0.021)  # type: ignore[arg-type]
    assert [p.how for p in job.ledger.unnamed] == ["lifted instead of No.19, not named"] * unnamed


def test_of_cloths_of_one_box_not_told_apart_by_their_colours_the_one_nearest_the_extra_is_named(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # held-out 883 (session 35): No.19 (grey, 20 g) came up with No.14, showing 31 % of its own
    # against No.4's 22 % (black checks, 23 g): the pair went back unnamed and stayed
    for own, weight, named in (
        ({"No.11": 0.3, "No.10": 0.25}, {"No.10": 0.029}, "No.10"),  # No.10 nearer the 29 g extra
        ({"No.11": 0.25, "No.10": 0.3}, {"No.11": 0.029, "No.10": 0.035}, "No.11"),
    ):
        put_back: list[str] = []
        job, _ = _looking_job(monkeypatch, put_back, own)
        job.weights.update(weight)
        job.sort = SortSettings(default="colours", boxes={"whites": ()})
        attempt = _lift(job)
        assert attempt.came_along == (named,) and attempt.named_by == "look" and put_back == []
        assert any("not told from" in note and "nearest the extra weight" in note for note in attempt.notes)


def _drag_lift(
    monkeypatch: pytest.MonkeyPatch,
    reading: float,
    others: dict[str, float],
    stayed: set[str],
    drag_extra: float | None,
    drag_look: bool = False,
) -> tuple[table_clearer.AttemptState, list[str], list[str]]:
    """No.19 (21 g) lifted, the load cell reading `reading` [kg]; the survey saw `others`
    (name -> x offset of its 0.2 m square from No.19's [m]); after the lift those in
    `stayed` are still found where the survey saw them. Returns the attempt, the cloths
    put back and the cloths the check looked for."""
    put_back: list[str] = []
    looked: list[str] = []
    job = _job(monkeypatch, put_back)
    job.settings = ClearTableSettings(
        survey_latency=0.0, held_look={"name_companion": False}, drag_extra=drag_extra, drag_look=drag_look
    )
    job.weigh = lambda: reading
    grid = np.linspace(-0.1, 0.1, 21)
    square = np.array([[x, y, 0.0] for x in grid for y in grid])  # a model's points, 1 cm apart
    for recognizer in job.recognizers.values():
        recognizer.model.points_in = square
    monkeypatch.setattr(table_clearer, "remembered_companion", lambda *args: None)

    def still_there(recognizer, *args) -> bool:
        looked.append(recognizer.name)
        return recognizer.name != "No.19" and recognizer.name in stayed  # No.19 itself left

    monkeypatch.setattr(table_clearer, "still_there", still_there)
    monkeypatch.setattr(table_clearer, "to_world", lambda capture, pose: pose)
    attempt = _attempt()
    poses = {n: np.eye(4) for n in others}
    for n, x in others.items():
        poses[n][0, 3] = x
    attempt.others = tuple(SimpleNamespace(name=n, transform_model_to_camera=p) for n, p in poses.items())  # type: ignore[misc]
    with contextlib.suppress(EpisodeAbortError):
        job._after_lift(attempt, SimpleNamespace(arm=SimpleNamespace(resume_at=lambda q: None)))  # type: ignore[arg-type]
    return attempt, put_back, [n for n in looked if n != "No.19"]


def test_a_cloth_beside_the_lifted_one_gone_from_its_place_makes_a_slightly_heavy_lift_a_double_pick(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # 26 g for No.19's 21 g (within 30 % + 3 g), No.11 lay touching it and is gone: held-out
    # episode 1159's second lift (session 39), No.20 dragged partly off the table by No.19
    attempt, put_back, looked = _drag_lift(monkeypatch, 0.026, {"No.11": 0.15, "No.12": 0.5}, set(), 0.002)
    assert attempt.lift_check == "double" and put_back == ["No.19"]
    assert attempt.laid_back_too == ("No.11",) and attempt.named_by == "drag"
    assert looked == ["No.11"]  # No.12 lay 0.3 m clear of it: not looked for


def test_a_slightly_heavy_lift_whose_neighbours_stayed_or_a_lone_lift_s_reading_goes_on(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    attempt, put_back, looked = _drag_lift(monkeypatch, 0.026, {"No.11": 0.15}, {"No.11"}, 0.002)
    assert attempt.lift_check == "ok" and put_back == [] and looked == ["No.11"]
    attempt, put_back, looked = _drag_lift(monkeypatch, 0.0225, {"No.11": 0.15}, set(), 0.002)  # 1.5 g over
    assert attempt.lift_check == "ok" and put_back == [] and looked == []
    attempt, put_back, looked = _drag_lift(monkeypatch, 0.026, {"No.11": 0.15}, set(), None)  # check off
    assert attempt.lift_check == "ok" and put_back == [] and looked == []
    attempt, put_back, looked = _drag_lift(monkeypatch, 0.026, {"No.11": 0.23}, set(), 0.002)  # 3 cm apart
    assert attempt.lift_check == "ok" and put_back == [] and looked == []


def test_footprints_touch_within_reach_only() -> None:
    square = CORNERS[:, :2]  # four corners 0.2 m apart
    assert table_clearer.footprints_touch(square, square + np.array([0.21, 0.0]), 0.02)
    assert not table_clearer.footprints_touch(square, square + np.array([0.23, 0.0]), 0.02)
    assert not table_clearer.footprints_touch(square, np.zeros((0, 2)), 1.0)


def test_an_unknown_region_beside_the_lifted_cloth_bared_makes_a_slightly_heavy_lift_a_double_pick(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # held-out 1108, 1121, 1159 (session 39): what came along was an unknown region, a
    # put-back heap or a crumpled cloth, touching the lifted one in the pick's survey
    mask = np.zeros((40, 60), dtype=bool)
    mask[10:30, 30:50] = True  # at 1 cm per pixel: x 0.30-0.50 m, y 0.10-0.30 m
    region = table_clearer.UnknownRegion((40.0, 20.0), int(mask.sum()), mask)
    footprint = np.zeros_like(mask)
    footprint[10:30, 5:26] = True  # No.19's own pixels
    shown: list[np.ndarray] = []
    given = [0.0]  # the share of the region the check after the lift sees bared

    def bared(points, *args):
        shown.extend(points)
        return given

    monkeypatch.setattr(table_clearer, "bared_from_elsewhere", bared)
    for share, double in ((0.6, True), (0.1, False)):
        given[0] = share
        put_back: list[str] = []
        job = _job(monkeypatch, put_back)
        job.cell = SimpleNamespace(capture=lambda: SimpleNamespace(transform_right_camera_to_world=np.eye(4)))  # type: ignore[assignment]
        job.settings = ClearTableSettings(
            survey_latency=0.0, held_look={"name_companion": False}, drag_extra=0.002
        )
        job.weigh = lambda: 0.026  # 5 g over No.19's 21 g
        job.table_z = 0.0
        job.table = SimpleNamespace(  # type: ignore[assignment]
            pixels=lambda capture, u, v: np.column_stack([np.asarray(u) * 0.01, np.asarray(v) * 0.01]),
            point=lambda capture, uv: (uv[0] * 0.01, uv[1] * 0.01),
        )
        job._sheet = lambda capture: np.zeros((40, 60), dtype=bool)  # type: ignore[method-assign]
        job._before_pick = table_clearer._BeforePick(
            "No.19",
            (region,),
            footprint,
            np.eye(4),
            np.zeros(2),
            SimpleNamespace(),  # type: ignore[arg-type]
        )
        job.rig = SimpleNamespace(right=SimpleNamespace(camera_matrix=np.eye(3)))  # type: ignore[assignment]
        attempt = _attempt()
        attempt.transform_target_to_world = np.eye(4)
        attempt.transform_target_to_world[:2, 3] = [0.15, 0.20]  # its square reaches x = 0.25... 0.30
        grid = np.linspace(-0.15, 0.15, 31)
        job.recognizers["No.19"].model.points_in = np.array([[x, y, 0.0] for x in grid for y in grid])
        monkeypatch.setattr(table_clearer, "remembered_companion", lambda *args: None)
        monkeypatch.setattr(table_clearer, "still_there", lambda *args: False)
        with contextlib.suppress(EpisodeAbortError):
            job._after_lift(attempt, SimpleNamespace(arm=SimpleNamespace(resume_at=lambda q: None)))  # type: ignore[arg-type]
        assert (attempt.lift_check == "double") is double and (put_back == ["No.19"]) is double
        assert attempt.unnamed_along == int(double) and attempt.laid_back_too == ()
        assert any("the unknown region at (0.40, 0.20) beside No.19" in n for n in attempt.notes)
        # judged only on its inner part, outside No.19's grown footprint (x >= 0.32 m)
        assert shown and min(float(p[:, 0].min()) for p in shown) >= 0.32 - 1e-9
        shown.clear()


def test_a_touching_cloth_seen_in_its_place_but_showing_hanging_makes_the_lift_a_double_pick(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    looks: list[tuple[str, tuple[str, ...]]] = []

    def showing(own: dict[str, float]):
        def look(job, meant, others, looks_=1, **kwargs):
            looks.append((meant, tuple(others)))
            return HeldColours(2000, 0.8, {n: own.get(n, 0.0) for n in others}), "looked from 10 cm aside"

        return look

    monkeypatch.setattr(table_clearer, "look_at_held", showing({"No.11": 0.15}))
    others = {"No.11": 0.15, "No.12": 0.5}
    attempt, put_back, _ = _drag_lift(monkeypatch, 0.026, others, {"No.11", "No.12"}, 0.002, drag_look=True)
    assert attempt.lift_check == "double" and put_back == ["No.19"]
    assert attempt.laid_back_too == ("No.11",) and attempt.named_by == "look" and attempt.unnamed_along == 0
    # every cloth not placed that weighs the 5 g extra or more was looked for, but No.12,
    # which the survey saw apart from No.19
    assert looks == [("No.19", ("No.10", "No.11"))]
    # two showing alike: one unnamed cloth came along
    monkeypatch.setattr(table_clearer, "look_at_held", showing({"No.11": 0.15, "No.12": 0.12}))
    attempt, put_back, _ = _drag_lift(monkeypatch, 0.026, {"No.11": 0.15}, {"No.11"}, 0.002, drag_look=True)
    assert attempt.lift_check == "double" and attempt.laid_back_too == () and attempt.unnamed_along == 1
    # nothing of another cloth's own colours hanging: the lift goes on
    monkeypatch.setattr(table_clearer, "look_at_held", showing({"No.11": 0.05}))
    attempt, put_back, _ = _drag_lift(monkeypatch, 0.026, {"No.11": 0.15}, {"No.11"}, 0.002, drag_look=True)
    assert attempt.lift_check == "ok" and put_back == [] and attempt.looked
    # nothing touched the lifted cloth: no look
    looks.clear()
    attempt, put_back, _ = _drag_lift(monkeypatch, 0.026, {"No.11": 0.5}, {"No.11"}, 0.002, drag_look=True)
    assert attempt.lift_check == "ok" and looks == [] and not attempt.looked
