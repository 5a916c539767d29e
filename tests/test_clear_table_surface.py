"""The top surface at a grasp point, by the survey's stereo pair (`control.table_surface`):
synthetic pairs (numpy renderer) of two cloths, one lying on the other, at known heights."""

from __future__ import annotations

from types import SimpleNamespace

import cv2
import numpy as np
import pytest

from robot_app.control.clear_table_records import BoxPlace, ClearTableSettings
from robot_app.control.loop_settings import LoopSettings
from robot_app.control.table_furniture import clear_of_walls
from robot_app.control.table_lost import LostMatch, _blind_grasp_height, _heap_top, inner_pixel
from robot_app.control.table_surface import SurfaceSettings, aimed_at, surface_height
from robot_app.geometry import make_transform, rotation_about_z
from robot_app.vision import Recognition
from robot_app.vision.identify import IdentifySettings, resolve
from robot_app.vision.synthetic import render_stereo_pair
from robot_app.vision.synthetic_catalogue import synthetic_cloth
from tests.table_scene import CAMERA, RIG, recognizer

# the right camera 0.6 m above the table (z = 0), looking straight down
CAMERA_TO_WORLD = make_transform(np.diag([1.0, -1.0, -1.0]), [0.5, 0.0, 0.6])
LOWER = make_transform(rotation_about_z(0.2), [-0.03, 0.0, 0.592])  # 8 mm above the table
UPPER = make_transform(rotation_about_z(-0.4), [0.05, 0.02, 0.548])  # 52 mm: three layers up
PLAIN = make_transform(rotation_about_z(0.1), [-0.1, -0.12, 0.592])  # a plain yellow cloth apart


@pytest.fixture(scope="module")
def pile():
    left, right = render_stereo_pair(
        RIG,
        [(synthetic_cloth(2), LOWER), (synthetic_cloth(10), UPPER), (synthetic_cloth(1), PLAIN)],
        rng=np.random.default_rng(3),
    )
    recognizers = {
        "lower": recognizer(2, "lower"),
        "upper": recognizer(10, "upper"),
        "plain": recognizer(1, "plain"),
    }
    seen = {
        name: Recognition(True, 0.9, pose, 0, 0, 0.0, confidence=0.95, visible_fraction=1.0)
        for name, pose in (("lower", LOWER), ("upper", UPPER), ("plain", PLAIN))
    }
    ident = resolve(recognizers, seen, right, IdentifySettings())
    capture = SimpleNamespace(left_bgr=left, right_bgr=right, transform_right_camera_to_world=CAMERA_TO_WORLD)
    return recognizers, {d.name: d for d in ident.detections}, capture


def _world(pose_in_camera: np.ndarray, xy_model: tuple[float, float]) -> np.ndarray:
    return (CAMERA_TO_WORLD @ pose_in_camera @ np.array([*xy_model, 0.0, 1.0]))[:3]


@pytest.mark.parametrize(("name", "pose", "xy", "height"), [("upper", UPPER, (0.0, 0.0), 0.052)])
def test_the_surface_on_top_of_a_pile_is_the_top_cloths(pile, name, pose, xy, height) -> None:
    recognizers, detections, capture = pile
    point = _world(pose, xy)
    assert point[2] == pytest.approx(height, abs=1e-6)
    point[2] = 0.03  # a pose's plane that lies 22 mm low, as on bench episode 32
    r = recognizers[name]
    found = surface_height(
        capture, RIG, r.model, r.settings.depth, detections[name].explained, point, 0.0, SurfaceSettings()
    )
    assert found.trusted
    assert found.z == pytest.approx(height, abs=0.003)


def test_the_lower_cloth_beside_the_top_one_is_measured_at_its_own_height(pile) -> None:
    recognizers, detections, capture = pile
    lower = detections["lower"]
    visible_far = None
    # a point of the lower cloth well away from the upper one
    for x in np.linspace(-0.1, 0.0, 11):
        point = _world(LOWER, (x, 0.0))
        u, v = CAMERA.project((np.linalg.inv(CAMERA_TO_WORLD) @ np.append(point, 1.0))[None, :3])[0]
        if lower.explained[round(v), round(u)]:
            visible_far = point
            break
    assert visible_far is not None
    r = recognizers["lower"]
    found = surface_height(
        capture, RIG, r.model, r.settings.depth, lower.explained, visible_far, 0.0, SurfaceSettings()
    )
    assert found.trusted and found.z == pytest.approx(0.008, abs=0.003)


def test_nothing_visible_or_nothing_textured_around_the_point_is_not_measured(pile) -> None:
    recognizers, detections, capture = pile
    # a plain cloth shows the pair nothing to correlate: the job keeps the pose's plane
    r = recognizers["plain"]
    centre = _world(PLAIN, (0.0, 0.0))
    visible = detections["plain"].explained
    plain = surface_height(capture, RIG, r.model, r.settings.depth, visible, centre, 0.0, SurfaceSettings())
    assert not plain.trusted
    r = recognizers["upper"]
    nothing = np.zeros_like(detections["upper"].explained)
    found = surface_height(
        capture, RIG, r.model, r.settings.depth, nothing, [0.5, 0.0, 0.0], 0.0, SurfaceSettings()
    )
    assert not found.trusted and np.isnan(found.z)


def test_aimed_at_moves_the_grasp_point_along_the_cloths_normal_only() -> None:
    pose = make_transform(rotation_about_z(0.7) @ np.diag([1.0, -1.0, -1.0]), [0.5, 0.1, 0.02])
    point = aimed_at(pose, [0.03, -0.02, 0.0], 0.055)
    world = pose[:3, :3] @ point + pose[:3, 3]
    before = pose[:3, :3] @ np.array([0.03, -0.02, 0.0]) + pose[:3, 3]
    assert world[2] == pytest.approx(0.055)
    assert world[:2] == pytest.approx(before[:2])


# ------------------------------------------------------------------ a blind grasp into a heap
def _blind_job(pile, misses: int = 0):
    recognizers, _, capture = pile
    ledger = SimpleNamespace(misses=lambda name: misses)
    return SimpleNamespace(
        settings=ClearTableSettings(), loop_settings=LoopSettings(), table_z=0.0, rig=RIG,
        recognizers=recognizers, survey_capture=capture, ledger=ledger,
        motion=SimpleNamespace(hold=lambda seconds: None), boxes={},
    )  # fmt: skip


def test_a_blind_grasp_is_aimed_at_the_top_of_the_heap_where_the_pair_measures_it(pile) -> None:
    _, detections, _ = pile
    region = SimpleNamespace(mask=detections["upper"].explained)  # the top cloth's part of the heap
    point = _world(UPPER, (0.0, 0.0))
    notes: list[str] = []
    z = _blind_grasp_height(_blind_job(pile), LostMatch("upper", region, 0.9), (point[0], point[1]), notes)
    assert z == pytest.approx(0.052 + LoopSettings().grasp_height, abs=0.003)  # 52 mm up, not 25 mm
    assert notes and "surface there at 52 mm" in notes[0]
    # after an empty blind grasp at this cloth, and where nothing is measured: the table's height
    fixed = ClearTableSettings().lost.grasp_height
    missed = _blind_job(pile, misses=1)
    assert _blind_grasp_height(missed, LostMatch("upper", region, 0.9), point[:2], []) == fixed
    plain = SimpleNamespace(mask=detections["plain"].explained)
    centre = _world(PLAIN, (0.0, 0.0))
    assert _blind_grasp_height(_blind_job(pile), LostMatch("plain", plain, 0.9), centre[:2], []) == fixed


def _table_point(capture, pixel) -> tuple[float, float]:
    """Where the ray through a right-image pixel meets the table (z = 0)."""
    ray = np.linalg.inv(CAMERA.camera_matrix) @ np.array([pixel[0], pixel[1], 1.0])
    T = capture.transform_right_camera_to_world
    direction = T[:3, :3] @ ray
    t = -T[2, 3] / direction[2]
    x, y, _ = T[:3, 3] + t * direction
    return float(x), float(y)


def _filled(mask: np.ndarray) -> np.ndarray:
    hull = cv2.convexHull(cv2.findNonZero(mask.astype(np.uint8)))
    filled = np.zeros(mask.shape, np.uint8)
    cv2.fillConvexPoly(filled, hull, 1)
    return filled.astype(bool)


def test_a_blind_grasp_goes_to_the_heaps_top_not_its_innermost_point(pile) -> None:
    _, detections, _ = pile
    # a heap: the lower cloth's region with the upper cloth's near part on it (its far part
    # cut off), the innermost pixel on the lower cloth at 8 mm
    upper = _filled(detections["upper"].explained)
    heap = _filled(detections["lower"].explained) | (upper & (np.arange(upper.shape[1]) < 150)[None, :])
    u, v = inner_pixel(heap)
    assert not upper[round(v), round(u)]
    job = _blind_job(pile)
    job.table = SimpleNamespace(point=_table_point)
    match = LostMatch("upper", SimpleNamespace(mask=heap), 0.9)
    top = _heap_top(job, match, heap, lambda x, y: True)
    assert top is not None
    x, y, z, note = top
    assert z == pytest.approx(0.052 + LoopSettings().grasp_height, abs=0.003)  # on the upper cloth
    assert "at the heap's top" in note
    # the point lies on the upper cloth (within the model's outline at its pose)
    recognizers, _, _ = pile
    footprint = (CAMERA_TO_WORLD @ UPPER)[:3, :3] @ recognizers["upper"].model.points_in.T
    footprint = footprint.T + (CAMERA_TO_WORLD @ UPPER)[:3, 3]
    assert np.min(np.hypot(footprint[:, 0] - x, footprint[:, 1] - y)) < 0.005
    # none of it where the hand cannot reach, after a grasp that closed on nothing, or off
    assert _heap_top(job, match, heap, lambda x, y: False) is None
    missed = _blind_job(pile, misses=1)
    missed.table = job.table
    assert _heap_top(missed, match, heap, lambda x, y: True) is None
    off = _blind_job(pile)
    off.table, off.settings = job.table, ClearTableSettings.model_validate({"lost": {"top_tries": 0}})
    assert _heap_top(off, match, heap, lambda x, y: True) is None
    # a box's wall 3 cm from that top (the hand's clearance is 5 cm): another point or none,
    # clear of the wall where the hand comes down (held-out episodes 776 and 783, session 33)
    box = BoxPlace("colours", np.array([x, y + 0.12 + 0.03, 0.0]), 0.22, 0.1, 0.01)
    job.boxes = {"colours": box}
    walled = _heap_top(job, match, heap, lambda x, y: True)
    clearance = ClearTableSettings().lost.wall_clearance
    assert walled is None or clear_of_walls(walled[:2], [box], clearance)[0]
    assert walled is None or walled[:2] != pytest.approx((x, y))
    # and none where the hand does not reach that top, up the ray from the point measured
    job.boxes = {}
    assert _heap_top(job, match, heap, lambda px, py: np.hypot(px - x, py - y) > 0.004) != top


def test_the_heap_already_in_a_box_is_measured_from_above_it(pile) -> None:
    # held-out 876 (session 35): the release went down into the heap of the cloths placed
    # before and carried two out; the box check's pair measures how high they lie
    from robot_app.control.box_contents import contents_top

    recognizers, _, capture = pile
    model, depth = recognizers["upper"].model, recognizers["upper"].settings.depth
    settings = SurfaceSettings()
    # a box around the upper cloth (52 mm over the table, on the lower one)
    over_pile = BoxPlace("colours", np.array([0.55, -0.02, 0.0]), 0.12, 0.1, 0.01)
    assert contents_top(capture, RIG, over_pile, model, depth, settings) == pytest.approx(0.052, abs=0.004)
    # over the plain cloth alone (8 mm over the table, little texture) and over bare table
    beside = BoxPlace("whites", np.array([0.40, 0.12, 0.0]), 0.06, 0.1, 0.01)
    assert contents_top(capture, RIG, beside, model, depth, settings) < 0.015
    bare = BoxPlace("whites", np.array([0.35, -0.15, 0.0]), 0.05, 0.1, 0.01)
    assert contents_top(capture, RIG, bare, model, depth, settings) < 0.015
