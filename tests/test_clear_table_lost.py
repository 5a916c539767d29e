"""A cloth the clear-table job lost (dropped, laid back) is matched to an unknown region by
its colours only when exactly one lost cloth's colours fit. Synthetic pair (numpy renderer)
with the identification resolved at set poses, as in test_identify."""

from __future__ import annotations

from dataclasses import replace
from itertools import combinations
from types import SimpleNamespace

import cv2
import numpy as np
import pytest

from robot_app.control.clear_table_records import (
    BoxPlace,
    ClearTableSettings,
    LossKind,
    LostPlace,
    LostSettings,
    TableArea,
)
from robot_app.control.episode import Outcome
from robot_app.control.loop_settings import LoopSettings
from robot_app.control.table_furniture import graspable
from robot_app.control.table_ledger import TableLedger
from robot_app.control.table_lost import (
    UNGRASPABLE,
    LostMatch,
    colour_patches,
    inner_pixel,
    inner_pixels,
    match_heap,
    match_lost,
    near_the_loss,
    pick_lost,
    reachable_point,
    weighed_as,
)
from robot_app.control.table_survey import TablePlane
from robot_app.geometry import make_transform, rotation_about_z
from robot_app.vision import PinholeCamera, Recognition, Recognizer
from robot_app.vision.identify import IdentifySettings, UnknownRegion, resolve
from robot_app.vision.regions import sheet_mask, undistorted
from robot_app.vision.synthetic import render_stereo_pair
from robot_app.vision.synthetic_catalogue import synthetic_cloth
from tests.table_scene import CAMERA, RIG, ray_cast_table_xy, recognizer

YELLOW = make_transform(rotation_about_z(0.3), [-0.06, -0.02, 0.585])
VIOLET = make_transform(rotation_about_z(0.1), [0.12, 0.06, 0.585])  # recognised by no model


@pytest.fixture(scope="module")
def survey():
    left, right = render_stereo_pair(
        RIG, [(synthetic_cloth(1), YELLOW), (synthetic_cloth(9), VIOLET)], rng=np.random.default_rng(5)
    )
    recognizers = {
        "yellow": recognizer(1, "yellow"),
        "violet": recognizer(9, "violet"),
        "stripes": recognizer(2, "stripes"),
    }
    seen = Recognition(True, 0.9, YELLOW, 0, 0, 0.0, confidence=0.95, visible_fraction=1.0)
    ident = resolve({"yellow": recognizers["yellow"]}, {"yellow": seen}, right, IdentifySettings())
    capture = SimpleNamespace(left_bgr=left, right_bgr=right)
    return recognizers, ident, capture


def test_a_region_a_spent_lost_cloth_explains_goes_to_no_guess(survey) -> None:
    # held-out bench episode 227 (session 24): No.6, put back four times, had no attempts left
    # and left the candidates; its region went to the guessed No.7 of the other box
    recognizers, ident, capture = survey
    settings, centres = LostSettings(), [np.array([0.6, 0.1])]
    twins = {"violet": recognizers["violet"], "twin": recognizer(9, "violet twin")}
    boxes = {"violet": "whites", "twin": "colours"}.__getitem__
    guessed = frozenset({"twin"})
    alone = {"twin": twins["twin"]}  # the spent violet left out: the guess takes its region
    taken = match_lost(capture, ident.unknown, centres, alone, {}, settings, boxes, guessed)
    assert taken is not None and taken.name == "twin"
    spent = frozenset({"violet"})  # the spent violet ranked, never taken, and nobody else is
    assert match_lost(capture, ident.unknown, centres, twins, {}, settings, boxes, guessed, spent) is None
    only = {"violet": twins["violet"]}
    assert match_lost(capture, ident.unknown, centres, only, {}, settings, boxes, frozenset(), spent) is None


def test_a_region_two_lost_cloths_of_both_boxes_fit_alike_is_taken_as_a_tie_only_when_asked(survey) -> None:
    # held-out 1771 (session 49): No.19 (colours) and No.6 (whites), put back together, fit
    # their heap within the margin; neither was picked and the job stopped
    recognizers, ident, capture = survey
    settings, centres = LostSettings(), [np.array([0.6, 0.1])]
    twins = {"violet": recognizers["violet"], "twin": recognizer(9, "violet twin")}
    boxes = {"violet": "colours", "twin": "whites"}.__getitem__

    def match(lost, box_for=boxes, guessed=frozenset(), ties=True):
        return match_lost(capture, ident.unknown, centres, lost, {}, settings, box_for, guessed, ties=ties)

    assert match(twins, ties=False) is None  # as before: which one it is changes the box
    tie = match(twins)
    assert tie is not None and {tie.name, *tie.rivals} == {"violet", "twin"} and tie.alike == ()
    # a third cloth of the best one's box, as alike: its alike, the other box's its rivals
    three = {**twins, "triplet": recognizer(9, "violet triplet")}
    tie = match(three, {"violet": "colours", "twin": "whites", "triplet": "colours"}.__getitem__)
    assert tie is not None and tie.rivals == (("twin",) if tie.name != "twin" else ("violet", "triplet"))
    assert set(tie.alike) | set(tie.rivals) | {tie.name} == set(three)
    # not a tie (one box, or one cloth): the other rounds' to take, not this one's
    assert match(twins, box_for=lambda name: "colours") is None
    assert match({"violet": recognizers["violet"]}) is None
    # a guess among them: never
    assert match(twins, guessed=frozenset({"twin"})) is None


def test_an_unknown_region_is_a_lost_cloth_only_in_its_colours(survey) -> None:
    recognizers, ident, capture = survey
    assert [d.name for d in ident.detections] == ["yellow"] and len(ident.unknown) == 1
    region = ident.unknown[0]
    settings = LostSettings()
    centres = [np.array([0.6, 0.1])]  # the region's centre on the table (no place given: anywhere)

    def match(lost: dict[str, Recognizer], places: dict[str, LostPlace] | None = None, box_for=None):
        return match_lost(capture, ident.unknown, centres, lost, places or {}, settings, box_for)

    # the violet cloth was lost: the region shows its colours
    matched = match({name: recognizers[name] for name in ("violet", "stripes")})
    assert matched is not None and matched.name == "violet" and matched.region is region
    assert matched.share >= settings.min_share and matched.alike == ()
    # only the stripes were lost: the region is not theirs, it is left alone
    assert match({"stripes": recognizers["stripes"]}) is None
    # two lost cloths of the same colours: which one it is cannot be told; neither is picked
    # when they belong in different boxes (or no sort rule is given) ...
    twins = {"violet": recognizers["violet"], "twin": recognizer(9, "violet twin")}
    assert match(twins) is None
    assert match(twins, box_for={"violet": "colours", "twin": "whites"}.__getitem__) is None
    # ... and one is, with the other as its alike, when both go into the same box
    same = match(twins, box_for=lambda name: "colours")
    assert same is not None and {same.name, *same.alike} == {"violet", "twin"} and len(same.alike) == 1

    # a guess for an unnamed companion is not taken where a cloth lost by name may lie too
    # (the two laid back together): the violet guessed, its twin lost by name, fitting as
    # well: the region is the named twin's, the guess its alike (taken only alone; held-out
    # 807, session 34: a named lost No.1 was left behind a guess, unpicked) ...
    def guessing(box_for, recognizers=twins):
        guessed = frozenset({"violet"})
        return match_lost(capture, ident.unknown, centres, recognizers, {}, settings, box_for, guessed)

    guess = guessing(lambda n: "colours")
    assert guess is not None and guess.name == "twin" and guess.alike == ("violet",)
    assert guess.guessed == {"violet"}
    # ... and where they belong in different boxes, neither
    assert guessing({"violet": "colours", "twin": "whites"}.__getitem__) is None
    # ... unless the named one's colours are not the region's (the stripes: under min_share)
    alone_guess = {"violet": recognizers["violet"], "stripes": recognizers["stripes"]}
    taken = match_lost(
        capture, ident.unknown, centres, alone_guess, {}, settings, None, frozenset({"violet"})
    )
    assert taken is not None and taken.name == "violet"
    # the twin was lost far from here: it cannot lie in this region, so it is no contender
    away = LostPlace(
        LossKind.DROPPED, "dropped in transfer", np.array([0.5, -0.3]), np.array([0.3, -0.56]), ()
    )
    alone = match(twins, {"twin": away})
    assert alone is not None and alone.name == "violet" and alone.alike == ()
    assert match({}) is None
    # where it was lost matters: far from the way it went, or where a region lay before, no
    here = LostPlace(
        LossKind.DROPPED, "dropped in transfer", np.array([0.5, 0.0]), np.array([0.3, -0.56]), ()
    )
    assert match({"violet": recognizers["violet"]}, {"violet": here}) is not None
    far = LostPlace(
        LossKind.DROPPED, "dropped in transfer", np.array([0.5, -0.2]), np.array([0.3, -0.56]), ()
    )
    assert match({"violet": recognizers["violet"]}, {"violet": far}) is None
    there_before = LostPlace(
        LossKind.PUT_BACK, "put back", np.array([0.5, 0.0]), np.array([0.6, 0.0]), ((0.61, 0.12),)
    )
    assert match({"violet": recognizers["violet"]}, {"violet": there_before}) is None
    # the grasp pixel lies inside the region, where the violet cloth is
    u, v = inner_pixel(region.mask)
    assert region.mask[round(v), round(u)]
    cu, cv = CAMERA.project(VIOLET[:3, 3][None])[0]
    assert np.hypot(u - cu, v - cv) < 25


def _survey_job(recognizers, capture):
    """A `TableClearer` with only what its survey rules read: the settings, the models, the
    survey's capture (no furniture in it) and a fresh ledger."""
    from robot_app.control import table_clearer

    job = table_clearer.TableClearer.__new__(table_clearer.TableClearer)
    job.settings, job.identify_settings = ClearTableSettings(), IdentifySettings()
    job.recognizers, job.rig, job._survey_capture = recognizers, RIG, capture  # type: ignore[assignment]
    job.ledger = TableLedger()
    job._without_furniture = lambda ident, capture: ident  # type: ignore[method-assign]
    return job


def _with_violet(recognizers, capture, violet: Recognition):
    """The survey's identification with the yellow cloth seen and the violet one recognised
    as `violet` says."""
    seen = Recognition(True, 0.9, YELLOW, 0, 0, 0.0, confidence=0.95, visible_fraction=1.0)
    pair = {name: recognizers[name] for name in ("yellow", "violet")}
    return resolve(pair, {"yellow": seen, "violet": violet}, capture.right_bgr, IdentifySettings())


def test_a_region_a_guess_fits_far_better_than_a_named_lost_cloth_is_not_taken_for_either(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # the named cloth's colours reach min_share, but its mix fits far worse than the guess's:
    # likely the two laid back together (bench episode 19), left to the heap rules
    from robot_app.control import table_lost
    from robot_app.control.colour_fit import ColourFit

    settings = LostSettings()
    region = UnknownRegion((100.0, 100.0), 400, np.ones((4, 4), bool))
    fits = {"guess": ColourFit(0.99, 1.0), "named": ColourFit(0.9, 0.8)}
    monkeypatch.setattr(table_lost, "colour_shares", lambda capture, mask, lost: fits)
    lost = dict.fromkeys(fits)

    def match():
        centres = [np.array([0.6, 0.0])]
        return match_lost(
            None, (region,), centres, lost, {}, settings, lambda n: "colours", frozenset({"guess"})
        )  # type: ignore[arg-type]

    assert 0.99 - fits["named"].score >= settings.margin and match() is None
    fits["named"] = ColourFit(0.9, 0.95)  # within the margin: the named one, the guess its alike
    found = match()
    assert found is not None and (found.name, found.alike, found.guessed) == ("named", ("guess",), {"guess"})
    fits["named"] = ColourFit(0.5, 1.0)  # under min_share: not its colours, the guess is taken
    found = match()
    assert found is not None and found.name == "guess"


def test_a_candidate_the_loop_could_not_confirm_is_left_to_the_lost_cloth_rules(survey) -> None:
    # held-out episode 730 (session 32): No.11, laid back crumpled, was a weak candidate the
    # loop's searches never confirmed; the job stopped with it on the table
    recognizers, _, capture = survey
    weak = Recognition(False, 0.6, VIOLET, 0, 0, 0.0, confidence=0.3, visible_fraction=0.6)
    both = _with_violet(recognizers, capture, weak)
    assert [d.name for d in both.detections] == ["yellow", "violet"] and both.unknown == ()
    job = _survey_job(recognizers, capture)
    job.ledger.last_seen["violet"], job.ledger.last_survey["violet"] = np.array([0.6, 0.1]), 2
    assert job._unconfirmed_as_unknown(both) is both  # the loop has not looked for it yet
    job.ledger.records["violet"] = {"attempts": 1, "sim_time": 0.0, "notes": [], "unconfirmed": True}
    rest = job._unconfirmed_as_unknown(both)
    assert [d.name for d in rest.detections] == ["yellow"] and len(rest.unknown) == 1
    cu, cv = CAMERA.project(VIOLET[:3, 3][None])[0]
    assert rest.unknown[0].mask[round(cv), round(cu)]
    assert job._book_hidden(rest) and job.ledger.lost["violet"].kind is LossKind.HIDDEN
    lost = {"violet": recognizers["violet"], "stripes": recognizers["stripes"]}
    where = {"violet": job.ledger.lost["violet"]}
    matched = match_lost(capture, rest.unknown, [np.array([0.6, 0.1])], lost, where, LostSettings())
    assert matched is not None and matched.name == "violet"  # picked blind, by its colours
    job.ledger.records["violet"]["attempts"] = job.settings.max_attempts  # attempts used up
    assert job._unconfirmed_as_unknown(both) is both
    job.ledger.records["violet"]["attempts"] = 1
    job.settings = ClearTableSettings(lost={"enabled": False})
    assert job._unconfirmed_as_unknown(both) is both


def test_a_lost_cloth_a_look_around_sees_weakly_is_picked_blind_by_its_colours(survey) -> None:
    # held-out episode 1704 (session 48): No.8, dropped off the sheet on the way to its box,
    # seen by a look around at 0.39, not found by the pick's searches (booked lost again),
    # seen at 0.37 by the next look: as a sighting it kept No.8 from the lost-cloth rules,
    # and the job stopped with No.8 on the table and attempts left
    recognizers, _, capture = survey
    weak = Recognition(False, 0.6, VIOLET, 0, 0, 0.0, confidence=0.37, visible_fraction=0.6)
    both = _with_violet(recognizers, capture, weak)
    job = _survey_job(recognizers, capture)
    job.sort = SimpleNamespace(box_for=lambda name: "colours")  # type: ignore[assignment]
    job.table = SimpleNamespace(point=lambda capture, pixel: (0.6, 0.1))  # type: ignore[assignment]
    job.weights = {"yellow": 0.02, "violet": 0.02, "stripes": 0.03}  # type: ignore[assignment]
    job.ledger.records["violet"] = {"attempts": 2, "sim_time": 0.0, "notes": [], "unconfirmed": True}
    dropped = LostPlace(
        LossKind.DROPPED, "dropped in transfer", np.array([0.6, 0.1]), np.array([0.3, -0.56]), ()
    )
    job.ledger.lost["violet"] = dropped
    assert job._lost_to_pick(both) is None  # a survey that "sees" it: not lost here
    rest, found = job._weak_lost_to_pick(both)
    assert found is not None and found.name == "violet"
    assert [d.name for d in rest.detections] == ["yellow"] and len(rest.unknown) == 1
    # not lost (only weakly seen), or its attempts used up: the look's survey stays as it was
    del job.ledger.lost["violet"]
    assert job._weak_lost_to_pick(both) == (both, None)
    job.ledger.lost["violet"] = dropped
    job.ledger.records["violet"]["attempts"] = job.settings.max_attempts
    assert job._weak_lost_to_pick(both) == (both, None)


def test_a_cloth_seen_in_its_box_yet_found_in_an_unknown_region_is_picked_again(survey) -> None:
    # held-out episode 768 (session 33): the grasp meant for No.13 lifted No.14 (same hue),
    # which went in and was seen in the box as No.13; No.13 stayed an unknown region
    recognizers, ident, capture = survey
    strong = Recognition(True, 0.9, VIOLET, 0, 0, 0.0, confidence=0.9, visible_fraction=1.0)
    both = _with_violet(recognizers, capture, strong)
    job = _survey_job(recognizers, capture)
    recorded, surveyed = [], []
    job._record_survey = lambda ident, chosen: recorded.append(ident)  # type: ignore[method-assign]

    def again(meanwhile=None, boxed=False):  # the second look: the violet one found where it lies
        surveyed.append(boxed)
        return both

    job._survey = again  # type: ignore[method-assign]
    assert job._boxed_again(ident) == (ident, None)  # nothing seen in a box: no second look
    job.ledger.placed("violet", confirmed=True)
    job.ledger.placed("yellow", confirmed=True)
    assert "violet" in job.ledger.seen_in_box
    rest, target = job._boxed_again(ident)
    assert surveyed == [True] and recorded == [ident]  # the first survey booked, then looked again
    assert target is not None and target.name == "violet"
    assert [d.name for d in rest.detections] == ["violet"]  # the yellow stays in its box
    assert "violet" not in job.ledger.seen_in_box and "violet" not in job.ledger.placed_order
    assert "yellow" in job.ledger.seen_in_box and job.ledger.placed_order == ["yellow"]
    assert "another cloth of its colours went in" in job.ledger.records["violet"]["notes"][-1]
    # found where the first survey saw no unknown region: still taken to be in its box
    job.ledger.placed("violet", confirmed=True)
    rest, target = job._boxed_again(replace(ident, unknown=(elsewhere_region(ident),)))
    assert target is None and "violet" in job.ledger.seen_in_box and rest.detections == ()
    job.settings = ClearTableSettings(boxed_again=None)
    assert job._boxed_again(ident) == (ident, None)


def test_a_region_in_the_colours_of_a_cloth_booked_placed_by_an_unsure_lift_is_that_cloth(survey) -> None:
    # replay of held-out 1438 (session 49): a blind lift meant for No.14, named No.2 by its
    # weight, held No.15 and went in as No.2; No.2 stayed an unknown region in its colours,
    # which no lost cloth's fit, and the job stopped with it on the table
    recognizers, ident, capture = survey
    job = _survey_job(recognizers, capture)
    job.sort = SimpleNamespace(box_for=lambda name: "colours")  # type: ignore[assignment]
    job.table = SimpleNamespace(point=lambda capture, pixel: (0.6, 0.1))  # type: ignore[assignment]
    job.weights = {"yellow": 0.02, "violet": 0.02, "stripes": 0.03}  # type: ignore[assignment]
    seen = replace(ident, detections=())  # the yellow one placed too: only the violet region

    def booked(unsure: dict[str, tuple[str, ...]], placed: tuple[str, ...]) -> None:
        job.ledger = TableLedger()
        for name in placed:
            job.ledger.placed(name, confirmed=True)
        job.ledger.placed_unsure = dict(unsure)

    booked({"violet": ("stripes",)}, ("yellow", "violet"))
    found = job._lost_to_pick(seen)
    assert found is not None and found.name == "violet"
    ledger = job.ledger
    assert "violet" not in ledger.placed_order and ledger.lost["violet"].kind is LossKind.HIDDEN
    assert "stripes" in ledger.placed_order and "violet" not in ledger.placed_unsure  # that lift held it
    # a booking that was sure, or whose other cloth is placed since: the region stays unknown
    booked({}, ("yellow", "violet"))
    assert job._lost_to_pick(seen) is None
    booked({"violet": ("stripes",)}, ("yellow", "violet", "stripes"))
    assert job._lost_to_pick(seen) is None
    # a region not in the unsure cloth's colours: nothing picked, nothing re-booked
    booked({"stripes": ("violet",)}, ("yellow", "stripes"))
    assert job._lost_to_pick(seen) is None
    assert job.ledger.placed_order == ["yellow", "stripes"] and not job.ledger.lost
    # lost cloths whose colours the region does not show leave it to the unsure one; its
    # other cloth, lost too, is booked for the earlier lift
    booked({"violet": ("stripes",)}, ("yellow", "violet"))
    laid = LostPlace(LossKind.PUT_BACK, "put back", np.array([0.6, 0.1]), np.array([0.6, 0.1]), ())
    job.ledger.lost["stripes"] = laid
    found = job._lost_to_pick(seen)
    assert found is not None and found.name == "violet"
    assert "stripes" in job.ledger.placed_order and "stripes" not in job.ledger.lost


def elsewhere_region(ident):
    """An unknown region of the same size as `ident`'s, mirrored to the image's other side."""
    region = ident.unknown[0]
    mask = region.mask[:, ::-1].copy()
    return replace(region, mask=mask)


def test_a_region_a_pick_moved_in_a_lost_cloths_colours_is_that_cloth_not_an_unnamed_one(survey) -> None:
    # held-out episode 744 (session 33): the put-back heap of No.7 moved with No.9's pick and
    # was booked an unnamed cloth; a guess of it, a cloth absent from the table, took five lifts
    from robot_app.control import table_clearer

    recognizers, ident, capture = survey
    (region,) = ident.unknown  # the violet cloth, no detection

    def job_after_pick(lost: tuple[str, ...], held: str = "yellow") -> table_clearer.TableClearer:
        job = table_clearer.TableClearer.__new__(table_clearer.TableClearer)
        job.settings, job.recognizers = ClearTableSettings(), recognizers
        job.sort = SimpleNamespace(box_for=lambda name: "colours")  # type: ignore[assignment]
        job.ledger = TableLedger()
        job.ledger.records["yellow"] = {"attempts": 1, "sim_time": 0.0, "notes": []}
        placed = SimpleNamespace(name=held, result=SimpleNamespace(outcome=Outcome.PLACED), put_back=False)
        job.ledger.attempts.append(placed)  # type: ignore[arg-type]
        laid = LostPlace(
            LossKind.PUT_BACK, "put back after the lift", np.array([0.5, 0.0]), np.array([0.6, 0.1]), ()
        )
        for name in lost:
            job.ledger.lost[name] = laid
        job._survey_camera_pose = np.eye(4)
        job._survey_capture = capture  # type: ignore[assignment]
        job.table = SimpleNamespace(point=lambda capture, pixel: (0.6, 0.1))  # type: ignore[assignment]
        job._survey_sheet = lambda: np.ones(region.mask.shape, bool)  # type: ignore[method-assign]
        footprint = np.zeros(region.mask.shape, bool)  # the picked cloth lay elsewhere
        job._before_pick = table_clearer._BeforePick(
            "yellow", (region,), footprint, np.eye(4), np.array([0.3, -0.56]), capture
        )
        job._notice_moved()
        return job

    job = job_after_pick(("violet", "stripes"))
    assert job.ledger.unnamed == []  # the lost violet cloth moved, no unnamed one came along
    moved = job.ledger.lost["violet"]
    assert moved.kind is LossKind.MOVED and np.allclose(moved.end, [0.3, -0.56])
    assert job.ledger.lost["stripes"].kind is LossKind.PUT_BACK  # not its colours: where it was
    assert any("moved violet (lost" in note for note in job.ledger.records["yellow"]["notes"])
    job = job_after_pick(("stripes",))  # no lost cloth in the region's colours: an unnamed one
    assert [place.kind for place in job.ledger.unnamed] == [LossKind.MOVED]
    assert job.ledger.lost["stripes"].kind is LossKind.PUT_BACK
    # the lift held another cloth than yellow (`_held_instead`): a region it left is that cloth
    job = job_after_pick(("stripes",), held="violet")
    assert job.ledger.unnamed == [] and job.ledger.lost["stripes"].kind is LossKind.PUT_BACK


def test_inner_pixel_lies_deep_inside_a_region_that_is_not_convex() -> None:
    mask = np.zeros((40, 60), bool)
    mask[5:35, 10:20] = True  # an L, 10 px wide: its centroid (17, 26) is near the bend's edge
    mask[25:35, 10:55] = True
    u, v = inner_pixel(mask)
    ui, vi = round(u), round(v)
    assert mask[vi - 4 : vi + 5, ui - 4 : ui + 5].all()  # 4 px from every border
    touching = np.zeros((10, 10), bool)
    touching[:, :4] = True  # a region at the image's edge: the edge is a border too
    u, v = inner_pixel(touching)
    assert 1 <= round(u) <= 2


def test_the_blind_grasp_takes_the_deepest_point_of_the_region_the_hand_can_reach() -> None:
    mask = np.zeros((40, 60), bool)
    mask[5:35, 10:20] = True  # the same L: deepest in its corner, near u = 15
    mask[25:35, 10:55] = True
    to_table = lambda px: (px[0] / 100, px[1] / 100)  # noqa: E731  (1 px = 1 cm)
    tried: list[tuple[float, float]] = []

    def beyond(x: float, y: float) -> bool:  # the arm reaches only beyond x = 0.30 m
        tried.append((x, y))
        return x >= 0.30

    x, y = reachable_point(mask, to_table, beyond)
    assert x >= 0.30 and mask[round(y * 100), round(x * 100)]
    assert mask[round(y * 100) - 3 : round(y * 100) + 4, round(x * 100) - 3 : round(x * 100) + 4].all()
    assert tried[0][0] < 0.30  # the innermost pixel was tried first, and refused
    spread = inner_pixels(mask, 8)
    assert all(np.hypot(a[0] - b[0], a[1] - b[1]) >= 4 for a, b in combinations(spread, 2))
    assert reachable_point(mask, to_table, lambda x, y: False) == to_table(inner_pixel(mask))


def test_a_lost_cloth_is_looked_for_along_the_way_it_was_lost() -> None:
    settings = LostSettings(reach=0.3, apart=0.05)
    drop = LostPlace(
        LossKind.DROPPED, "dropped in transfer", np.array([0.5, 0.0]), np.array([0.3, -0.56]), ((0.45, 0.2),)
    )
    assert near_the_loss(np.array([0.5, 0.0]), drop, settings)  # where it was lifted
    assert near_the_loss(np.array([0.55, -0.4]), drop, settings)  # beside the way to the box
    assert not near_the_loss(np.array([0.5, 0.45]), drop, settings)  # the other side of the table
    assert not near_the_loss(np.array([0.46, 0.21]), drop, settings)  # an unknown region was there before
    spot = LostPlace(
        LossKind.PUT_BACK, "put back", np.array([0.5, 0.0]), np.array([0.5, 0.0]), ()
    )  # let go where lifted
    assert near_the_loss(np.array([0.7, 0.1]), spot, settings)
    assert not near_the_loss(np.array([0.9, 0.0]), spot, settings)
    # laid back by the job over a region seen before: that region is no alibi; one off the
    # laid strip still is
    before = ((0.52, 0.04), (0.7, -0.2))
    laid = LostPlace(
        LossKind.PUT_BACK, "put back", np.array([0.5, 0.0]), np.array([0.5, -0.15]), before, laid=True
    )
    assert near_the_loss(np.array([0.52, 0.03]), laid, settings)
    assert not near_the_loss(np.array([0.7, -0.19]), laid, settings)
    dropped = LostPlace(
        LossKind.DROPPED, "dropped in transfer", np.array([0.5, 0.0]), np.array([0.5, -0.15]), before
    )
    assert not near_the_loss(np.array([0.52, 0.03]), dropped, settings)


def test_the_candidates_for_a_lost_cloth_are_the_lost_ones_and_after_a_nameless_double_the_unplaced_unseen(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from robot_app.control import table_clearer
    from robot_app.control.clear_table_records import ClearTableSettings
    from robot_app.control.table_ledger import TableLedger

    job = table_clearer.TableClearer.__new__(table_clearer.TableClearer)
    job.settings = ClearTableSettings()
    job.recognizers = {n: SimpleNamespace(name=n) for n in ("No.1", "No.2", "No.3", "No.4")}  # type: ignore[misc]
    job.ledger = TableLedger()
    job.table = SimpleNamespace(point=lambda capture, pixel: (0.5, 0.0))  # type: ignore[assignment]
    job._survey_capture = None  # type: ignore[assignment]
    job.sort = SimpleNamespace(box_for=lambda name: "colours")  # type: ignore[assignment]
    asked: list[tuple[set[str], dict[str, LostPlace]]] = []

    def fake_match(
        capture,
        regions,
        centres,
        lost,
        places,
        settings,
        box_for=None,
        guessed=frozenset(),
        spent=frozenset(),
        ties=False,
    ):
        if ties:  # the last round, for a tie across boxes (`_tie_to_pick`)
            tied.append((set(lost), set(guessed)))
            return None
        asked.append((set(lost), dict(places)))
        guesses.append(set(guessed))
        spents.append(set(spent))
        return None

    guesses: list[set[str]] = []
    spents: list[set[str]] = []
    tied: list[tuple[set[str], set[str]]] = []

    monkeypatch.setattr(table_clearer, "match_lost", fake_match)
    ident = SimpleNamespace(detections=(SimpleNamespace(name="No.2"),), unknown=())
    place = LostPlace(LossKind.DROPPED, "dropped in transfer", np.zeros(2), np.ones(2), ())
    for name in ("No.1", "No.2"):  # both seen by surveys; No.1 was dropped, No.2 is seen now
        job.ledger.records[name] = {"attempts": 1, "sim_time": 0.0, "notes": []}
        job.ledger.lost[name] = place
    job._lost_to_pick(ident)  # type: ignore[arg-type]
    assert asked[-1][0] == {"No.1"}  # No.3 and No.4 were never seen and nothing came up unnamed
    nameless = LostPlace(LossKind.PUT_BACK, "came up with No.1, not named", np.zeros(2), np.ones(2), ())
    job.ledger.unnamed.append(nameless)
    job._lost_to_pick(ident)  # type: ignore[arg-type]
    lost, places = asked[-1]
    assert lost == {"No.1", "No.3", "No.4"}
    assert places["No.3"] is nameless and places["No.1"] is place
    assert tied[-1] == ({"No.1"}, set())  # a tie: the cloths lost by name only, no guess
    assert guesses[-1] == {"No.3", "No.4"} and guesses[0] == set()  # No.1 is known by name
    job.ledger.records["No.1"]["attempts"] = job.settings.max_attempts  # attempts used up
    job._lost_to_pick(ident)  # type: ignore[arg-type]
    # still ranked (its colours explain its region: no guess takes it), never taken
    assert asked[-1][0] == {"No.1", "No.3", "No.4"} and spents[-1] == {"No.1"}
    assert spents[0] == set()
    # seen once and never picked is no alibi (bench episode 19's No.5, identified at 0.24 by
    # the first survey, came up with the first pick and was laid back with it); placed is
    job.ledger.records["No.3"] = {"attempts": 0, "sim_time": 0.0, "notes": []}
    job.ledger.records["No.4"] = {"attempts": 1, "sim_time": 0.0, "notes": []}
    job.ledger.placed_order.append("No.4")
    job._lost_to_pick(ident)  # type: ignore[arg-type]
    assert asked[-1][0] == {"No.1", "No.3"} and asked[-1][1]["No.3"] is nameless  # No.1: spent
    # a suspect (seen by a survey, not seen now, not placed) is asked alone first, then with
    # every other guess (bench episode 60, session 20)
    job.ledger.records["No.4"]["attempts"] = 0
    job.ledger.placed_order.remove("No.4")
    job.ledger.last_seen["No.4"] = np.array([0.5, 0.1])
    job._lost_to_pick(ident)  # type: ignore[arg-type]
    assert [guess for guess in guesses[-2:]] == [{"No.4"}, {"No.3", "No.4"}]
    assert asked[-2][0] == {"No.1", "No.4"} and asked[-2][1]["No.4"] is nameless
    job.ledger.last_seen["No.2"] = np.array([0.6, 0.0])  # seen now: no suspect, nor a guess
    job.ledger.last_seen["No.3"] = np.array([0.4, 0.0])  # every guess a suspect: one round
    calls = len(asked)
    job._lost_to_pick(ident)  # type: ignore[arg-type]
    assert len(asked) == calls + 1 and guesses[-1] == {"No.3", "No.4"}
    job.settings = ClearTableSettings(lost={"enabled": False})
    assert job._lost_to_pick(ident) is None and len(asked) == calls + 1  # type: ignore[arg-type]


def _look_around_over_the_sheet():
    """A `TableRecovery` (look_around 2, look_apart 0.08 m) with nothing looked at, a survey
    from over the sheet's middle and no unknown region: (recovery, capture, identification)."""
    from robot_app.control.clear_table_records import ClearTableSettings
    from robot_app.control.table_recovery import TableRecovery

    recovery = TableRecovery.__new__(TableRecovery)
    recovery.settings = ClearTableSettings(look_around=2, look_apart=0.08)
    recovery.forget()
    camera_over = np.eye(4)
    camera_over[:2, 3] = (0.55, 0.0)
    capture = SimpleNamespace(transform_right_camera_to_world=camera_over)
    ident = SimpleNamespace(unknown=())
    return recovery, capture, ident


def test_after_a_drop_the_job_looks_along_the_way_to_the_box() -> None:
    recovery, capture, ident = _look_around_over_the_sheet()
    way = (np.array([0.45, -0.25]), np.array([0.40, -0.40]))
    seen_before = {"No.3": np.array([0.6, 0.2])}
    places = recovery.places_to_look(capture, ident, seen_before, lambda name: True, way)  # type: ignore[arg-type]
    np.testing.assert_allclose(places, [way[0], way[1]])  # the way first, at most look_around places
    places = recovery.places_to_look(capture, ident, seen_before, lambda name: True)  # type: ignore[arg-type]
    np.testing.assert_allclose(places, [seen_before["No.3"]])  # no drop: the cloth seen before
    recovery.looked = [way[0].copy()]
    places = recovery.places_to_look(capture, ident, seen_before, lambda name: True, way)  # type: ignore[arg-type]
    np.testing.assert_allclose(places, [way[1]])  # one look left, the way's first place looked at


def test_any_pick_attempt_gives_the_look_around_its_looks_again() -> None:
    """Bench episode 24 (session 17): after a blind pick of a lost cloth the job had no
    look left, since only the loop's picks started the count afresh; the ledger's count of
    attempts does it now, whatever the pick path."""
    recovery, capture, ident = _look_around_over_the_sheet()
    seen = {"No.3": np.array([0.6, 0.2]), "No.5": np.array([0.4, 0.2])}

    def look(attempts: int) -> list:
        return recovery.places_to_look(capture, ident, seen, lambda name: True, (), attempts)  # type: ignore[arg-type]

    first = look(attempts=3)
    assert len(first) == 2
    recovery.looked.extend(first)  # both looked at, nothing found
    assert look(attempts=3) == []  # no look left until a pick
    again = look(attempts=4)  # a pick attempt (any kind) was booked since
    assert len(again) == 2
    np.testing.assert_allclose(again, first)


def test_a_white_cloths_shaded_folds_count_as_its_colours_a_dark_cloths_do_not_grow_light() -> None:
    from robot_app.control.colour_fit import palette_share
    from robot_app.vision.hue import DARK, LIGHT

    white, black, red = np.array([LIGHT]), np.array([DARK]), np.array([0, 250])
    # a crumpled white cloth: lit parts light, its folds in its own shade dark, a few tinted
    heap = np.array([LIGHT] * 50 + [DARK] * 40 + [30] * 10)
    assert palette_share(heap, white, 10) == pytest.approx(0.9)
    assert palette_share(heap, black, 10) == pytest.approx(0.4)  # ahead by the white's light half
    assert palette_share(heap, red, 10) == 0.0
    # a crumpled black cloth: shade leaves it dark; a white palette takes it too (no hue),
    # so a lost white and a lost black cloth are not told apart by colour: neither is picked
    soot = np.array([DARK] * 95 + [LIGHT] * 5)
    assert palette_share(soot, black, 10) == pytest.approx(0.95)
    assert palette_share(soot, white, 10) == pytest.approx(1.0)
    # hues as before: within the threshold on the circle
    assert palette_share(np.array([5, 252, 128]), red, 10) == pytest.approx(2 / 3)
    assert palette_share(np.array([], dtype=int), white, 10) == 0.0


def test_a_dark_region_is_no_white_cloth(monkeypatch: pytest.MonkeyPatch) -> None:
    # bench episode 60 (session 21): No.20's black heap was 95 % "in the colours" of the
    # guessed whites No.17 and No.18 (their folds' shade counts as theirs); once No.20 was
    # booked placed, the heap was taken for No.17 and went into the whites box
    from robot_app.control import table_lost
    from robot_app.control.colour_fit import MIN_LIGHT_SHARE, ColourFit, shows_light
    from robot_app.vision.hue import DARK, LIGHT

    assert shows_light(np.array([LIGHT] * 50 + [DARK] * 40 + [30] * 10)) == 1.0  # a crumpled white
    assert shows_light(np.array([DARK] * 100)) == 0.0  # a black heap
    soot = np.array([DARK] * 95 + [LIGHT] * 5)
    assert shows_light(soot) == pytest.approx(0.05 / MIN_LIGHT_SHARE)
    assert shows_light(np.array([], dtype=int)) == 0.0
    region = UnknownRegion((10.0, 10.0), 100, np.ones((20, 20), bool))
    fits = {"No.17": ColourFit(0.95, 1.0, shows_light(np.array([DARK] * 100)))}
    monkeypatch.setattr(table_lost, "colour_shares", lambda capture, region, lost: fits)
    lost = {"No.17": None}
    settings = LostSettings()
    assert match_lost(None, (region,), [np.zeros(2)], lost, {}, settings) is None  # type: ignore[arg-type]
    fits["No.17"] = ColourFit(0.95, 1.0, 1.0)  # the same share with its white showing: taken
    taken = match_lost(None, (region,), [np.zeros(2)], lost, {}, settings)  # type: ignore[arg-type]
    assert taken is not None and taken.name == "No.17"


def test_a_dark_cloth_seen_hanging_is_no_white_print(monkeypatch: pytest.MonkeyPatch) -> None:
    """Held-out 1108 and 1129 (sessions 38-39): the grey No.19 and the black No.20 seen
    hanging, nearly all DARK, fitted the white print No.6 (73 % LIGHT, blue and pink motifs,
    whites) at 0.72 (its LIGHT takes DARK as its folds' shade), and went back at every lift.
    A cloth whose main colour is white must show white, as an all-white one must."""
    from robot_app.control import colour_fit
    from robot_app.vision import FitnessSettings
    from robot_app.vision.hue import DARK, LIGHT

    blue, pink = 196, 254
    print_codes = np.array([LIGHT] * 73 + [blue] * 15 + [pink] * 12, dtype=np.uint16)  # No.6's S_in

    def recognizer(codes: np.ndarray) -> SimpleNamespace:
        model = SimpleNamespace(hues_in=codes, texture_bgr=None, texture_mask=None)
        return SimpleNamespace(model=model, settings=SimpleNamespace(fitness=FitnessSettings()))

    recognizers = {
        "print": recognizer(print_codes),
        "black": recognizer(np.array([DARK] * 100, dtype=np.uint16)),
    }
    seen = {"codes": np.zeros((10, 10), np.uint16)}
    monkeypatch.setattr(
        colour_fit,
        "survey_colours",
        lambda capture, recs: (np.full((10, 10, 3), 60, np.uint8), np.ones(3), seen["codes"]),
    )
    mask = np.ones((10, 10), bool)
    seen["codes"][:] = DARK  # a dark cloth hanging
    fits = colour_fit.colour_shares(None, mask, recognizers)  # type: ignore[arg-type]
    assert fits["black"].score == pytest.approx(1.0)
    assert fits["print"].share == pytest.approx(1.0)  # its white's folds explain the dark ...
    assert fits["print"].score == 0.0  # ... but none of its white shows
    seen["codes"][:] = LIGHT
    seen["codes"][:, 7:] = DARK  # the print hanging: white, a part in its own shade
    seen["codes"][0, :3] = blue
    fits = colour_fit.colour_shares(None, mask, recognizers)  # type: ignore[arg-type]
    assert fits["print"].lightness == 1.0 and fits["print"].score > 0.7


def test_a_white_heap_fits_a_white_cloth_better_than_a_print_with_white_in_it() -> None:
    from robot_app.control.colour_fit import palette_proportions, palette_share
    from robot_app.vision.hue import DARK, LIGHT

    turquoise = 128
    heap = np.array([LIGHT] * 60 + [DARK] * 35 + [30] * 5)  # bench episode 1: two whites laid back
    white_towel = np.array([LIGHT] * 95 + [DARK] * 5)  # the models' own codes (S_in)
    stripes = np.array([LIGHT] * 50 + [turquoise] * 50)
    # the palettes alone explain the heap equally: that tied the whites with the stripes
    assert palette_share(heap, [LIGHT], 10) == palette_share(heap, [LIGHT, turquoise], 10)
    # the mix tells them apart: all white as the towel, half the stripes' mix missing
    assert palette_proportions(heap, white_towel, [LIGHT], 10) == pytest.approx(1.0)
    assert palette_proportions(heap, stripes, [LIGHT, turquoise], 10) == pytest.approx(0.5)
    # the stripes crumpled (both colours seen) fit their own mix, whatever the share of shade
    crumpled = np.array([LIGHT] * 30 + [DARK] * 20 + [turquoise] * 45 + [30] * 5)
    assert palette_proportions(crumpled, stripes, [LIGHT, turquoise], 10) > 0.9
    assert palette_proportions(crumpled, white_towel, [LIGHT], 10) == pytest.approx(1.0)
    assert palette_share(crumpled, [LIGHT], 10) == pytest.approx(0.5)  # but half its pixels only
    assert palette_proportions(np.array([30] * 9), stripes, [LIGHT, turquoise], 10) == 0.0


def test_a_cloth_may_look_darker_than_its_photo_not_lighter() -> None:
    from robot_app.control.colour_fit import LIGHTER_TOLERANCE, lit_value, not_lighter

    rng = np.random.default_rng(3)
    white = rng.integers(200, 256, (500, 3))  # a white cloth's photo, folds and lit parts
    grey = rng.integers(100, 170, (500, 3))
    heap = np.vstack([rng.integers(210, 256, (300, 3)), rng.integers(90, 140, (200, 3))])  # lit + shade
    own_white, own_grey, seen = lit_value(white), lit_value(grey), lit_value(heap)
    assert own_grey < 170 < 240 < own_white and seen > 240
    assert not_lighter(seen, own_white) == 1.0  # the white heap may be the white cloth
    assert not_lighter(seen, own_grey) == 0.0  # a grey cloth cannot look that light
    shaded = heap * 0.7  # the same heap in shade: as light as the grey cloth at most
    assert (
        not_lighter(lit_value(shaded), own_grey) == 1.0 and not_lighter(lit_value(shaded), own_white) == 1.0
    )
    assert not_lighter(own_grey + LIGHTER_TOLERANCE * 1.5, own_grey) == pytest.approx(0.5)
    assert lit_value(np.empty((0, 3))) == 0.0


def test_a_blind_lift_is_named_after_the_lost_cloths_whose_weights_it_reads() -> None:
    from robot_app.control.clear_table_records import ClearTableSettings

    settings = ClearTableSettings()  # 30 % + 3 g tolerance
    weights = {"No.1": 0.020, "No.2": 0.026, "No.3": 0.030, "No.4": 0.012}
    assert weighed_as(0.047, "No.1", ("No.2",), weights, settings) == ("No.1", "No.2")  # both came up
    assert weighed_as(0.047, "No.1", (), weights, settings) == ()  # no alike: a heavier lift is laid back
    # lighter than the meant cloth by more than the tolerance: its lighter alike alone
    assert weighed_as(0.011, "No.3", ("No.4", "No.2"), weights, settings) == ("No.4",)
    # two together are the most one lift is taken for: at three cloths' weight the tolerance
    # is a whole cloth's, and three cannot be told from four (held-out episode 593)
    assert weighed_as(0.076, "No.1", ("No.2", "No.3"), weights, settings) == ()
    assert weighed_as(0.076, "No.1", ("No.2", "No.3"), weights, settings, most=3) == ("No.1", "No.2", "No.3")
    assert weighed_as(0.058, "No.1", ("No.2", "No.3"), weights, settings) == ("No.1", "No.2")
    assert weighed_as(0.047, "No.1", ("No.9",), weights, settings) == ()  # a weight not known: no
    # a lift from a piece of a heap is one cloth or nothing: the others below are not its alike
    assert weighed_as(0.047, "No.1", ("No.2",), weights, settings, most=1) == ()
    assert weighed_as(0.011, "No.3", ("No.4", "No.2"), weights, settings, most=1) == ("No.4",)

    # a guessed companion of a double pick (any known cloth not placed or seen) is taken alone,
    # never in a sum (bench episode 48, session 19: No.17 + the guessed No.6 held No.3 and No.18)
    def alone(weighed: float, name: str, alike: tuple[str, ...], guessed: str) -> tuple[str, ...]:
        return weighed_as(weighed, name, alike, weights, settings, alone_only=frozenset({guessed}))

    assert alone(0.047, "No.1", ("No.2",), guessed="No.2") == ()  # No.1 + No.2: a sum with a guess
    assert alone(0.026, "No.1", ("No.2",), guessed="No.2") == ("No.1",)
    assert alone(0.033, "No.1", ("No.2",), guessed="No.1") == ("No.2",)  # the guess alone is no sum
    assert alone(0.047, "No.1", ("No.2", "No.3"), guessed="No.9") == ("No.1", "No.2")  # others summed


# --------------------------------------------------------------- where a blind hand may aim
# Bench episode 24 (session 18): a lost cloth hanging over the table's edge next to the whites
# box; blind grasps aimed at its region's innermost pixel, whose ray met the table plane at
# y = 0.75 m where the table ends at 0.70, and one beside the box lifted a cloth hanging out
# of it. The cell's own geometry, as experiments/clear_table.py hands it in:
TABLE_TOP = TableArea((0.35 - 0.65, 0.35 + 0.65), (-0.70, 0.70))
WHITES = BoxPlace("whites", np.array([0.30, 0.56, 0.0]), 0.22, 0.10, 0.01)
DOWN_CAMERA = PinholeCamera.from_fov((320, 240), np.deg2rad(60))


def _camera_over(x: float, y: float, height: float = 0.5) -> np.ndarray:
    return make_transform(np.diag([1.0, -1.0, -1.0]), [x, y, height])  # looking straight down


def test_a_blind_grasp_aims_only_on_the_table_top_and_clear_of_the_box_walls() -> None:
    transform = _camera_over(0.45, 0.62)  # sees the table's +y edge and the whites box's corner
    capture = SimpleNamespace(transform_right_camera_to_world=transform)
    settings = LostSettings()
    whole, plane = np.ones((240, 320), bool), TablePlane(DOWN_CAMERA.camera_matrix, 0.0)
    aims = graspable(whole, capture, plane, TABLE_TOP, [WHITES], settings.edge_inset, settings.wall_clearance)
    x, y = ray_cast_table_xy(DOWN_CAMERA, transform)
    on_top = (y <= 0.70 - settings.edge_inset) & (x >= -0.30 + settings.edge_inset)
    reach = 0.11 + 0.01 + settings.wall_clearance  # inner half side, wall, clearance
    clear = np.maximum(np.abs(x - 0.30), np.abs(y - 0.56)) > reach
    truth = on_top & clear
    assert np.any(~on_top) and np.any(on_top & ~clear) and np.any(truth)  # all three in view
    assert np.count_nonzero(aims != truth) <= 0.002 * truth.size  # the rounding at the borders
    # a region wholly past the edge leaves no aim; the table top unknown, any point of it
    past = whole & (y > 0.71)
    assert not np.any(graspable(past, capture, plane, TABLE_TOP, [], 0.02, 0.05))
    assert np.array_equal(graspable(past, capture, plane, None, [], 0.02, 0.05), past)


def test_a_lost_cloth_with_no_graspable_part_is_not_grasped_blind_and_the_cause_is_booked() -> None:
    transform = _camera_over(0.45, 0.62)
    x, y = ray_cast_table_xy(DOWN_CAMERA, transform)
    past = (y > 0.72) & (np.abs(x - 0.45) < 0.05)  # a cloth hanging past the table's edge
    vs, us = np.nonzero(past)
    region = UnknownRegion((float(us.mean()), float(vs.mean())), int(past.sum()), past)
    ledger = TableLedger()
    ledger.lost["No.6"] = LostPlace(
        LossKind.PUT_BACK, "put back after the lift", np.array([0.4, 0.5]), np.array([0.45, 0.65]), ()
    )

    class NoMotion:  # the hand must not move
        def __getattr__(self, name: str):
            raise AssertionError(f"the arm was asked to {name}")

    job = SimpleNamespace(
        settings=ClearTableSettings(), loop_settings=LoopSettings(), table_z=0.0,
        survey_capture=SimpleNamespace(transform_right_camera_to_world=transform),
        boxes={"whites": WHITES}, sort=SimpleNamespace(box_for=lambda name: "whites"),
        table=TablePlane(DOWN_CAMERA.camera_matrix, 0.0), table_top=TABLE_TOP,
        motion=NoMotion(), ledger=ledger, cell=SimpleNamespace(time=42.0), weights={},
    )  # fmt: skip
    pick_lost(job, LostMatch("No.6", region, 0.9))  # type: ignore[arg-type]
    (attempt,) = ledger.attempts
    assert attempt.result.outcome is Outcome.UNREACHABLE and attempt.result.reason.startswith(UNGRASPABLE)
    assert attempt.result.grasp_attempts == 0 and attempt.result.sim_time == 0.0
    assert ledger.records["No.6"]["attempts"] == 1
    assert any(UNGRASPABLE in note for note in ledger.records["No.6"]["notes"])  # the cause, in its row


# --------------------------------------------------------------- a heap of several lost cloths
# Bench episode 29 (session 19): a grasp lifted four cloths (93 g), put back as one heap; no
# survey recognised any of them again and no lost cloth's colours filled 60 % of the heap's
# region, so none was picked again. Here three cloths lie in one heap, the yellow on top.
HEAP_TOP = make_transform(rotation_about_z(0.3), [0.0, -0.01, 0.580])
HEAP_RIGHT = make_transform(rotation_about_z(-0.4), [0.12, 0.04, 0.585])
HEAP_LEFT = make_transform(rotation_about_z(0.9), [-0.12, -0.03, 0.585])


def _foreground(placements, sheet_hue: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(left, right, not-sheet mask of the undistorted right image) of cloths at poses."""
    left, right = render_stereo_pair(RIG, placements, rng=np.random.default_rng(5))
    image = undistorted(right, RIG.right)
    return left, right, ~sheet_mask(image, sheet_hue, 12, 40)


def test_a_heap_of_lost_cloths_is_picked_where_one_of_them_shows_on_top() -> None:
    cloths = {"violet": (9, HEAP_RIGHT), "grey": (11, HEAP_LEFT), "yellow": (1, HEAP_TOP)}  # drawn in order
    models = {name: recognizer(n, name) for name, (n, _) in cloths.items()}
    hue = models["yellow"].model.background_hue  # the green sheet's, as the model photo measured it
    left, right, heap = _foreground([(synthetic_cloth(n), pose) for n, pose in cloths.values()], hue)
    alone = {name: _foreground([(synthetic_cloth(n), pose)], hue)[2] for name, (n, pose) in cloths.items()}
    visible = {
        "yellow": alone["yellow"],
        "grey": alone["grey"] & ~alone["yellow"],
        "violet": alone["violet"] & ~alone["yellow"] & ~alone["grey"],
    }
    count, _ = cv2.connectedComponents(heap.astype(np.uint8))
    assert count == 2  # one heap: a single unknown region
    vs, us = np.nonzero(heap)
    region = UnknownRegion((float(us.mean()), float(vs.mean())), int(heap.sum()), heap)
    capture = SimpleNamespace(left_bgr=left, right_bgr=right)
    settings, smallest = LostSettings(), 0.01 * heap.size

    def match(lost: dict[str, Recognizer], regions: tuple[UnknownRegion, ...]) -> LostMatch | None:
        return match_lost(capture, regions, [np.zeros(2)] * len(regions), lost, {}, settings)

    assert match(models, (region,)) is None  # no cloth's colours fill the heap's region
    patches = colour_patches(capture, (region,), models, smallest)
    assert patches and all(p.area < region.area and np.all(p.mask <= heap) for p in patches)
    for lost in (models, {"violet": models["violet"]}):
        found = match(lost, (region, *colour_patches(capture, (region,), lost, smallest)))
        assert found is not None
        name = "yellow" if len(lost) == 3 else "violet"  # the largest piece shown first
        assert found.name == name and found.share >= settings.min_share
        on_it = np.count_nonzero(found.region.mask & visible[name]) / found.region.area
        assert on_it >= 0.95  # the piece is that cloth's own visible part
        u, v = inner_pixel(found.region.mask)
        assert visible[name][int(v), int(u)]  # and the blind grasp aims at it
    assert colour_patches(capture, (region,), {}, smallest) == ()


def test_a_heap_is_not_lifted_blind_where_a_hidden_suspect_of_another_box_weighs_the_same() -> None:
    # bench episode 60 (session 21): the heap in No.20's colours, lifted blind as No.20, held
    # the suspect No.15 (seen before the double pick, gone since), hidden under it; both go into
    # colours. Had No.15 been a white cloth, neither colours nor weight would have told.
    from robot_app.control import table_clearer
    from robot_app.control.clear_table_records import ClearTableSettings

    job = table_clearer.TableClearer.__new__(table_clearer.TableClearer)
    job.settings = ClearTableSettings()
    whites = {"No.17", "No.12"}
    job.sort = SimpleNamespace(box_for=lambda name: "whites" if name in whites else "colours")  # type: ignore[assignment]
    job.weights = {"No.20": 0.025, "No.15": 0.0265, "No.17": 0.024, "No.12": 0.012}
    job.ledger = TableLedger()
    region = UnknownRegion((10.0, 10.0), 100, np.ones((20, 20), bool))
    found = LostMatch("No.20", region, 0.96)
    assert job._suspects_under(found, ()) == ()
    assert job._suspects_under(found, ("No.15",)) == ()  # same box: wherever it goes, it is right
    assert job._suspects_under(found, ("No.15", "No.17")) == ("No.17",)  # a white of the same weight
    assert job._suspects_under(found, ("No.12",)) == ()  # a white the load cell tells apart
    assert job._suspects_under(LostMatch("No.20", region, 0.96, alike=("No.17",)), ("No.17",)) == ()
    # a lost cloth named by the job that may lie there doubts a guess, never a named match
    assert job._suspects_under(found, (), ("No.17",)) == ()
    guess = LostMatch("No.20", region, 0.93, guessed=frozenset({"No.20"}))
    assert job._suspects_under(guess, (), ("No.17",)) == ("No.17",)
    assert job._suspects_under(guess, (), ("No.15", "No.12")) == ()  # same box; told by weight
    job.ledger.unsure["No.20"] = ("No.17",)  # laid back as No.20 by a lift that doubted No.17
    assert job._suspects_under(found, (), ("No.17",)) == ("No.17",)


def test_a_guess_is_doubted_for_the_never_seen_cloths_whose_colours_its_region_shows(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # held-out episode 327 (session 26): a double pick's companion, never seen, was guessed
    # the grey melange No.19 (its region 98 % in grey and white, 18.3 g read, No.19's 18.2 g)
    # and went into colours; it was the white No.18 (20.9 g), never seen (laid face down):
    # a never-seen cloth of another box that the region's colours and the weight fit as
    # well is doubted (the lift is looked at before it goes anywhere)
    from robot_app.control import table_clearer
    from robot_app.control.clear_table_records import ClearTableSettings
    from robot_app.control.colour_fit import ColourFit

    job = table_clearer.TableClearer.__new__(table_clearer.TableClearer)
    job.settings = ClearTableSettings()
    whites = {"No.17", "No.18"}
    job.sort = SimpleNamespace(box_for=lambda name: "whites" if name in whites else "colours")  # type: ignore[assignment]
    job.weights = {"No.19": 0.0182, "No.18": 0.0209, "No.17": 0.030, "No.2": 0.023, "No.13": 0.019}
    job.recognizers = dict.fromkeys(job.weights)  # type: ignore[assignment]
    job.ledger = TableLedger()
    job._survey_capture = None  # type: ignore[assignment]
    fits = {
        "No.18": ColourFit(0.98, 1.0, 0.9),  # white: its folds' grey counts as its colour
        "No.17": ColourFit(0.98, 1.0, 0.9),
        "No.2": ColourFit(0.70, 0.9),  # turquoise-white stripes: the white part
        "No.13": ColourFit(0.05, 1.0),  # denim: not its colours
    }
    asked: list[set[str]] = []

    def shares(capture, mask, recognizers):
        asked.append(set(recognizers))
        return {n: fits[n] for n in recognizers}

    monkeypatch.setattr(table_clearer, "colour_shares", shares)
    region = UnknownRegion((10.0, 10.0), 100, np.ones((20, 20), bool))
    guess = LostMatch("No.19", region, 0.98, alike=("No.2",), guessed=frozenset({"No.19", "No.2"}))
    unseen = ("No.19", "No.18", "No.17", "No.2", "No.13")
    under = job._unseen_under(guess, unseen)
    assert set(under) == {"No.18", "No.17", "No.2"} and "No.19" not in asked[-1]
    # of those, the ones of another box that weigh as much: No.17 (30 g) the load cell tells apart
    assert job._suspects_under(guess, under) == ("No.18",)
    fits["No.18"] = ColourFit(0.98, 1.0, 0.3)  # a region with hardly any white: no white cloth
    assert "No.18" not in job._unseen_under(guess, unseen)
    fits["No.18"] = ColourFit(0.98, 1.0, 0.9)
    job.ledger.placed_order.append("No.18")  # placed: not on the table
    assert "No.18" not in job._unseen_under(guess, unseen)
    # a cloth the job named (lost by it, not guessed) is not doubted for unseen ones
    assert job._unseen_under(LostMatch("No.19", region, 0.98), unseen) == ()


def test_a_guess_lifted_where_a_named_lost_cloth_may_lie_is_looked_at_first() -> None:
    # held-out episode 233 (session 24): the heap where No.9 (colours, 17 g) had been laid
    # back showed 28 % of its colours and 93 % of the guessed white No.6's (21 g); the blind
    # lift held No.9 and put it into the whites box
    from robot_app.control import table_clearer
    from robot_app.control.clear_table_records import ClearTableSettings

    job = table_clearer.TableClearer.__new__(table_clearer.TableClearer)
    job.settings = ClearTableSettings()
    job.table = SimpleNamespace(point=lambda capture, uv: (0.63, -0.05))  # type: ignore[assignment]
    job._survey_capture = None  # type: ignore[assignment]
    laid = LostPlace(
        LossKind.PUT_BACK, "put back after the lift", np.array([0.63, -0.14]), np.array([0.63, -0.03]), ()
    )
    far = LostPlace(
        LossKind.PUT_BACK, "put back after the lift", np.array([0.30, 0.30]), np.array([0.35, 0.30]), ()
    )
    region = UnknownRegion((10.0, 10.0), 100, np.ones((20, 20), bool))
    found = LostMatch("No.6", region, 0.93, guessed=frozenset({"No.6"}))
    job.ledger = TableLedger()
    assert job._lost_near(found, {"No.9": laid, "No.4": far, "No.6": laid}) == ("No.9",)
    # the look put the lift back: No.9 may lie where it was laid, far from its loss
    laid_again = LostPlace(LossKind.PUT_BACK, "put back", np.array([0.63, -0.05]), np.array([0.28, 0.10]), ())
    found_there = LostMatch("No.6", region, 0.93, guessed=frozenset({"No.6"}))
    job.table = SimpleNamespace(point=lambda capture, uv: (0.25, 0.10))  # type: ignore[assignment]
    assert job._lost_near(found_there, {"No.9": laid}) == ()
    job.ledger.maybe["No.9"] = [laid_again]
    assert job._lost_near(found_there, {"No.9": laid}) == ("No.9",)


def test_a_cloth_a_pick_moved_is_looked_for_along_the_way_to_the_box() -> None:
    # bench episode 12 (session 21): after the pick of No.16 had moved an unidentified cloth
    # (the sheet bared where it lay), three cloths were gone from the view and never looked for
    from robot_app.control import table_clearer
    from robot_app.control.clear_table_records import ClearTableSettings
    from robot_app.control.table_ledger import TableLedger

    job = table_clearer.TableClearer.__new__(table_clearer.TableClearer)
    job.settings, job.ledger = ClearTableSettings(), TableLedger()
    job._survey_capture = None  # type: ignore[assignment]
    asked: list[tuple[np.ndarray, ...]] = []
    job.recovery = SimpleNamespace(  # type: ignore[assignment]
        places_to_look=lambda capture, ident, seen, look_for, dropped_on, attempts: (
            asked.append(dropped_on) or []
        )
    )
    job._places_to_look(SimpleNamespace(unknown=()))  # type: ignore[arg-type]
    assert asked[-1] == ()
    way = (np.array([0.6, -0.1]), np.array([0.3, -0.56]))
    job.ledger.unnamed.append(LostPlace(LossKind.MOVED, "moved by the pick of No.16", *way, ()))
    job.ledger.unnamed.append(
        LostPlace(LossKind.PUT_BACK, "came up with No.2, not named", *way, ())
    )  # laid back: not
    job._places_to_look(SimpleNamespace(unknown=()))  # type: ignore[arg-type]
    np.testing.assert_allclose(
        asked[-1], [way[0] + 0.5 * (way[1] - way[0]), way[0] + 0.75 * (way[1] - way[0])]
    )


def test_a_heap_of_lost_cloths_of_one_box_is_taken_as_one() -> None:
    """Two lost cloths laid back over each other: one unknown region, neither's colours
    fill `min_share` of it alone, both together do (`match_heap`): taken for the named one
    with the other as its alike when both go into one box; never when one belongs in the
    other box, when none of them was lost by name, or when the colours are not theirs."""
    over = make_transform(rotation_about_z(0.5), [0.0, 0.0, 0.585])
    left, right = render_stereo_pair(
        RIG, [(synthetic_cloth(1), YELLOW), (synthetic_cloth(9), over)], rng=np.random.default_rng(7)
    )
    yellow, violet, stripes = recognizer(1, "yellow"), recognizer(9, "violet"), recognizer(2, "stripes")
    missed = Recognition(False, 0.1, YELLOW, 0, 0, 0.0, confidence=0.05, visible_fraction=0.0)
    ident = resolve({"yellow": yellow}, {"yellow": missed}, right, IdentifySettings())
    assert not ident.detections and len(ident.unknown) == 1
    capture = SimpleNamespace(left_bgr=left, right_bgr=right)
    settings, centres = LostSettings(), [np.array([0.6, 0.1])]
    colours = lambda name: "colours"  # noqa: E731
    both = {"yellow": yellow, "violet": violet}
    assert match_lost(capture, ident.unknown, centres, both, {}, settings, colours) is None  # neither alone

    def heap(named, suspects, box_for=colours):
        return match_heap(capture, ident.unknown, centres, named, suspects, {}, settings, box_for)

    taken = heap({"yellow": yellow}, {"violet": violet})
    assert taken is not None and taken.name == "yellow" and taken.alike == ("violet",)
    assert taken.share >= settings.min_share and taken.guessed == frozenset() and not taken.piece
    assert (
        heap({"yellow": yellow}, {"violet": violet}, {"yellow": "colours", "violet": "whites"}.__getitem__)
        is None
    )
    assert heap({}, both) is None  # no cloth lost by name
    assert heap({"yellow": yellow}, {}) is None  # one cloth is no heap
    assert heap({"yellow": yellow}, {"stripes": stripes}) is None  # not their colours


def test_no_grasp_comes_down_by_a_box_wall() -> None:
    """`clear_of_walls`: the whites box's outer walls lie 0.12 m from its centre; a grasp
    point within `wall_clearance` of them is refused, also for an identified cloth's grasp
    (`TableClearer._grasps_at`: held-out episode 107, a finger on the colours box's wall),
    before any IK is asked."""
    from robot_app.control import table_clearer
    from robot_app.control.table_furniture import clear_of_walls

    points = np.array([[0.30, 0.40], [0.30, 0.45], [0.12, 0.56], [0.30, 0.56], [0.60, 0.0]])
    np.testing.assert_array_equal(clear_of_walls(points, [WHITES], 0.05), [False, False, True, False, True])
    np.testing.assert_array_equal(clear_of_walls(points, [WHITES], 0.0), [True, False, True, False, True])
    job = table_clearer.TableClearer.__new__(table_clearer.TableClearer)
    job.boxes = {"whites": WHITES}
    job.settings = ClearTableSettings()
    job.loop_settings = LoopSettings()
    job.table_z = 0.0
    asked: list[list[float]] = []
    job.motion = SimpleNamespace(reaches=lambda p: asked.append(list(p)) or True)
    assert not job._grasps_at(np.array([0.30, 0.43, 0.01])) and asked == []
    assert job._grasps_at(np.array([0.60, 0.0, 0.01])) and len(asked) == 3


def test_a_blind_grasp_comes_down_over_its_point_not_across_a_wall() -> None:
    """`_approach`: from a low pose (by the box) up over the walls first, across at that
    height, then down to the pregrasp point; from a high pose across at that height; where
    the hand does not reach that height over the point, straight there once raised
    (held-out episode 107: a finger on the colours box's wall)."""
    from robot_app.control.table_lost import WALL_MARGIN, _approach

    reach = {"ok": True}
    job = SimpleNamespace(
        boxes={"whites": WHITES}, table_z=0.0, motion=SimpleNamespace(reaches=lambda p: reach["ok"])
    )
    safe = WHITES.wall_height + WALL_MARGIN
    low = _approach(np.array([0.30, 0.50, 0.08]), (0.18, 0.38), 0.03, 0.055, job)  # type: ignore[arg-type]
    np.testing.assert_allclose(low, [[0.30, 0.50, safe], [0.18, 0.38, safe], [0.18, 0.38, 0.085]])
    high = _approach(np.array([0.5, 0.0, 0.5]), (0.18, 0.38), 0.03, 0.055, job)  # type: ignore[arg-type]
    np.testing.assert_allclose(high, [[0.18, 0.38, safe], [0.18, 0.38, 0.085]])
    on_heap = _approach(np.array([0.5, 0.0, 0.5]), (0.6, 0.0), 0.12, 0.055, job)  # type: ignore[arg-type]
    np.testing.assert_allclose(on_heap, [[0.6, 0.0, 0.175]])  # above the walls already
    reach["ok"] = False
    base = _approach(np.array([0.30, 0.50, 0.08]), (0.18, 0.38), 0.03, 0.055, job)  # type: ignore[arg-type]
    np.testing.assert_allclose(base, [[0.30, 0.50, safe], [0.18, 0.38, 0.085]])


def test_a_blind_grasp_aims_away_from_where_blind_grasps_closed_on_nothing() -> None:
    """Held-out episode 409 (session 28): ten blind grasps at one spot of one region lifted
    nothing, the region's centre 8 cm away; the next grasp's aims leave out the pixels whose
    table point lies within `empty_reach` of such a spot, and a region with none left is
    given up."""
    from types import SimpleNamespace

    from robot_app.control.table_lost import away_from

    table = SimpleNamespace(pixels=lambda capture, u, v: np.stack([u / 100.0, v / 100.0], axis=1))
    aims = np.zeros((20, 20), bool)
    aims[5:15, 5:15] = True  # table points 0.05-0.14 m along both axes
    assert np.array_equal(away_from(aims, None, table, [], 0.06), aims)
    kept = away_from(aims, None, table, [np.array([0.05, 0.05])], 0.03)
    v, u = np.nonzero(aims & ~kept)
    assert len(u) and np.all(np.hypot(u / 100 - 0.05, v / 100 - 0.05) <= 0.03)  # only those near
    assert kept[14, 14] and not kept[5, 5]
    assert not np.any(away_from(aims, None, table, [np.array([0.1, 0.1])], 0.2))


# the catalogue's cloths whose main colours are all tones (`TableClearer.tones_only`): the
# white towel and linen (whites), the grey melange and the black tee (colours)
TONES_ONLY = ("No.17", "No.18", "No.19", "No.20")


def scale_job(weights: dict[str, float], whites: tuple[str, ...]) -> SimpleNamespace:
    """What `_weighs_more_like` asks of the job: the cloths' weights [kg], the sort rule
    (`whites` go there, the rest into colours), the settings, which cloths are of tones only."""
    return SimpleNamespace(
        weights=dict(weights),
        sort=SimpleNamespace(box_for=lambda n: "whites" if n in whites else "colours"),
        settings=ClearTableSettings(),
        tones_only=lambda n: n in TONES_ONLY,
    )


def test_a_blind_lift_whose_weight_is_nearer_a_doubted_cloth_of_another_box_is_not_taken() -> None:
    # held-out episode 769 (session 33): guessed No.6 (whites, 22 g), read 16.7 g, looked like
    # No.6 by its colours; it was No.19 (colours, 20 g), and went into whites. Held-out 939
    # (session 36): the same pair of colours under a name (lost No.17), into whites too
    from robot_app.control.table_lost import _weighs_more_like

    job = scale_job({"No.6": 0.022, "No.19": 0.020, "No.2": 0.027, "No.18": 0.0205}, ("No.6", "No.18"))
    doubted = ("No.2", "No.19", "No.18")
    assert _weighs_more_like(job, "No.6", doubted, 0.0167, "whites") == "No.19"  # type: ignore[arg-type]
    assert _weighs_more_like(job, "No.6", doubted, 0.0215, "whites") == ""  # type: ignore[arg-type]
    assert _weighs_more_like(job, "No.6", ("No.2", "No.18"), 0.0167, "whites") == ""  # type: ignore[arg-type]
    assert _weighs_more_like(job, "No.6", doubted, None, "whites") == ""  # type: ignore[arg-type]
    # the colours seen hanging: No.19's fit 0.49 to No.6's 0.72 is near enough for the scale to
    # decide; 0.00 to 0.97 is not (held-out 799: No.15 of colours, guessed No.14, went back)
    from robot_app.control.colour_fit import ColourFit
    from robot_app.control.held_look import HeldColours

    def seen(meant: float, other: float) -> HeldColours:
        fits = {n: ColourFit(other, 1.0) for n in doubted}
        return HeldColours(9000, 0.9, dict.fromkeys(doubted, 0.0), ColourFit(meant, 1.0), fits)

    assert _weighs_more_like(job, "No.6", doubted, 0.0167, "whites", seen(0.72, 0.49)) == "No.19"  # type: ignore[arg-type]
    assert _weighs_more_like(job, "No.6", doubted, 0.0167, "whites", seen(0.97, 0.0)) == ""  # type: ignore[arg-type]


def test_the_scale_overrules_a_blind_lifts_colours_only_by_more_than_its_own_error() -> None:
    # held-out 1244 (session 41): No.18 (whites, 20.8 g) read 19.4 g and showed its colours
    # (fit 0.99, No.19's 0.70); No.19 (colours, 20.1 g) was nearer by 0.7 g, within the
    # scale's error (2 g), and No.18 went back at its last attempt
    from robot_app.control.colour_fit import ColourFit
    from robot_app.control.held_look import HeldColours
    from robot_app.control.table_lost import _weighs_more_like

    job = scale_job({"No.18": 0.0208, "No.19": 0.0201}, ("No.18",))
    seen = HeldColours(21731, 0.99, {"No.19": 0.0}, ColourFit(0.99, 1.0), {"No.19": ColourFit(0.70, 1.0)})
    assert _weighs_more_like(job, "No.18", ("No.19",), 0.0194, "whites", seen) == ""  # type: ignore[arg-type]
    # weights 0.7 g apart: no reading tells them apart
    assert _weighs_more_like(job, "No.18", ("No.19",), 0.0150, "whites", seen) == ""  # type: ignore[arg-type]
    job.weights["No.19"] = 0.0170  # a lighter No.19: the 15.0 g reading lies 2.0 g nearer it
    assert _weighs_more_like(job, "No.18", ("No.19",), 0.0150, "whites", seen) == "No.19"  # type: ignore[arg-type]
    job.settings = ClearTableSettings(nearer_margin=0.0)  # without the margin, 0.7 g decided
    job.weights["No.19"] = 0.0201
    assert _weighs_more_like(job, "No.18", ("No.19",), 0.0194, "whites", seen) == "No.19"  # type: ignore[arg-type]


def test_after_looks_that_found_nothing_the_lost_cloth_is_sought_from_the_observation_pose(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # held-out 814 (session 34): No.19, dropped in transfer, lay as an unknown region the
    # observation survey saw; the two looks around saw nothing, and the job stopped
    from robot_app.control import table_clearer
    from robot_app.errors import InterruptError
    from robot_app.vision.identify import Identification

    region = UnknownRegion((100.0, 100.0), 400, np.ones((4, 4), bool))
    seen_from_above = Identification((), (), (), (region,), {})
    nothing = Identification((), (), (), (), {})
    surveys = iter([seen_from_above, nothing, seen_from_above])  # observation, a look, observation
    calls: list[str] = []
    match = object()
    job = table_clearer.TableClearer.__new__(table_clearer.TableClearer)
    job.settings, job.ledger = ClearTableSettings(look_at_boxes=False), TableLedger()
    job.cell = SimpleNamespace(set_gripper=lambda opening: None, time=0.0)  # type: ignore[assignment]
    job.loop_settings = LoopSettings()
    job.start = lambda: None  # type: ignore[method-assign]
    job._back_to_observation = lambda: calls.append("observation")  # type: ignore[method-assign]
    job._survey = lambda meanwhile=None, boxed=False: (calls.append("survey"), next(surveys))[1]  # type: ignore[method-assign]
    job._notice_moved = lambda: None  # type: ignore[method-assign]
    job._places_to_look = lambda ident: [np.array([0.6, 0.2])] if calls.count("look") == 0 else []  # type: ignore[method-assign]
    job._look_from = lambda place: (calls.append("look"), True)[1]  # type: ignore[method-assign]
    job._record_survey = lambda ident, chosen: None  # type: ignore[method-assign]
    job._lost_to_pick = lambda ident: match if ident is seen_from_above else None  # type: ignore[method-assign]
    job._result = lambda last, reason, interrupted, start, wall: (last, reason, interrupted)  # type: ignore[method-assign]
    job._looked_left = {}
    job._left = lambda ident, seen_by="": {"No.1": (f"{seen_by}: {len(ident.unknown)} region",)}  # type: ignore[method-assign]
    picked: list[object] = []

    def pick(job, found) -> None:
        picked.append(found)
        raise InterruptError("stop here")

    monkeypatch.setattr(table_clearer, "pick_lost", pick)
    last, reason, interrupted = job.run()  # type: ignore[misc]
    assert reason == "interrupted"
    # (a survey that chose no cloth sends the arm back first: no move where it is already)
    assert calls == ["observation", "survey", "observation", "look", "survey", "observation", "survey"]
    assert job._looked_left == {}  # the look saw no region: nothing kept for the results
    assert picked == [match] and last is seen_from_above and interrupted


def test_the_regions_the_last_look_saw_are_kept_for_the_results() -> None:
    # held-out 890 (session 35): a put-back pair lay where only a look around saw it; the job
    # stopped after the observation survey, which did not, and the results named no region
    from robot_app.control import table_clearer
    from robot_app.vision.identify import Identification

    region = UnknownRegion((100.0, 100.0), 400, np.ones((4, 4), bool))
    job = table_clearer.TableClearer.__new__(table_clearer.TableClearer)
    job._looked_left = {}
    job._left = lambda ident, seen_by="": {"No.2": (f"{seen_by}: {len(ident.unknown)} region",)}  # type: ignore[method-assign]
    job._record_survey = lambda ident, chosen: None  # type: ignore[method-assign]
    job._back_to_observation = lambda: None  # type: ignore[method-assign]
    job._survey = lambda meanwhile=None, boxed=False: Identification((), (), (), (), {})  # type: ignore[method-assign]
    job.ledger = TableLedger()
    job._from_observation(Identification((), (), (), (region,), {}))
    assert job._looked_left == {"No.2": ("seen by the last look around: 1 region",)}


def test_the_regions_left_at_the_end_are_noted_on_the_cloths_whose_colours_they_show(survey) -> None:
    # the evidence a failed episode needs, as bench reruns take other courses (807, 810)
    from robot_app.control.table_left import left_notes

    recognizers, ident, capture = survey
    settings = LostSettings()
    candidates = {name: recognizers[name] for name in ("violet", "stripes")}
    centres = [np.array([0.6, 0.1])]

    def notes(lost=None, untried=lambda name: True, empty=lambda centre: False):
        return left_notes(capture, ident.unknown, centres, candidates, lost or {}, settings, untried, empty)

    never = notes()
    assert list(never) == ["violet"]  # the stripes' colours are not the region's
    (text,) = never["violet"]
    assert "(0.60, 0.10)" in text and "stripes" in text and text.endswith("not booked lost")
    far = LostPlace(
        LossKind.DROPPED, "dropped in transfer", np.array([0.5, -0.2]), np.array([0.3, -0.56]), ()
    )
    near = LostPlace(
        LossKind.DROPPED, "dropped in transfer", np.array([0.5, 0.0]), np.array([0.3, -0.56]), ()
    )
    assert notes({"violet": far})["violet"][0].endswith("lost far from there (dropped in transfer)")
    assert ":" not in notes({"violet": near})["violet"][0].split(")")[-1]  # no gate closed
    spent = notes({"violet": near}, untried=lambda name: False, empty=lambda centre: True)["violet"][0]
    assert spent.endswith("no attempts left, blind grasps closed on nothing there")
    assert left_notes(capture, ident.unknown, centres, {}, {}, settings, bool, bool) == {}


def test_a_lift_reading_more_than_the_heavy_bound_is_a_double_pick_and_names_no_lone_cloth() -> None:
    from robot_app.control.clear_table_records import ClearTableSettings
    from robot_app.control.pick_checks import weight_verdict

    # held-out 1179 (session 40): No.7 (23.1 g) read 29.2 g with No.20 dragged partly along
    tight = ClearTableSettings(heavy_tolerance=0.15, heavy_floor=0.002)
    assert weight_verdict(0.0292, 0.0231, "No.7", tight, lift=True)[0] == "double"  # over 28.6 g
    assert weight_verdict(0.0284, 0.0231, "No.7", tight, lift=True)[0] == "ok"
    assert (
        weight_verdict(0.0292, 0.0231, "No.7", tight)[0] == "ok"
    )  # weights compared, not a lift: 30 % + 3 g
    assert weight_verdict(0.0292, 0.0231, "No.7", ClearTableSettings(), lift=True)[0] == "ok"  # unset
    # the light side stays 30 % + 3 g
    assert weight_verdict(0.0150, 0.0231, "No.7", tight, lift=True)[0] == "ok"
    assert weight_verdict(0.0130, 0.0231, "No.7", tight, lift=True)[0] == "wrong"
    # a blind lift so heavy is not that cloth alone, nor a pair it does not weigh
    weights = {"No.7": 0.0231, "No.2": 0.060}  # No.2: a heavy alike, far from 29 g
    assert weighed_as(0.0292, "No.7", ("No.2",), weights, tight) == ()
    assert weighed_as(0.0292, "No.7", ("No.2",), weights, ClearTableSettings()) == ("No.7",)
    assert weighed_as(0.085, "No.7", ("No.2",), weights, tight) == ("No.7", "No.2")


def test_between_two_cloths_of_tones_only_the_scale_decides_whatever_the_colour_fit() -> None:
    # held-out 1535 (session 45): a blind lift meant for No.17 (white towel, whites, 23.5 g)
    # read 19.1 g and fit No.17 at 0.99, No.19 at 0.49; it held No.19 (grey melange, colours,
    # 21.3 g), lit white, and went into whites
    from robot_app.control.colour_fit import ColourFit
    from robot_app.control.held_look import HeldColours
    from robot_app.control.table_lost import _weighs_more_like

    job = scale_job({"No.17": 0.0235, "No.19": 0.0213, "No.14": 0.0235}, ("No.17",))
    seen = HeldColours(3978, 0.99, {"No.19": 0.0}, ColourFit(0.99, 1.0), {"No.19": ColourFit(0.49, 1.0)})
    assert _weighs_more_like(job, "No.17", ("No.19",), 0.0191, "whites", seen) == "No.19"  # type: ignore[arg-type]
    # the reading as near No.17's weight: the scale does not overrule
    assert _weighs_more_like(job, "No.17", ("No.19",), 0.0230, "whites", seen) == ""  # type: ignore[arg-type]
    # a cloth with a hue meant (as heavy as No.17): its colours seen hanging still keep it
    job = scale_job(job.weights, ("No.14",))
    assert _weighs_more_like(job, "No.14", ("No.19",), 0.0191, "whites", seen) == ""  # type: ignore[arg-type]


def test_a_blind_lift_of_a_cloth_booked_placed_by_an_unsure_lift_goes_in_and_swaps_the_booking(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # held-out episode 1739 (session 48): a blind lift named No.6 (whites, 20.8 g), its region
    # as much in No.17's colours (whites, 24.0 g), held No.17 and was booked as No.6; the real
    # No.6 was then lifted blind ten times under guesses, fit none of them, and went back
    from robot_app.control import table_lost
    from robot_app.control.colour_fit import ColourFit
    from robot_app.control.held_look import HeldColours
    from robot_app.control.pick_checks import AttemptState
    from robot_app.control.table_lost import _the_earlier_lift, booked_in_stead

    doubted = ("No.3", "No.9")  # prints of colours that weigh as much
    looked: list[str] = []

    def look(job, meant, others, **_):
        looked.append(meant)
        own = dict.fromkeys(others, shown_own)
        fits = {n: ColourFit(0.1, 1.0) for n in others}
        return HeldColours(9000, 0.95 if meant == "No.6" else 0.06, own, ColourFit(0.9, 1.0), fits), "here"

    monkeypatch.setattr(table_lost, "look_at_held", look)
    job = scale_job({"No.6": 0.0208, "No.17": 0.0240, "No.3": 0.022, "No.9": 0.021}, ("No.6", "No.17"))
    job.ledger = TableLedger()
    job.recognizers = dict.fromkeys(job.weights)
    job.untried = lambda name: job.ledger.untried(name, 4)

    def booked_unsure() -> None:
        job.ledger.placed_order.clear()
        job.ledger.placed("No.6", confirmed=True)
        job.ledger.placed_unsure = {"No.6": ("No.17",)}

    def lift(weighed: float) -> AttemptState:
        attempt = AttemptState(None, WHITES, np.eye(4), 0.0, lost_name="No.17", weighed=weighed)
        return attempt

    shown_own = 0.0
    booked_unsure()
    assert booked_in_stead(job, lift(0.0222), doubted) == "No.6"  # type: ignore[arg-type]
    assert _the_earlier_lift(job, "No.6", "No.17") == "No.17"  # type: ignore[arg-type]
    job.ledger.swap_placed("No.6", "No.17", "lifted blind again")
    assert job.ledger.placed_order == ["No.17"] and "No.6" not in job.ledger.placed_unsure
    assert job.ledger.records["No.17"]["confirmed"]  # the box check saw that lift go in
    # the reading is not No.6's: no look, nothing swapped
    booked_unsure()
    looked.clear()
    assert booked_in_stead(job, lift(0.0420), doubted) == "" and not looked  # type: ignore[arg-type]
    # what hangs shows a cloth of another box's own colours: not taken for No.6
    shown_own = 0.3
    assert booked_in_stead(job, lift(0.0222), doubted) == "" and looked == ["No.6"]  # type: ignore[arg-type]
    shown_own = 0.0
    # No.6's lift was sure (its region fit no other cloth), or that other is placed since
    job.ledger.placed_unsure = {}
    assert booked_in_stead(job, lift(0.0222), doubted) == ""  # type: ignore[arg-type]
    job.ledger.placed_unsure = {"No.6": ("No.17",)}
    job.ledger.placed("No.17", confirmed=False)
    assert booked_in_stead(job, lift(0.0222), doubted) == ""  # type: ignore[arg-type]
    # a cloth of another box booked unsure is never this box's lift
    booked_unsure()
    colours = BoxPlace("colours", np.array([0.3, -0.56, 0.0]), 0.22)
    attempt = AttemptState(None, colours, np.eye(4), 0.0, lost_name="No.3", weighed=0.0222)
    assert booked_in_stead(job, attempt, ("No.17",)) == ""  # type: ignore[arg-type]
    # held-out 1664 (session 47): a cloth of the box not placed, its attempts spent, is looked
    # for too (one with attempts left gets them); it is never the cloth the lift was meant for
    job.ledger = TableLedger()
    job.ledger.records["No.6"] = {"attempts": 4, "sim_time": 0.0, "notes": []}
    looked.clear()
    assert booked_in_stead(job, lift(0.0222), doubted) == "No.6" and looked == ["No.6"]  # type: ignore[arg-type]
    job.ledger.records["No.6"]["attempts"] = 3
    assert booked_in_stead(job, lift(0.0222), doubted) == ""  # type: ignore[arg-type]
    job.ledger.records["No.6"]["attempts"] = 4
    meant_no6 = AttemptState(None, WHITES, np.eye(4), 0.0, lost_name="No.6", weighed=0.0222)
    assert booked_in_stead(job, meant_no6, doubted) == ""  # type: ignore[arg-type]
