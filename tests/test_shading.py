"""Uneven light: a shadow across the sheet and a white cloth (the arm's, in the cell)."""

from __future__ import annotations

import cv2
import numpy as np

from robot_app.config import load_config
from robot_app.geometry import make_transform, pose_error, rotation_from_rpy
from robot_app.vision.camera import ModelCamera, PinholeCamera, StereoRig
from robot_app.vision.exposure import ExposureSettings, scene_exposure
from robot_app.vision.exposure_kernels import encoded_deviation, hsv_image, sheet_sample
from robot_app.vision.fitness_kernels import bgr_codes, bgr_codes_shaded, every_colour, gain_levels
from robot_app.vision.fitness_scores import OFF_IMAGE
from robot_app.vision.hue import hue_distance, to_hsv
from robot_app.vision.photo_model import make_model
from robot_app.vision.pixel_codes import box_spans, colour_table
from robot_app.vision.recognizer import RecognitionSettings, Recognizer
from robot_app.vision.synthetic import SyntheticCloth, render_model_photo, render_stereo_pair
from robot_app.vision.synthetic_camera import CameraRealism

CAMERA = PinholeCamera.from_fov((640, 480), np.deg2rad(48))
RIG = StereoRig(CAMERA, CAMERA, make_transform(np.eye(3), [-0.1, 0.0, 0.0]))
MODEL_CAMERA = ModelCamera(CAMERA, 0.40)
POSE = make_transform(rotation_from_rpy(0.03, -0.02, 0.7), [0.01, -0.01, 0.58])
SHADOW = 0.45  # the shadow keeps this share of the light


def white_towel() -> SyntheticCloth:
    """A plain white cloth, 0.22 x 0.17 m, with a fabric grain of a few grey levels."""
    rng = np.random.default_rng(3)
    shape = (340, 440)
    grain = rng.normal(0.0, 4.0, (*shape, 1))
    texture = np.clip(np.array([228.0, 232.0, 235.0]) + grain, 0, 255).astype(np.uint8)
    return SyntheticCloth("white_towel", texture, np.ones(shape, bool), (0.22, 0.17))


def shadowed(image: np.ndarray, columns: tuple[int, int]) -> np.ndarray:
    """`image` with a soft-edged band of shadow over `columns` (the whole height)."""
    u = np.arange(image.shape[1], dtype=float)
    edge = np.clip((u - columns[0]) / 12.0, 0, 1) * np.clip((columns[1] - u) / 12.0, 0, 1)
    factor = 1.0 - (1.0 - SHADOW) * edge
    return np.clip(image * factor[None, :, None] + 0.5, 0, 255).astype(np.uint8)


def scene_pair(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """The white cloth at POSE in even light."""
    camera = CameraRealism(gain=1.1, white_balance=(1.0, 1.0, 1.0), shading=0.0, noise_sigma=3.0,
                           blur_sigma=0.6, jpeg_quality=90)  # fmt: skip
    left, right = render_stereo_pair(RIG, [(white_towel(), POSE)], rng=rng, camera=camera)
    return left, right


def scene(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """... with a band of shadow across the cloth's middle in both images."""
    left, right = scene_pair(rng)
    return shadowed(left, (300, 470)), shadowed(right, (280, 450))


def test_the_shading_is_the_shadow_on_the_sheet_and_under_the_cloth() -> None:
    _, right = scene(np.random.default_rng(0))
    photo, background = render_model_photo(white_towel(), MODEL_CAMERA)
    model = make_model(photo, MODEL_CAMERA, background, name="white_towel")
    exposure = scene_exposure(right, model, ExposureSettings())
    assert exposure.shading is not None
    factors = exposure.shading.factor_map(right.shape[:2])
    unshadowed, _ = scene_pair(np.random.default_rng(0))
    shadow = right[20:60, 330:400, 1].mean() / unshadowed[20:60, 330:400, 1].mean()  # ~ SHADOW

    def corrected(rows: slice, columns: slice) -> float:
        return float(right[rows, columns, 1].mean() * np.median(factors[rows, columns]))

    top = slice(20, 60)
    lit = corrected(top, slice(100, 200))
    assert abs(corrected(top, slice(330, 400)) / lit - 1.0) < 0.1  # the sheet in the band as bright as lit
    assert abs(corrected(top, slice(500, 600)) / lit - 1.0) < 0.1  # and beside it
    # under the cloth the sheet's shadow is filled in from around it: at least half the way
    band = np.median(factors[220:260, 330:400]) / np.median(factors[220:260, 100:200])
    assert band > shadow**-0.5
    even, _ = render_stereo_pair(RIG, [(white_towel(), POSE)], rng=np.random.default_rng(1))
    assert scene_exposure(even, model, ExposureSettings()).shading is None


def test_shaded_codes_with_one_level_of_one_are_the_plain_codes() -> None:
    bgr = np.random.default_rng(5).integers(0, 256, (30, 40, 3)).astype(np.uint8)
    table = colour_table(40, 40, 128)
    box = box_spans([3, 2, 35, 27], 30)
    gains = np.array([1.1, 0.9, 1.3])
    plain = bgr_codes(bgr, table, OFF_IMAGE, gain_levels(gains), box)
    levels = np.stack([gain_levels(gains), gain_levels(gains * 2.0)])
    index = np.zeros((4, 5), np.uint8)
    assert np.array_equal(bgr_codes_shaded(bgr, table, OFF_IMAGE, levels, index, 8, box), plain)
    index[:, 2:] = 1  # columns from 16 px on: twice the light
    doubled = bgr_codes(bgr, table, OFF_IMAGE, gain_levels(gains * 2.0), box).reshape(33, 43)
    shaded = bgr_codes_shaded(bgr, table, OFF_IMAGE, levels, index, 8, box).reshape(33, 43)
    assert np.array_equal(shaded[:, 17:], doubled[:, 17:])
    assert np.array_equal(shaded[:, :17], plain.reshape(33, 43)[:, :17])


def test_a_white_cloth_half_in_a_shadow_is_found_where_it_lies() -> None:
    photo, background = render_model_photo(white_towel(), MODEL_CAMERA)
    model = make_model(photo, MODEL_CAMERA, background, name="white_towel")
    settings = RecognitionSettings()
    without = load_config(RecognitionSettings, None, ["exposure.shading=false"])
    found, found_without = [], []
    for seed in range(3):
        left, right = scene(np.random.default_rng(10 + seed))
        for recognizer, out in (
            (Recognizer(model, RIG, settings), found),
            (Recognizer(model, RIG, without), found_without),
        ):
            result = recognizer.recognize(left, right, seed=seed)
            error = pose_error(result.transform_model_to_camera, POSE, tuple(model.symmetry_angles))
            out.append(result.found and max(abs(error.x_mm), abs(error.y_mm)) < 3 and abs(error.yaw_deg) < 2)
    assert all(found)
    assert not any(found_without)  # the shadowed half is DARK against the model's LIGHT


def test_the_compiled_hsv_is_opencvs_for_every_colour() -> None:
    """`exposure_kernels._hsv` (OpenCV's integer arithmetic) against `hue.to_hsv` on all 2^24 colours."""
    colours = every_colour()
    assert np.array_equal(hsv_image(colours), to_hsv(colours))


def test_the_compiled_sheet_sample_is_that_of_numpy() -> None:
    """`exposure_kernels.sheet_sample` against its numpy twin (the mask by
    `hue.hue_distance` on `hue.to_hsv` of image[::step, ::step], the lower median of each
    channel by sorting, `np.median` of the value, the core by `cv2.erode`) on noisy images
    with sheet, foreign hues, greys and hues across the circle's wrap."""
    rng = np.random.default_rng(5)
    for trial in range(40):
        sheet_bgr = np.array([40, 150 + trial, 60])  # green, the sheet
        image = rng.integers(0, 256, (83, 101, 3)).astype(np.uint8)
        sheet_like = rng.random((83, 101)) < rng.uniform(0.0, 0.95)
        noisy = sheet_bgr + rng.normal(0, 12, (sheet_like.sum(), 3))
        image[sheet_like] = np.clip(noisy, 0, 255).astype(np.uint8)
        step = int(rng.integers(1, 9))
        sample = np.ascontiguousarray(image[::step, ::step])
        hsv = to_hsv(sample)
        background_hue = int(rng.integers(0, 256))
        min_saturation, tolerance = int(rng.integers(0, 80)), int(rng.integers(1, 64))
        expected = (hsv[..., 1] >= min_saturation) & (hue_distance(hsv[..., 0], background_hue) <= tolerance)
        mask, count, medians, value, median, core, size = sheet_sample(
            image, step, min_saturation, background_hue, tolerance
        )
        assert np.array_equal(mask, expected) and count == expected.sum()
        assert np.array_equal(value, hsv[..., 2])
        eroded = cv2.erode(expected.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0
        assert np.array_equal(core, eroded) and size == eroded.sum()
        if count:
            lower = np.sort(sample[expected], axis=0)[(count - 1) // 2]
            assert medians.tolist() == lower.astype(float).tolist()
            assert median == float(np.median(hsv[..., 2][expected]))
        else:
            assert np.isnan(median)


def test_the_compiled_even_light_test_is_that_of_opencv() -> None:
    """`exposure_kernels.encoded_deviation` against its twin: the encoding on the core, 128
    elsewhere, and the largest |cv2.medianBlur - 128| over the core."""
    rng = np.random.default_rng(6)
    for _ in range(60):
        shape = (int(rng.integers(1, 70)), int(rng.integers(1, 90)))
        value = rng.integers(0, 256, shape).astype(np.uint8)
        core = rng.random(shape) < rng.uniform(0.0, 1.0)
        levels = np.clip(rng.normal(128, rng.uniform(1, 60), 256), 0, 255).astype(np.uint8)
        encoded, deviation = encoded_deviation(value, core, levels)
        expected = np.where(core, levels[value], 128).astype(np.uint8)
        assert np.array_equal(encoded, expected)
        smoothed = cv2.medianBlur(expected, 3).astype(int)
        assert deviation == (np.abs(smoothed[core] - 128).max() if core.any() else 0)


def test_the_even_light_test_on_many_tiny_images() -> None:
    """`encoded_deviation` on 3000 images of 1-4 x 1-4 samples, all core: with so few
    samples the largest deviation is that of one or two medians, so a wrong median of any
    position shows (the kernel takes each 3 x 3 median from sorted columns)."""
    rng = np.random.default_rng(7)
    for _ in range(3000):
        shape = (int(rng.integers(1, 5)), int(rng.integers(1, 5)))
        value = rng.integers(0, 256, shape).astype(np.uint8)
        levels = rng.integers(0, 256, 256).astype(np.uint8)
        _, deviation = encoded_deviation(value, np.ones(shape, dtype=bool), levels)
        smoothed = cv2.medianBlur(levels[value], 3).astype(int)
        assert deviation == np.abs(smoothed - 128).max()
