"""Identification among many models: the best model per cloth region, who lies on whom,
what no model explains. Synthetic pairs (numpy renderer) with recognitions set by hand at
the true poses, so the test is of the comparison, not of the search."""

from __future__ import annotations

import numpy as np
import pytest

from robot_app.geometry import make_transform, rotation_about_z
from robot_app.vision import ModelCamera, PinholeCamera, Recognition, Recognizer, StereoRig, make_model
from robot_app.vision.identify import IdentifySettings, resolve
from robot_app.vision.regions import explained, footprint, image_codes, sheet_mask
from robot_app.vision.synthetic import render_model_photo, render_stereo_pair
from robot_app.vision.synthetic_catalogue import synthetic_cloth

CAMERA = PinholeCamera.from_fov((320, 240), np.deg2rad(48))
RIG = StereoRig(CAMERA, CAMERA, make_transform(np.eye(3), [-0.1, 0.0, 0.0]))
STATION = ModelCamera(PinholeCamera.from_fov((480, 360), np.deg2rad(48)), 0.40)
# the stripes (index 2) lie partly on the yellow square (1); the cyan ellipse's cousin, a
# violet ellipse (9), lies apart and has no model: an unknown cloth
BOTTOM = make_transform(rotation_about_z(0.3), [-0.06, -0.02, 0.585])
TOP = make_transform(rotation_about_z(-0.2), [0.04, 0.0, 0.57])
APART = make_transform(rotation_about_z(0.1), [-0.17, 0.125, 0.585])


def _recognizer(index: int) -> Recognizer:
    photo, background = render_model_photo(synthetic_cloth(index), STATION, rng=np.random.default_rng(index))
    return Recognizer(make_model(photo, STATION, background, name=f"S{index}"), RIG)


@pytest.fixture(scope="module")
def scene() -> tuple[dict[str, Recognizer], np.ndarray]:
    _, right = render_stereo_pair(
        RIG,
        [(synthetic_cloth(1), BOTTOM), (synthetic_cloth(2), TOP), (synthetic_cloth(9), APART)],
        rng=np.random.default_rng(5),
    )
    return {name: _recognizer(index) for name, index in (("yellow", 1), ("stripes", 2), ("red", 0))}, right


def _recognition(pose: np.ndarray, confidence: float) -> Recognition:
    return Recognition(confidence > 0.69, 0.9, pose, 0, 0, 0.0, confidence=confidence, visible_fraction=0.8)


def test_footprint_and_explained_pixels_follow_the_pose(scene) -> None:
    recognizers, right = scene
    model = recognizers["stripes"].model
    area = footprint(model, CAMERA, TOP)
    codes = image_codes(right, np.ones(3), recognizers["stripes"].settings.fitness)
    inside, agree = explained(model, CAMERA, TOP, codes, recognizers["stripes"].settings.fitness)
    np.testing.assert_array_equal(area, inside)
    # the cloth covers about its area in pixels: 0.25 x 0.20 m at 0.57 m
    focal = CAMERA.camera_matrix[0, 0]
    expected = 0.25 * 0.20 * (focal / 0.57) ** 2
    assert 0.8 * expected < area.sum() < 1.1 * expected
    assert agree.sum() > 0.65 * area.sum()  # the stripes lie on top: most of it agrees (edges mix)
    moved = make_transform(np.eye(3), [0.12, -0.06, 0.57])
    _, away = explained(model, CAMERA, moved, codes, recognizers["stripes"].settings.fitness)
    assert away.sum() < 0.5 * agree.sum()


def test_best_model_per_region_and_who_lies_on_whom(scene) -> None:
    recognizers, right = scene
    recognitions = {
        "yellow": _recognition(BOTTOM, 0.95),
        "stripes": _recognition(TOP, 0.9),
        # the plain red model fitted onto the stripes' red: a look-alike, less confident
        "red": _recognition(make_transform(rotation_about_z(-0.2), [0.045, 0.002, 0.57]), 0.5),
    }
    ident = resolve(recognizers, recognitions, right, IdentifySettings())
    assert [d.name for d in ident.detections] == ["yellow", "stripes"]
    assert ident.dropped == (("red", "stripes"),)
    assert ident.above == (("stripes", "yellow"),)
    assert [d.name for d in ident.free()] == ["stripes"]
    assert ident.preferred().name == "stripes"
    # the violet ellipse has no model: it is foreground that no detection covers
    assert len(ident.unknown) == 1
    u, v = CAMERA.project(APART[:3, 3][None])[0]
    assert ident.unknown[0].mask[round(v), round(u)]


def test_a_look_alike_more_confident_than_the_cloth(scene) -> None:
    # the plain red model explains only the red half of the stripes: the stripes are not
    # dropped, they explain the shared pixels and more, so they lie "on" the look-alike
    # and are picked first (after which the look-alike has nothing left to stand on)
    recognizers, right = scene
    recognitions = {
        "stripes": _recognition(TOP, 0.6),
        "red": _recognition(make_transform(rotation_about_z(-0.2), [0.045, 0.002, 0.57]), 0.7),
    }
    ident = resolve({k: recognizers[k] for k in recognitions}, recognitions, right, IdentifySettings())
    assert [d.name for d in ident.detections] == ["red", "stripes"]
    assert ident.above == (("stripes", "red"),)
    assert ident.preferred().name == "stripes"


def test_a_cloth_without_model_lying_on_a_detection_makes_it_not_free(scene) -> None:
    recognizers, _ = scene
    on_top = make_transform(rotation_about_z(0.4), [0.13, 0.06, 0.56])
    _, right = render_stereo_pair(
        RIG,
        [(synthetic_cloth(1), BOTTOM), (synthetic_cloth(2), TOP), (synthetic_cloth(9), on_top)],
        rng=np.random.default_rng(6),
    )
    recognitions = {"yellow": _recognition(BOTTOM, 0.95), "stripes": _recognition(TOP, 0.9)}
    ident = resolve({k: recognizers[k] for k in recognitions}, recognitions, right, IdentifySettings())
    assert [d.name for d in ident.detections] == ["yellow", "stripes"]
    assert ident.covered == ("stripes",)
    assert ident.free() == ()  # the yellow square lies under the stripes, the stripes under the ellipse
    u, v = CAMERA.project(on_top[:3, 3][None])[0]
    assert any(region.mask[round(v), round(u)] for region in ident.unknown)


def test_below_the_candidate_confidence_nothing_is_detected(scene) -> None:
    recognizers, right = scene
    recognitions = {"yellow": _recognition(BOTTOM, 0.05), "stripes": _recognition(TOP, 0.1)}
    ident = resolve({k: recognizers[k] for k in recognitions}, recognitions, right, IdentifySettings())
    assert ident.detections == () and ident.preferred() is None
    stripes = footprint(recognizers["stripes"].model, CAMERA, TOP)
    assert sum(u.area for u in ident.unknown) > 1.5 * stripes.sum()  # all three are unexplained


def test_the_sheet_is_not_foreground(scene) -> None:
    recognizers, right = scene
    sheet = sheet_mask(right, recognizers["yellow"].model.background_hue, 25, 40)
    assert 0.5 < sheet.mean() < 0.95
    u, v = CAMERA.project(TOP[:3, 3][None])[0]
    assert not sheet[round(v), round(u)]
