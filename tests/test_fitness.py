"""Fitness (eqs. 9-11): the compiled kernel against a plain numpy reading of the paper."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from robot_app.config import validate
from robot_app.errors import ConfigError, InputError
from robot_app.geometry import make_transform, rotation_about_z, rotation_from_rpy
from robot_app.vision.camera import ModelCamera, PinholeCamera, StereoRig
from robot_app.vision.cloth_model import ClothModel
from robot_app.vision.fitness import FitnessEvaluator
from robot_app.vision.fitness_kernels import bgr_codes, gain_levels, hsv_codes
from robot_app.vision.fitness_scores import OFF_IMAGE, OUTSIDE_ROW, FitnessSettings, score_table, seen_table
from robot_app.vision.hue import DARK, LIGHT, colour_codes, hue_distance, to_hsv
from robot_app.vision.photo_model import ModelSettings, make_model
from robot_app.vision.pixel_codes import box_spans, colour_table
from robot_app.vision.poses import AvoidedPoses
from robot_app.vision.recognizer import RecognitionSettings
from robot_app.vision.synthetic import SyntheticCloth, render_model_photo, render_stereo_pair
from robot_app.vision.synthetic_catalogue import synthetic_cloth


def make_rig(size: tuple[int, int] = (320, 240)) -> StereoRig:
    camera = PinholeCamera.from_fov(size, np.deg2rad(48))
    return StereoRig(camera, camera, make_transform(np.eye(3), [-0.1, 0.0, 0.0]))


def hand_model(
    index: int, spacing: float = 0.006, band: float = 0.006, margin_m: float = 0.002
) -> ClothModel:
    """A model read straight off a synthetic cloth's texture: S_in on a grid inside the
    outline (at least `margin_m` from its edge), S_out on a ring `band` outside it."""
    cloth = synthetic_cloth(index)
    hues = to_hsv(np.ascontiguousarray(cloth.texture_bgr))[:, :, 0]
    sx, _ = cloth.texel_size
    step = round(spacing / sx)
    height, width = cloth.alpha.shape
    v0, u0 = ((height - 1) % step) // 2, ((width - 1) % step) // 2  # a grid centred on the texture
    v, u = np.mgrid[v0:height:step, u0:width:step]
    u, v = u.ravel(), v.ravel()
    margin = round(margin_m / sx)
    inner = np.ones_like(u, dtype=bool)
    for du, dv in ((margin, 0), (-margin, 0), (0, margin), (0, -margin)):
        uu, vv = np.clip(u + du, 0, width - 1), np.clip(v + dv, 0, height - 1)
        inner &= cloth.alpha[vv, uu] & (u + du >= 0) & (u + du < width) & (v + dv >= 0) & (v + dv < height)
    points_in = cloth.texel_to_model(np.stack([u[inner], v[inner]], axis=-1))
    ring = []
    for angle in np.linspace(0, 2 * np.pi, 180, endpoint=False):
        d = np.array([np.cos(angle), np.sin(angle)])
        edge = max(float(np.max(points_in[:, :2] @ d)), 0.0)
        ring.append(d * (edge + band))
    hull = np.array(ring)
    points_out = np.c_[hull, np.zeros(len(hull))]
    return ClothModel(
        name=cloth.name,
        points_in=points_in,
        hues_in=hues[v[inner], u[inner]],
        points_out=points_out,
        background_hue=86.0,
        grasp_point=np.zeros(3),
        extent=(float(np.ptp(points_in[:, 0])), float(np.ptp(points_in[:, 1]))),
    )


def reference_fitness(model: ClothModel, rig: StereoRig, left, right, T, p: FitnessSettings) -> float:
    """Eqs. 9-11 read literally, one point at a time, with the rig's own projection."""
    total, in_view = 0.0, 0.0
    pix_left, pix_right = rig.project_model(T, np.vstack([model.points_in, model.points_out]))
    for image, pixels in ((left, pix_left), (right, pix_right)):
        hue = to_hsv(image)[:, :, 0]
        for i, (u, v) in enumerate(pixels):
            if not np.isfinite(u) or not (0 <= u + 0.5 < image.shape[1] and 0 <= v + 0.5 < image.shape[0]):
                continue
            h = hue[int(v + 0.5), int(u + 0.5)]
            in_view += p.score_in_match if i < model.n_in else p.score_out_background
            near_bg = hue_distance(h, round(model.background_hue))
            if i < model.n_in:
                if hue_distance(h, model.hues_in[i]) <= p.hue_threshold_in:
                    total += p.score_in_match
                elif near_bg <= p.hue_threshold_in:
                    total += p.score_in_background
                else:
                    total += p.score_in_other
            else:
                total += p.score_out_background if near_bg <= p.hue_threshold_out else p.score_out_other
    full = 2.0 * (p.score_in_match * model.n_in + p.score_out_background * model.n_out)
    if p.normalisation == "model":
        return total / full
    return total / max(in_view, p.min_view_fraction * full)


@pytest.fixture(scope="module")
def scene():
    rig = make_rig()
    model = hand_model(4)  # checks: colour edges in both directions pin the pose inside the outline
    pose = make_transform(rotation_about_z(0.4), [0.02, -0.01, 0.58])
    left, right = render_stereo_pair(rig, [(synthetic_cloth(4), pose)], rng=np.random.default_rng(1))
    evaluator = FitnessEvaluator(model, rig)
    evaluator.update(left, right)
    return rig, model, pose, left, right, evaluator


def test_true_pose_scores_near_one_and_beats_neighbours(scene) -> None:
    _, _, pose, _, _, evaluator = scene
    at_truth = evaluator.evaluate(pose)[0]
    assert at_truth > 0.97
    shifted = pose.copy()
    shifted[0, 3] += 0.01
    turned = pose.copy()
    turned[:3, :3] = rotation_about_z(0.1) @ pose[:3, :3]
    deeper = pose.copy()
    deeper[2, 3] += 0.03
    assert np.all(evaluator.evaluate(np.stack([shifted, turned, deeper])) < at_truth - 0.02)


def test_kernel_matches_reference_including_points_off_the_image(scene) -> None:
    rig, model, pose, left, right, evaluator = scene
    rng = np.random.default_rng(7)
    poses = [pose]
    for _ in range(12):
        R = rotation_from_rpy(*rng.uniform(-0.3, 0.3, 2), rng.uniform(-np.pi, np.pi))
        poses.append(
            make_transform(R, [rng.uniform(-0.3, 0.3), rng.uniform(-0.25, 0.25), rng.uniform(0.5, 0.7)])
        )
    edge = pose.copy()  # half the model out of view
    edge[0, 3] = 0.23
    poses.append(edge)
    for normalisation in ("view", "model"):
        p = FitnessSettings(normalisation=normalisation)
        evaluator = FitnessEvaluator(model, rig, p)
        evaluator.update(left, right)
        got = evaluator.evaluate(np.stack(poses))
        want = [reference_fitness(model, rig, left, right, T, p) for T in poses]
        np.testing.assert_allclose(got, want, atol=1e-5)


def test_a_cloth_reaching_past_the_image_edge_matches_fully_at_its_true_pose() -> None:
    rig = make_rig()
    model = hand_model(4)
    pose = make_transform(rotation_about_z(0.4), [-0.2, 0.0, 0.58])  # partly out of the left image
    left, right = render_stereo_pair(rig, [(synthetic_cloth(4), pose)], rng=np.random.default_rng(2))
    fitness = {}
    for normalisation in ("view", "model"):
        evaluator = FitnessEvaluator(model, rig, FitnessSettings(normalisation=normalisation))
        evaluator.update(left, right)
        fitness[normalisation] = evaluator.evaluate(pose)[0]
        farther = pose.copy()
        farther[2, 3] += 0.03  # smaller: more of it fits into the left image
        fitness[normalisation + " farther"] = evaluator.evaluate(farther)[0]
    assert fitness["model"] < 0.95  # the paper's divisor counts the points off the left image
    assert fitness["view"] > 0.97
    assert fitness["view farther"] < fitness["view"] - 0.05


def test_hue_is_compared_on_the_circle() -> None:
    table = score_table(86.0, FitnessSettings())
    assert table[250, 5] == 2.0  # 250 and 5 are 11 steps apart across 0
    assert table[250, 200] == 0.0  # 50 steps: no match, not background
    assert table[10, 100] == pytest.approx(-0.005)  # background-hued pixel under S_in
    assert table[OUTSIDE_ROW, 70] == pytest.approx(0.1) and table[OUTSIDE_ROW, 120] == -0.5  # S_out, eq. 10


def test_tones_match_only_their_own_tone() -> None:
    p = FitnessSettings()
    table = score_table(86.0, p)
    assert table[DARK, DARK] == 2.0 and table[LIGHT, LIGHT] == 2.0
    assert table[DARK, LIGHT] == p.score_in_other and table[LIGHT, DARK] == p.score_in_other
    assert table[DARK, 10] == p.score_in_other and table[10, DARK] == p.score_in_other
    assert table[LIGHT, 86] == pytest.approx(p.score_in_background)  # a white point on the sheet
    assert table[OUTSIDE_ROW, DARK] == p.score_out_other and table[OUTSIDE_ROW, LIGHT] == p.score_out_other
    assert not table[:, OFF_IMAGE].any()
    # A tone the model lacks is foreign (hidden) in the search; one it has is not.
    hidden = FitnessSettings(hidden_foreign=True)
    seen = seen_table(86.0, hidden, np.r_[np.full(50, 10), np.full(50, DARK)])
    assert seen[10, DARK] and seen[OUTSIDE_ROW, DARK]
    assert not seen[10, LIGHT] and not seen[OUTSIDE_ROW, LIGHT] and not seen[DARK, LIGHT]


def test_compiled_pixel_codes_agree_with_colour_codes() -> None:
    rng = np.random.default_rng(3)
    hsv = rng.integers(0, 256, (37, 53, 3)).astype(np.uint8)
    hsv[::3, :, 2] = rng.integers(0, 60, (13, 53))  # plenty of dark pixels
    flat = hsv_codes(hsv, 40, 40, 128, DARK, LIGHT, OFF_IMAGE).reshape(37 + 3, 53 + 3)
    expected = colour_codes(hsv, 40, 40, 128)
    assert np.array_equal(flat[1:-2, 1:-2], expected)
    assert set(np.unique(expected[expected > 255])) == {DARK, LIGHT}
    assert (flat[0] == OFF_IMAGE).all() and (flat[-2:] == OFF_IMAGE).all()


def test_pixel_codes_by_colour_table_agree_with_the_conversion() -> None:
    rng = np.random.default_rng(4)
    bgr = rng.integers(0, 256, (41, 59, 3)).astype(np.uint8)
    bgr[::4] //= 6  # plenty of dark pixels
    for thresholds in ((40, 40, 128), (0, 0, 128), (25, 60, 100)):
        expected = hsv_codes(to_hsv(bgr), *thresholds, DARK, LIGHT, OFF_IMAGE)
        assert np.array_equal(
            bgr_codes(
                bgr,
                colour_table(*thresholds),
                OFF_IMAGE,
                gain_levels(np.ones(3)),
                box_spans([0, 0, 10**6, 10**6], 41),
            ),
            expected,
        )
    assert not colour_table(40, 40, 128).flags.writeable


def test_the_colour_table_is_kept_in_the_cache_folder_and_rebuilt_when_damaged(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("ROBOT_APP_CACHE", str(tmp_path))
    build = colour_table.__wrapped__  # past the in-process cache
    built = build(30, 50, 120)
    files = list(tmp_path.glob("colour_table_s30_v50_split120_*.npy"))
    assert len(files) == 1 and not list(tmp_path.glob(".*partial"))
    read = build(30, 50, 120)
    assert np.array_equal(read, built) and not read.flags.writeable
    files[0].write_bytes(b"not a table")
    assert np.array_equal(build(30, 50, 120), built)  # rebuilt and written again
    assert np.array_equal(np.load(files[0]), built)


def test_pixel_codes_only_inside_the_region_the_rest_off_the_image() -> None:
    bgr = np.random.default_rng(5).integers(0, 256, (30, 40, 3)).astype(np.uint8)
    table = colour_table(40, 40, 128)
    full = bgr_codes(bgr, table, OFF_IMAGE, gain_levels(np.ones(3)), box_spans([0, 0, 39, 29], 30))
    part = bgr_codes(bgr, table, OFF_IMAGE, gain_levels(np.ones(3)), box_spans([5, 7, 20, 11], 30))
    framed = full.reshape(33, 43)  # one frame pixel left and top, two right and bottom
    inside = np.zeros_like(framed, dtype=bool)
    inside[8:13, 6:22] = True
    np.testing.assert_array_equal(part.reshape(33, 43)[inside], framed[inside])
    assert np.all(part.reshape(33, 43)[~inside] == OFF_IMAGE)


def test_low_saturation_pixels_have_no_hue() -> None:
    rig = make_rig((64, 48))
    model = ClothModel("grey", np.zeros((1, 3)), np.array([0]), np.empty((0, 3)), 86.0, np.zeros(3), (0, 0))
    grey = np.full((48, 64, 3), 128, np.uint8)  # hue 0 by OpenCV's convention, saturation 0
    pose = make_transform(np.eye(3), [0.0, 0.0, 0.5])
    paper = FitnessEvaluator(model, rig)
    paper.update(grey, grey)
    assert paper.evaluate(pose)[0] == pytest.approx(1.0)  # the paper's reading: grey has hue 0
    strict = FitnessEvaluator(model, rig, FitnessSettings(min_saturation=40))
    strict.update(grey, grey)
    assert strict.evaluate(pose)[0] == 0.0
    # A point of tone LIGHT matches grey at or above the value split, DARK one below it.
    for code, image, expected in ((LIGHT, grey, 1.0), (DARK, grey, 0.0), (DARK, grey // 4, 1.0)):
        toned = ClothModel("t", np.zeros((1, 3)), [code], np.empty((0, 3)), 86.0, np.zeros(3), (0, 0))
        evaluator = FitnessEvaluator(toned, rig, FitnessSettings(min_saturation=40))
        evaluator.update(image, image)
        assert evaluator.evaluate(pose)[0] == pytest.approx(expected)


def _maroon_cloth_with_white_dots_on_one_side() -> SyntheticCloth:
    """14 x 12 cm maroon, three white dots near its left edge: only the dots tell a half turn."""
    texel = 0.0005
    texture = np.zeros((240, 280, 3), np.uint8)
    texture[:] = (50, 30, 130)
    for centre in ((50, 60), (50, 120), (50, 180)):
        cv2.circle(texture, centre, 22, (225, 225, 225), -1)
    return SyntheticCloth("maroon dots", texture, np.ones((240, 280), bool), (280 * texel, 240 * texel))


def test_white_parts_break_a_half_turn_symmetry_with_tones() -> None:
    cloth = _maroon_cloth_with_white_dots_on_one_side()
    camera = ModelCamera(PinholeCamera.from_fov((640, 480), np.deg2rad(48)), 0.40)
    photo, background = render_model_photo(cloth, camera, rng=np.random.default_rng(0))
    rig = make_rig()
    pose = make_transform(rotation_about_z(0.3), [0.01, 0.02, 0.58])
    half_turn = pose @ make_transform(rotation_about_z(np.pi), [0.0, 0.0, 0.0])
    left, right = render_stereo_pair(rig, [(cloth, pose)], rng=np.random.default_rng(1))
    scores = {}
    for tones, params in ((True, RecognitionSettings().fitness), (False, FitnessSettings())):
        model = make_model(photo, camera, background, ModelSettings(tones=tones))
        evaluator = FitnessEvaluator(model, rig, params)
        evaluator.update(left, right)
        scores[tones] = evaluator.evaluate(np.stack([pose, half_turn]))
    margin = {tones: pair[0] - pair[1] for tones, pair in scores.items()}
    assert scores[True][0] > 0.95 and margin[True] > 0.1, scores
    # The paper's reading: a white pixel's hue is noise around 0, often close to maroon's,
    # so the half turn nearly matches too.
    assert margin[False] < 0.06 and margin[True] > 2.5 * margin[False], scores


def test_subpixel_scoring_agrees_at_the_optimum_and_is_smooth(scene) -> None:
    _, _, pose, _, _, evaluator = scene
    assert evaluator.evaluate(pose, subpixel=True)[0] > 0.95
    shifts = np.linspace(-0.002, 0.002, 41)
    poses = np.repeat(pose[None], len(shifts), axis=0)
    poses[:, 0, 3] += shifts
    smooth = evaluator.evaluate(poses, subpixel=True)
    assert np.max(np.abs(np.diff(smooth))) < 0.01
    assert abs(shifts[np.argmax(smooth)]) <= 0.0005


def test_counts_evaluations_and_validates_input(scene) -> None:
    rig, model, pose, left, right, _ = scene
    evaluator = FitnessEvaluator(model, rig)
    with pytest.raises(RuntimeError, match="update"):
        evaluator.evaluate(pose)
    with pytest.raises(InputError) as size:
        evaluator.update(left, right[:, :200])
    assert (size.value.key, size.value.value) == ("right", (200, 240))  # (width, height) [px]
    with pytest.raises(InputError) as dtype:
        evaluator.update(left.astype(float), right)
    assert (dtype.value.key, dtype.value.value) == ("left", ((240, 320, 3), "float64"))
    evaluator.update(left, right)
    with pytest.raises(ValueError, match="shape"):
        evaluator.evaluate(np.eye(3))
    evaluator.evaluate(np.stack([pose] * 5))
    assert evaluator.evaluations == 5
    assert evaluator.point_evaluations == 5 * 2 * (model.n_in + model.n_out)


def test_params_are_validated() -> None:
    for data, key, value in (
        ({"hue_threshold_in": 200}, "hue_threshold_in", 200),
        ({"score_in_match": -1.0}, "score_in_match", -1.0),
        ({"score_in_match": 0.5, "score_in_other": 1.0}, "score_in_match", 0.5),  # not the largest
        ({"hidden_foreign": True, "normalisation": "model"}, "normalisation", "model"),
    ):
        with pytest.raises(ConfigError) as bad:
            validate(FitnessSettings, data)
        assert (bad.value.key, bad.value.value) == (key, value)
    with pytest.raises(ConfigError) as unknown:
        validate(FitnessSettings, {"bogus": 1})
    assert unknown.value.key == "bogus" and unknown.value.problems[0].problem == "unknown key"


def test_avoided_poses_are_those_near_a_centre_at_its_yaw_or_at_any_yaw() -> None:
    rng = np.random.default_rng(8)
    yaws = rng.uniform(-np.pi, np.pi, 400)
    poses = np.array(
        [
            make_transform(rotation_from_rpy(0.05, -0.04, yaw), [*rng.uniform(-0.1, 0.1, 2), 0.58])
            for yaw in yaws
        ]
    )
    centres = np.array([[0.02, -0.03, np.nan], [-0.04, 0.05, 3.0], [0.05, 0.05, -0.5]])
    separation, window = 0.04, np.deg2rad(45.0)
    # the rule, written plainly: near in x-y and (any yaw or a yaw within the window, on the circle)
    near = np.linalg.norm(poses[:, None, :2, 3] - centres[None, :, :2], axis=2) < separation
    turn = np.abs(
        np.angle(np.exp(1j * (np.arctan2(poses[:, 1, 0], poses[:, 0, 0])[:, None] - centres[None, :, 2])))
    )
    expected = (near & (np.isnan(centres[None, :, 2]) | (turn < window))).any(axis=1)
    mask = AvoidedPoses(centres, separation, window).mask(poses)
    assert 20 < expected.sum() < 380  # both kinds occur
    np.testing.assert_array_equal(mask, expected)
    assert not AvoidedPoses.none().mask(poses).any()
