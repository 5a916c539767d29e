"""The box's rim in the check's look: read where the walls' tops lie in the images, and a
run of it changed between two looks (a cloth over the wall), whatever the exposure did."""

from __future__ import annotations

import numpy as np
import pytest

from robot_app.arrays import FloatArray
from robot_app.config import load_config
from robot_app.control.box_check import (
    WALL_NORMALS,
    BoxCheckSettings,
    RimView,
    rim_covered,
    rim_points,
    rim_runs,
    rim_view,
)
from robot_app.control.box_rim import lay_again_point, over_wall_note
from robot_app.experiments.clear_table import ClearTableConfig
from robot_app.geometry import invert_transform, make_transform
from robot_app.vision.camera import PinholeCamera, StereoRig
from tests.table_scene import Capture

CAMERA = PinholeCamera.from_fov((320, 240), np.deg2rad(48.0))  # the cell's hand camera
RIG = StereoRig(CAMERA, CAMERA, make_transform(np.eye(3), [-0.1, 0.0, 0.0]))
DOWN = np.column_stack([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])  # camera looking down
WALL_BGR, CLOTH_BGR = (60, 140, 220), (200, 90, 40)
OVER = "a cloth over the +y wall of colours"  # the check's note


def _box() -> tuple[FloatArray, float, float, float]:
    """The clear-table cell's colours box: floor centre [m], inner side, wall height and thickness."""
    world = load_config(ClearTableConfig, "configs/clear_table.yaml").world
    box = world.all_boxes[0]
    return np.array([*box.centre_xy, world.table.top_z]), box.inner_size, box.wall_height, box.wall_thickness


def _paint(camera_height: float, gain: float, cloth: tuple[int, slice] | None) -> Capture:
    """Both images of a look from `camera_height` over the box floor: grey, the rim's
    points painted the wall's colour times `gain` (exposure), `cloth` = (wall, points) of
    it painted a cloth's colour instead."""
    centre, inner, height, thickness = _box()
    pose = make_transform(DOWN, centre + np.array([0.0, 0.0, camera_height]))
    points = rim_points(centre, inner, height, thickness, BoxCheckSettings().rim_samples)
    colours = np.empty(points.shape)
    colours[:] = WALL_BGR
    if cloth is not None:
        colours[cloth[0], cloth[1]] = CLOTH_BGR
    images = []
    for to_camera in (
        invert_transform(pose),
        invert_transform(RIG.transform_left_to_right) @ invert_transform(pose),
    ):
        image = np.full((240, 320, 3), 128.0)
        local = points.reshape(-1, 3) @ to_camera[:3, :3].T + to_camera[:3, 3]
        for (u, v), bgr in zip(CAMERA.project(local), colours.reshape(-1, 3), strict=True):
            if 0 <= u < 320 and 0 <= v < 240:
                image[max(0, int(v) - 2) : int(v) + 3, max(0, int(u) - 2) : int(u) + 3] = bgr
        images.append(np.clip(image * gain, 0, 255).astype(np.uint8))
    return Capture(images[0], images[1], pose)


def _rim(capture: Capture) -> RimView:
    centre, inner, height, thickness = _box()
    return rim_view(capture, RIG, centre, inner, height, thickness, BoxCheckSettings())


def test_rim_points_lie_on_the_middle_of_each_walls_top() -> None:
    centre, inner, height, thickness = _box()
    points = rim_points(centre, inner, height, thickness, 11)
    for wall, normal in enumerate(WALL_NORMALS):
        out = (points[wall, :, :2] - centre[:2]) @ normal
        np.testing.assert_allclose(out, inner / 2 + thickness / 2)
        np.testing.assert_allclose(points[wall, :, 2], centre[2] + height)
        along = (points[wall, :, :2] - centre[:2]) @ normal[::-1]
        assert along.min() == pytest.approx(-(inner / 2 + thickness / 2))


def test_the_checks_look_sees_every_walls_rim_the_old_one_did_not() -> None:
    height = ClearTableConfig().clear.box_view_height
    assert _rim(_paint(height, 1.0, None)).seen[0].all()
    assert not _rim(_paint(0.42, 1.0, None)).seen[0].all()  # the look before session 43


def test_a_brighter_look_alone_covers_no_rim() -> None:
    height = ClearTableConfig().clear.box_view_height
    before, after = _rim(_paint(height, 1.0, None)), _rim(_paint(height, 1.3, None))
    np.testing.assert_allclose(after.bgr[0, 0, 0], np.minimum(np.array(WALL_BGR) * 1.3, 255), atol=1.0)
    assert rim_covered(before, after, BoxCheckSettings()).max() == 0.0


def test_a_cloth_over_a_wall_is_the_run_of_its_rim_that_changed() -> None:
    height, settings = ClearTableConfig().clear.box_view_height, BoxCheckSettings()
    before = _rim(_paint(height, 1.0, None))
    after = _rim(_paint(height, 0.8, (2, slice(10, 22))))
    covered = rim_covered(before, after, settings)
    assert covered[2] == pytest.approx(12 * after.spacing)
    assert covered[[0, 1, 3]].max() == 0.0
    assert covered[2] >= settings.rim_run
    assert over_wall_note(covered, "colours").startswith(OVER + " (")
    short = rim_covered(before, _rim(_paint(height, 1.0, (0, slice(3, 5)))), settings)
    assert 0.0 < short[0] < settings.rim_run  # a corner touching it: not over the wall


def test_the_run_says_where_along_its_wall_the_cloth_crosses() -> None:
    height, settings = ClearTableConfig().clear.box_view_height, BoxCheckSettings()
    centre, inner, wall_height, thickness = _box()
    points = rim_points(centre, inner, wall_height, thickness, settings.rim_samples)
    before = _rim(_paint(height, 1.0, None))
    for wall, run in ((2, slice(4, 12)), (1, slice(25, 37))):
        lengths, middles = rim_runs(before, _rim(_paint(height, 0.9, (wall, run))), settings)
        crossing = points[wall, run, :2].mean(axis=0) - centre[:2]  # the painted run's middle, Σ_W
        tangent = np.abs(WALL_NORMALS[wall][::-1])
        assert middles[wall] == pytest.approx(crossing @ tangent, abs=1e-9)
        assert lengths[wall] == pytest.approx((run.stop - run.start) * before.spacing)
        others = [k for k in range(4) if k != wall]
        assert lengths[others].max() == 0.0 and middles[others].max() == 0.0


def test_laying_again_takes_the_cloth_inside_the_wall_where_it_crosses() -> None:
    centre, inner = np.array([0.3, -0.56, 0.72]), 0.22
    np.testing.assert_array_equal(lay_again_point(centre, inner, 2, 0.05, None), centre)  # the middle
    at = lay_again_point(centre, inner, 2, 0.02, 0.07)  # +y wall, 2 cm towards +x
    np.testing.assert_allclose(at, centre + np.array([0.02, 0.04, 0.0]))
    at = lay_again_point(centre, inner, 1, -0.09, 0.07)  # -x wall, near its -y corner
    np.testing.assert_allclose(at, centre + np.array([-0.04, -0.04, 0.0]))  # kept the inset off both walls
    for wall in range(4):
        for along in (-0.2, 0.0, 0.2):
            off = lay_again_point(centre, inner, wall, along, 0.07)[:2] - centre[:2]
            assert np.abs(off).max() <= inner / 2 - 0.07 + 1e-12


def test_no_reference_look_in_view_covers_nothing() -> None:
    height = ClearTableConfig().clear.box_view_height
    unseen = RimView(np.zeros((2, 4, 40, 3)), np.zeros((2, 4, 40), bool), 0.006)
    after = _rim(_paint(height, 1.0, (1, slice(0, 40))))
    assert rim_covered(unseen, after, BoxCheckSettings()).max() == 0.0


def _rim_job(monkeypatch: pytest.MonkeyPatch, looks: list[float], tries: int, reach: bool = True):
    """A job whose check sees a cloth over the +y wall `looks[k]` [m] of rim at its k-th look
    (the reference look first), and whose laying again reaches (`reach`) or not."""
    from types import SimpleNamespace

    from robot_app.control import table_clearer
    from robot_app.control.clear_table_records import BoxPlace, ClearTableSettings

    centre, inner, height, thickness = _box()
    box = BoxPlace("colours", centre, inner, height, thickness)
    seen = iter(looks)
    laid: list[tuple[int, float, float | None]] = []

    def rim_of(*args: object) -> RimView:
        run = round(next(seen) / 0.01)
        bgr = np.zeros((2, 4, 40, 3))
        bgr[:, 2, :run] = 200.0
        return RimView(bgr, np.ones((2, 4, 40), bool), 0.01)

    def again(job: object, attempt: object, wall: int, capture: object, along: float, inset: float) -> object:
        laid.append((wall, along, inset))
        return object() if reach else None

    monkeypatch.setattr(table_clearer, "rim_view", rim_of)
    monkeypatch.setattr(table_clearer, "lay_again", again)
    monkeypatch.setattr(table_clearer, "box_view", lambda *args: SimpleNamespace(in_view=np.zeros(1)))
    job = table_clearer.TableClearer.__new__(table_clearer.TableClearer)
    job.settings = ClearTableSettings(rim_tries=tries, box_heap=False, rim_grasp_inset=0.07)
    job.box_settings, job.rig = BoxCheckSettings(), None  # type: ignore[assignment]
    job._rims = {"colours": job._rim_view(box, None)}  # type: ignore[arg-type]
    attempt = SimpleNamespace(box=box, notes=[])
    return job, attempt, laid


def test_a_cloth_seen_over_a_wall_is_laid_again_until_the_rim_is_clear(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    job, attempt, laid = _rim_job(monkeypatch, [0.0, 0.12, 0.0], tries=1)
    job._check_rim(attempt, None)
    assert laid == [(2, pytest.approx((5.5 - 19.5) * 0.01), None)]  # the +y wall, from the middle
    assert attempt.notes == [
        OVER + " (12 cm of its rim): laid again",
        "laid again 1 time(s): the rim is clear",
    ]
    assert job._rims["colours"].bgr[0, 2].max() == 0.0  # the clear look is the next reference


def test_a_rim_touched_less_than_the_run_is_left_alone(monkeypatch: pytest.MonkeyPatch) -> None:
    job, attempt, laid = _rim_job(monkeypatch, [0.0, 0.02], tries=1)
    job._check_rim(attempt, None)
    assert laid == [] and attempt.notes == []


def test_laying_again_stops_after_its_tries_or_when_it_cannot(monkeypatch: pytest.MonkeyPatch) -> None:
    job, attempt, laid = _rim_job(monkeypatch, [0.0, 0.12, 0.10], tries=1)
    job._check_rim(attempt, None)
    assert [wall for wall, *_ in laid] == [2] and attempt.notes[-1] == OVER + " (10 cm of its rim): left so"
    assert job._rims["colours"].bgr[0, 2, :10].min() == 200.0  # left over the wall: not blamed on the next
    job, attempt, laid = _rim_job(monkeypatch, [0.0, 0.12], tries=0)
    job._check_rim(attempt, None)
    assert laid == [] and attempt.notes == [OVER + " (12 cm of its rim): not laid again (clear.rim_tries 0)"]
    job, attempt, laid = _rim_job(monkeypatch, [0.0, 0.12, 0.10, 0.02], tries=2)
    job._check_rim(attempt, None)  # the second try takes it inside the wall where it crosses
    assert laid == [(2, pytest.approx(-0.14), None), (2, pytest.approx(-0.15), 0.07)]
    assert attempt.notes[-1] == "laid again 2 time(s): the rim is clear"
    job, attempt, laid = _rim_job(monkeypatch, [0.0, 0.12], tries=2, reach=False)
    job._check_rim(attempt, None)
    assert [wall for wall, *_ in laid] == [2] and attempt.notes == [OVER + " (12 cm of its rim): laid again"]
