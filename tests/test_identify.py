"""Identification among many models: the best model per cloth region, who lies on whom,
what no model explains. Synthetic pairs (numpy renderer) with recognitions set by hand at
the true poses, so the test is of the comparison, not of the search."""

from __future__ import annotations

import numpy as np
import pytest

from robot_app.geometry import make_transform, rotation_about_z
from robot_app.vision import ModelCamera, PinholeCamera, Recognition, Recognizer, StereoRig, make_model
from robot_app.vision.identify import Detection, IdentifySettings, _upper, resolve, without
from robot_app.vision.regions import (
    explained,
    footprint,
    image_codes,
    lab_image,
    outline_contrast,
    sheet_mask,
)
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


def test_a_detection_taken_out_leaves_its_pixels_unknown(scene) -> None:
    # the job takes out a candidate its loop could not confirm (a crumpled cloth), to pick it
    # blind by the colours of the region it leaves
    recognizers, right = scene
    recognitions = {"yellow": _recognition(BOTTOM, 0.95), "stripes": _recognition(TOP, 0.9)}
    ident = resolve(recognizers, recognitions, right, IdentifySettings())
    sheet = sheet_mask(right, recognizers["yellow"].model.background_hue, 25, 40)
    rest = without(ident, ["stripes"], sheet)
    assert [d.name for d in rest.detections] == ["yellow"] and rest.above == ()
    u, v = CAMERA.project(TOP[:3, 3][None])[0]
    assert not any(region.mask[round(v), round(u)] for region in ident.unknown)
    assert any(region.mask[round(v), round(u)] for region in rest.unknown)  # the stripes' pixels
    a, b = CAMERA.project(APART[:3, 3][None])[0]
    assert any(region.mask[round(b), round(a)] for region in rest.unknown)  # the ellipse still
    yellow = ident.detections[0]
    assert not any(np.any(region.mask & yellow.explained) for region in rest.unknown)


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


def _two_rectangles(upper_bgr: tuple[int, int, int]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A white cloth with red dots (rows 20-100, columns 20-100) under a cloth of `upper_bgr`
    with a faint print (rows 40-110, columns 60-140), on green: image, lower and upper masks."""
    rng = np.random.default_rng(2)
    image = np.zeros((120, 160, 3), np.uint8)
    image[:] = (40, 150, 40)
    lower = np.zeros((120, 160), bool)
    lower[20:100, 20:100] = True
    upper = np.zeros_like(lower)
    upper[40:110, 60:140] = True
    image[lower] = (235, 235, 235)
    v, u = np.indices(lower.shape)
    for cu, cv in rng.uniform(25, 95, (8, 2)):
        image[lower & ((u - cu) ** 2 + (v - cv) ** 2 < 25)] = (40, 40, 200)
    image[upper] = np.clip(np.asarray(upper_bgr) + rng.normal(0, 6, (int(upper.sum()), 3)), 0, 255)
    return image, lower, upper


def _detection(name: str, where: np.ndarray, explained_pixels: np.ndarray, z: float) -> Detection:
    pose = make_transform(np.eye(3), [0.0, 0.0, z])
    return Detection(name, _recognition(pose, 0.9), where, explained_pixels)


def test_the_cloth_whose_outline_shows_lies_on_top_though_the_other_explains_more() -> None:
    # bench episode 668: a grey print lay on a white cloth with a print; the white ground
    # agreed with the grey, so the lower cloth explained more of the overlap than the
    # upper one (whose pose was a little off) and was picked from under it
    image, lower, upper = _two_rectangles((185, 180, 190))
    half = upper & (np.random.default_rng(3).random(upper.shape) < 0.5)
    white, grey = _detection("white", lower, lower, 0.57), _detection("grey", upper, half, 0.58)
    lab = lab_image(image)
    # the grey cloth's edge over the white one is an edge in the image; the white one's
    # edge under the grey one is not
    assert outline_contrast(lab, upper, lower, 3.0, 4, 25) > 2 * outline_contrast(
        lab, lower, upper, 3.0, 4, 25
    )
    assert _upper(white, grey, lab, IdentifySettings()) == ("grey", "white")
    assert _upper(grey, white, lab, IdentifySettings()) == ("grey", "white")
    # by the explained pixels alone, the white cloth would lie on top
    assert _upper(white, grey, lab, IdentifySettings(edge_ratio=None)) == ("white", "grey")


def test_where_no_edge_shows_the_explained_pixels_decide() -> None:
    # a white cloth on a white cloth: neither outline steps in colour, so the edge cannot
    # tell; the one explaining more of the overlap (then the nearer one) lies on top
    image, lower, upper = _two_rectangles((235, 235, 235))
    image[lower & ~upper] = (235, 235, 235)  # no dots: the same plain white both
    lab = lab_image(image)
    assert not np.isfinite(outline_contrast(lab, upper, lower, 3.0, 4, 10**6))  # too short an edge
    more, less = (
        _detection("a", lower, lower, 0.58),
        _detection("b", upper, upper & lower & (np.indices(lower.shape)[0] < 60), 0.57),
    )
    assert _upper(less, more, lab, IdentifySettings()) == ("a", "b")
