"""Identification's second search (`identify.search_again`): a model whose search ended on a
cloth already identified is searched again with that cloth painted over.

Two plain white cloths: the larger one lies partly on the smaller. The smaller one's search
ends on the larger one (in 2 of 3 seeds, with confidence 0.999: a white 18 x 16 cm patch
fits anywhere on a white 26 x 20 cm cloth); with the larger one painted over it ends on
its own cloth. Synthetic pairs (numpy renderer), real recognisers.
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from robot_app.geometry import make_transform, rotation_about_z
from robot_app.vision import ModelCamera, PinholeCamera, Recognizer, StereoRig, make_model
from robot_app.vision.hue import colour_codes, colours_match, to_hsv
from robot_app.vision.identify import IdentifySettings, identify
from robot_app.vision.regions import explained, image_codes
from robot_app.vision.search_again import PAINTS, Identified, _to_raw, foreign_paint, search_again
from robot_app.vision.synthetic import SyntheticCloth, render_model_photo, render_stereo_pair
from robot_app.vision.synthetic_catalogue import CATALOGUE_SIZE, CLOTH_TEXEL, synthetic_cloth

CAMERA = PinholeCamera.from_fov((320, 240), np.deg2rad(48))
RIG = StereoRig(CAMERA, CAMERA, make_transform(np.eye(3), [-0.1, 0.0, 0.0]))
STATION = ModelCamera(PinholeCamera.from_fov((480, 360), np.deg2rad(48)), 0.40)
LARGE_POSE = make_transform(rotation_about_z(0.2), [0.03, 0.0, 0.57])
SMALL_POSE = make_transform(rotation_about_z(-0.4), [-0.12, 0.03, 0.585])
COVERED_BOUND = 0.006  # [m] issue 15's x/y bound for a partly covered cloth


def _plain(name: str, size: tuple[float, float], bgr: tuple[int, int, int], seed: int) -> SyntheticCloth:
    rng = np.random.default_rng(seed)
    shape = (round(size[1] / CLOTH_TEXEL), round(size[0] / CLOTH_TEXEL))
    texture = np.clip(np.asarray(bgr, float) + rng.normal(0, 6, (*shape, 1)), 0, 255).astype(np.uint8)
    return SyntheticCloth(name, texture, np.ones(shape, bool), size)


def _recognizer(cloth: SyntheticCloth, seed: int) -> Recognizer:
    photo, background = render_model_photo(cloth, STATION, rng=np.random.default_rng(seed))
    return Recognizer(make_model(photo, STATION, background, name=cloth.name), RIG)


@pytest.fixture(scope="module")
def whites() -> tuple[dict[str, Recognizer], np.ndarray, np.ndarray]:
    large = _plain("large", (0.26, 0.20), (225, 225, 225), 1)
    small = _plain("small", (0.18, 0.16), (225, 225, 225), 2)
    left, right = render_stereo_pair(
        RIG, [(small, SMALL_POSE), (large, LARGE_POSE)], rng=np.random.default_rng(3)
    )
    return {"large": _recognizer(large, 1), "small": _recognizer(small, 2)}, left, right


def test_a_cloth_painted_over_no_longer_holds_the_search(whites) -> None:
    recognizers, left, right = whites
    large = recognizers["large"]
    codes = image_codes(right, np.ones(3), large.settings.fitness)
    _, pixels = explained(large.model, CAMERA, LARGE_POSE, codes, large.settings.fitness)
    for seed in range(3):
        found = search_again(
            {"small": recognizers["small"]},
            [Identified(large.model, LARGE_POSE, pixels)],
            left,
            right,
            seed=seed,
        )["small"]
        error = np.linalg.norm(found.transform_model_to_camera[:2, 3] - SMALL_POSE[:2, 3])
        assert error < 0.005, f"seed {seed}: {error * 1000:.1f} mm from the small cloth"
        assert found.found


def test_identify_searches_again_and_keeps_both_cloths(whites) -> None:
    """Over seeds (whether a first search ends on the larger cloth depends on the GA's run,
    and so on the machine's arithmetic: seed 0 did on session 27's machine, not on session
    28's), every identification keeps both cloths where they are, and the seeds whose first
    search ended on the larger one searched the smaller one again; at least one did. "Where
    they are": within issue 15's bound for a covered cloth (6 mm; the smaller one lies partly
    under a cloth of its own white, and its first search with seed 5 ends 5.7 mm off on
    session 36's machine, 0.4-2.6 mm with seeds 0-4 and 6-11); taken for the other cloth, it
    would be some 15 cm off."""
    recognizers, left, right = whites
    again = 0
    for seed in range(6):
        ident = identify(recognizers, left, right, IdentifySettings(search_again=True), seed=seed)
        names = {d.name: d for d in ident.detections}
        assert set(names) == {"large", "small"}, f"seed {seed}"
        assert ident.searched_again in ((), ("small",)), f"seed {seed}"
        again += ident.searched_again == ("small",)
        for name, truth in (("large", LARGE_POSE), ("small", SMALL_POSE)):
            error = np.linalg.norm(names[name].transform_model_to_camera[:2, 3] - truth[:2, 3])
            assert error < COVERED_BOUND, f"seed {seed}, {name}: {error * 1000:.1f} mm off"
    assert again >= 1, "no seed needed the second search: the scene no longer tests it"


def test_nothing_searched_again_when_every_model_is_kept(whites) -> None:
    recognizers, left, right = whites
    only_large = {"large": recognizers["large"]}
    ident = identify(only_large, left, right, IdentifySettings(search_again=True), seed=0)
    assert [d.name for d in ident.detections] == ["large"]
    assert ident.searched_again == ()


def test_the_paint_is_foreign_to_every_model() -> None:
    for index in range(CATALOGUE_SIZE):
        recognizer = _recognizer(synthetic_cloth(index), index)
        paint = foreign_paint(recognizer)
        assert paint is not None and paint in PAINTS
        f = recognizer.settings.fitness
        code = colour_codes(
            to_hsv(np.asarray([[paint]], np.uint8)), f.min_saturation, f.min_value, f.value_split
        )
        own = np.unique(np.asarray(recognizer.model.hues_in))
        assert not np.any(colours_match(np.full(own.shape, code[0, 0]), own, f.hue_threshold_in)), index


def test_a_mask_of_the_ideal_image_lands_where_the_lens_puts_it() -> None:
    lens = PinholeCamera(CAMERA.camera_matrix, (320, 240), dist_coeffs=np.array([-0.25, 0.08, 0.0, 0.0, 0.0]))
    ideal = np.zeros((240, 320), bool)
    ideal[20:70, 15:90] = True  # near a corner, where the lens moves pixels most
    raw = _to_raw(ideal, lens)
    K = lens.camera_matrix
    back = cv2.undistort(raw.astype(np.uint8) * 255, K, lens.dist_coeffs, None, K) > 127
    assert np.count_nonzero(back ^ ideal) < 0.05 * np.count_nonzero(ideal)
    assert np.count_nonzero(raw ^ ideal) > 0.2 * np.count_nonzero(ideal)  # the lens did move it
    np.testing.assert_array_equal(_to_raw(ideal, CAMERA), ideal)  # no lens, no change
