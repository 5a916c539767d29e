"""Recognizer on synthetic stereo pairs with exact ground truth (320x240, 48°, 0.1 m baseline)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from robot_app.errors import InputError
from robot_app.geometry import (
    invert_transform,
    make_transform,
    rotation_about_z,
    rotation_from_rpy,
    wrap_angle,
    yaw_of,
)
from robot_app.vision.camera import ModelCamera, PinholeCamera, StereoRig
from robot_app.vision.cloth_model import ClothModel
from robot_app.vision.photo_model import make_model
from robot_app.vision.recognizer import RecognitionSettings, Recognizer
from robot_app.vision.synthetic import occluder_covering, render_model_photo, render_stereo_pair
from robot_app.vision.synthetic_catalogue import synthetic_cloth

CAMERA = PinholeCamera.from_fov((320, 240), np.deg2rad(48))
RIG = StereoRig(CAMERA, CAMERA, make_transform(np.eye(3), [-0.1, 0.0, 0.0]))
MODEL_CAMERA = ModelCamera(PinholeCamera.from_fov((640, 480), np.deg2rad(48)), 0.40)
_MODELS: dict[int, ClothModel] = {}


def model(index: int) -> ClothModel:
    if index not in _MODELS:
        photo, background = render_model_photo(synthetic_cloth(index), MODEL_CAMERA)
        _MODELS[index] = make_model(photo, MODEL_CAMERA, background, name=f"cloth{index}")
    return _MODELS[index]


def yaw_error(model: ClothModel, estimate: np.ndarray, truth: np.ndarray) -> float:
    """Yaw difference [rad] modulo the cloth's own symmetries."""
    d = float(wrap_angle(np.arctan2(estimate[1, 0], estimate[0, 0]) - np.arctan2(truth[1, 0], truth[0, 0])))
    return min([abs(d)] + [abs(float(wrap_angle(d - a))) for a in model.symmetry_angles])


POSE = make_transform(rotation_from_rpy(0.05, -0.04, 2.2), [-0.04, 0.03, 0.575])


def test_recognizes_the_cloth_at_its_true_pose() -> None:
    left, right = render_stereo_pair(RIG, [(synthetic_cloth(8), POSE)], rng=np.random.default_rng(0))
    recognizer = Recognizer(model(8), RIG)
    results = [recognizer.recognize(left, right, seed=seed) for seed in range(5)]
    good = []
    for result in results:
        error = result.transform_model_to_camera[:3, 3] - POSE[:3, 3]
        yaw = yaw_error(model(8), result.transform_model_to_camera, POSE)
        good.append(bool(np.all(np.abs(error[:2]) < 0.003) and abs(error[2]) < 0.015 and yaw < np.deg2rad(2)))
        assert good[-1] == (result.fitness > 0.95)  # a wrong pose shows in the fitness
    assert sum(good) >= 4  # the GA misses now and then (a local peak); the benchmark counts how often
    result = results[good.index(True)]
    assert result.found and result.generations == 100 and result.evaluations > 100 * 98
    record = result.to_json()
    assert record["frame"] == "right_camera" and record["found"] is True
    assert np.allclose(record["position"], result.position) and abs(record["quaternion_xyzw"][3]) <= 1


def test_same_seed_same_result() -> None:
    left, right = render_stereo_pair(RIG, [(synthetic_cloth(5), POSE)], rng=np.random.default_rng(1))
    recognizer = Recognizer(model(5), RIG)
    a = recognizer.recognize(left, right, seed=11)
    b = recognizer.recognize(left, right, seed=11)
    np.testing.assert_array_equal(a.transform_model_to_camera, b.transform_model_to_camera)


def test_partly_covered_cloth_is_still_located_roughly() -> None:
    # 45 % under a blue sheet: the paper's fitness peaks near, not at, the truth (a smaller,
    # farther model fits the visible part); scripts/bench_recognition.py measures the spread.
    cover = occluder_covering(synthetic_cloth(3), POSE, fraction=0.45, direction=1.0)
    left, right = render_stereo_pair(
        RIG, [(synthetic_cloth(3), POSE)], occluder=cover, rng=np.random.default_rng(2)
    )
    recognizer = Recognizer(model(3), RIG)
    results = [recognizer.recognize(left, right, seed=seed) for seed in range(4)]
    near = [bool(np.all(np.abs(r.transform_model_to_camera[:2, 3] - POSE[:2, 3]) < 0.015)) for r in results]
    # Known weakness (see the benchmark): the GA misses this scene's peak in half the runs.
    assert sum(near) >= 2
    assert all(0.3 < r.fitness < 0.8 for r, ok in zip(results, near, strict=True) if ok)


def test_absent_cloth_is_not_found_and_two_cloths_give_two_peaks() -> None:
    other = make_transform(rotation_about_z(-0.5), [0.1, -0.06, 0.58])
    target = make_transform(rotation_about_z(1.0), [-0.12, 0.05, 0.58])
    only_other = render_stereo_pair(RIG, [(synthetic_cloth(4), other)], rng=np.random.default_rng(3))
    assert not Recognizer(model(0), RIG).recognize(*only_other, seed=2).found
    both = render_stereo_pair(
        RIG, [(synthetic_cloth(0), target), (synthetic_cloth(4), other)], rng=np.random.default_rng(4)
    )
    result = Recognizer(model(0), RIG).recognize(*both, seed=2, report_peaks=True)
    assert result.found and np.linalg.norm(result.position[:2] - target[:2, 3]) < 0.004
    assert len(result.peaks) >= 2 and result.peaks[0].fitness == result.fitness
    fitness = [p.fitness for p in result.peaks]
    assert fitness == sorted(fitness, reverse=True)
    for i, a in enumerate(result.peaks):
        for b in result.peaks[i + 1 :]:
            assert np.linalg.norm(a.position[:2] - b.position[:2]) >= 0.06  # distinct peaks


def test_restarts_search_away_from_a_poor_peak_that_draws_the_runs() -> None:
    # A dotted cyan model beside a plain cyan cloth: the plain cloth's wide peak (0.68) drew
    # every run of seed 1 from the target's narrow one (1.00) before restarts avoided it.
    target = make_transform(rotation_about_z(2.42), [0.12, 0.0076, 0.58])
    other = make_transform(rotation_about_z(2.94), [-0.12, 0.033, 0.58])
    both = render_stereo_pair(
        RIG, [(synthetic_cloth(5), target), (synthetic_cloth(6), other)], rng=np.random.default_rng(0)
    )
    recognizer = Recognizer(model(5), RIG)
    for seed in range(4):
        result = recognizer.recognize(*both, seed=seed)
        assert result.found and np.linalg.norm(result.position[:2] - target[:2, 3]) < 0.005, seed


def test_tracking_follows_a_moving_camera_with_few_evaluations() -> None:
    recognizer = Recognizer(model(3), RIG)
    pose = POSE.copy()
    left, right = render_stereo_pair(RIG, [(synthetic_cloth(3), pose)], rng=np.random.default_rng(5))
    recognizer.recognize(left, right, seed=0)
    step = make_transform(rotation_about_z(0.03), [0.004, -0.003, -0.002])  # camera pose change
    for frame in range(5):
        motion = invert_transform(step)  # ^CR_new T_CR_old for a camera moved by `step`
        pose = motion @ pose
        left, right = render_stereo_pair(
            RIG, [(synthetic_cloth(3), pose)], rng=np.random.default_rng(10 + frame)
        )
        result = recognizer.track(left, right, motion)
        assert result.found
        assert np.all(np.abs(result.transform_model_to_camera[:2, 3] - pose[:2, 3]) < 0.003)
        assert yaw_error(model(3), result.transform_model_to_camera, pose) < np.deg2rad(2)
        assert result.evaluations < 1500 and result.generations == 3


def test_tracking_codes_only_the_region_its_window_reaches_and_finds_the_same() -> None:
    left, right = render_stereo_pair(RIG, [(synthetic_cloth(3), POSE)], rng=np.random.default_rng(6))
    motion = invert_transform(make_transform(rotation_about_z(0.02), [0.003, -0.002, 0.0]))
    moved_left, moved_right = render_stereo_pair(
        RIG, [(synthetic_cloth(3), motion @ POSE)], rng=np.random.default_rng(7)
    )
    results = []
    for whole_images in (False, True):
        recognizer = Recognizer(model(3), RIG)
        recognizer.recognize(left, right, seed=0)
        regions = recognizer.proposer.tracking_regions(motion)
        width, height = RIG.image_size
        assert all(np.maximum(s[:, 1] - s[:, 0] + 1, 0).sum() < 0.8 * width * height for s in regions)
        if whole_images:
            recognizer.proposer.tracking_regions = lambda _motion: None  # type: ignore[method-assign]
        results.append(recognizer.track(moved_left, moved_right, motion))
    np.testing.assert_allclose(results[0].transform_model_to_camera, results[1].transform_model_to_camera)
    assert results[0].fitness == results[1].fitness


def test_each_tracking_frame_searches_around_its_own_moved_pose() -> None:
    """The window is built once per frame (shared by the pixel regions and the search), and
    a motion equal to the last frame's still moves the poses kept since."""
    motion = invert_transform(make_transform(rotation_about_z(0.01), [0.003, -0.002, 0.0]))
    recognizer = Recognizer(model(3), RIG)
    pose = POSE
    left, right = render_stereo_pair(RIG, [(synthetic_cloth(3), pose)], rng=np.random.default_rng(6))
    recognizer.recognize(left, right, seed=0)
    for frame in range(3):
        pose = motion @ pose
        kept = recognizer.proposer.kept_poses
        assert kept is not None
        window = recognizer.proposer.tracking_window(motion)
        moved = (motion @ kept[0])[:3, 3]
        assert window.x == (moved[0] - 0.02, moved[0] + 0.02)
        assert window.y == (moved[1] - 0.02, moved[1] + 0.02)
        rng = np.random.default_rng(20 + frame)
        left, right = render_stereo_pair(RIG, [(synthetic_cloth(3), pose)], rng=rng)
        result = recognizer.track(left, right, motion)
        assert np.all(np.abs(result.transform_model_to_camera[:2, 3] - pose[:2, 3]) < 0.003)


def test_wrong_image_size_is_bad_input() -> None:
    image = np.zeros((100, 100, 3), np.uint8)
    with pytest.raises(InputError) as size:
        Recognizer(model(0), RIG).recognize(image, image)
    assert (size.value.key, size.value.value) == ("left", (100, 100))


def test_settings_reach_the_parts() -> None:
    settings = RecognitionSettings.model_validate(
        {
            "propose": {"ga": {"population": 20, "generations": 5, "islands": 1}, "coarse_generations": 2,
                        "restarts": 0},
            "refine": {"enabled": False},
            "depth": {"enabled": False},  # (it scores the poses it moves or searches again)
        }
    )  # fmt: skip
    left, right = render_stereo_pair(RIG, [(synthetic_cloth(0), POSE)], rng=np.random.default_rng(6))
    result = Recognizer(model(0), RIG, settings).recognize(left, right, seed=0)
    # rescored at the coarse-to-fine switch; + the search fitness of the end; the 4 turns of
    # the ambiguity check; the reported (paper) fitness of the result
    assert result.generations == 5 and result.evaluations == 20 + 2 * 18 + 20 + 3 * 18 + 1 + 4 + 1


def test_garbage_collector_runs_again_after_a_recognition() -> None:
    import gc

    left, right = render_stereo_pair(RIG, [(synthetic_cloth(0), POSE)], rng=np.random.default_rng(0))
    settings = RecognitionSettings.model_validate({"propose": {"ga": {"generations": 5}, "restarts": 0}})
    recognizer = Recognizer(model(0), RIG, settings)
    assert gc.isenabled()
    recognizer.recognize(left, right, seed=0)
    recognizer.track(left, right)
    assert gc.isenabled()
    gc.disable()  # a caller that switched it off keeps it off
    try:
        recognizer.recognize(left, right, seed=0)
        assert not gc.isenabled()
    finally:
        gc.enable()


def test_tracking_keeps_the_yaw_branch_of_the_predicted_pose() -> None:
    """A plain rectangle scores the same half turned; tracking must not flip to the half
    turn even when most of the poses it kept are half turned (they came from the one-shot
    search, which explored both)."""
    recognizer = Recognizer(model(0), RIG)
    left, right = render_stereo_pair(RIG, [(synthetic_cloth(0), POSE)], rng=np.random.default_rng(7))
    recognizer.recognize(left, right, seed=0)
    half_turn = np.diag([-1.0, -1.0, 1.0, 1.0])
    kept = recognizer.proposer.kept_poses
    predicted = make_transform(rotation_about_z(0.06), [0.002, -0.002, 0.0]) @ POSE  # a little off
    recognizer.proposer.keep(predicted, np.repeat((POSE @ half_turn)[None], len(kept), axis=0))
    for frame in range(3):
        left, right = render_stereo_pair(
            RIG, [(synthetic_cloth(0), POSE)], rng=np.random.default_rng(20 + frame)
        )
        result = recognizer.track(left, right, np.eye(4))
        turned = abs(wrap_angle(yaw_of(result.transform_model_to_camera[:3, :3]) - yaw_of(POSE[:3, :3])))
        assert turned < np.deg2rad(5.0), (
            f"frame {frame}: tracking turned the cloth by {np.rad2deg(turned):.0f} deg"
        )


def test_tracking_starts_from_the_verified_pose_not_the_proposal(monkeypatch: pytest.MonkeyPatch) -> None:
    """When verification prefers another pose than the GA's best (e.g. its half turn), the
    next tracking frame starts from the verified pose."""
    recognizer = Recognizer(model(2), RIG)
    left, right = render_stereo_pair(RIG, [(synthetic_cloth(2), POSE)], rng=np.random.default_rng(8))
    half_turn = np.diag([-1.0, -1.0, 1.0, 1.0])
    choose = recognizer._most_confident

    def prefer_the_half_turn(best, candidates, rng):  # what verification does on a flipped proposal
        verified = choose(best, candidates, rng)
        return dataclasses.replace(verified, pose=verified.pose @ half_turn)

    monkeypatch.setattr(recognizer, "_most_confident", prefer_the_half_turn)
    result = recognizer.recognize(left, right, seed=0)
    kept = recognizer.proposer.kept_poses
    assert kept is not None
    np.testing.assert_allclose(kept[0], result.transform_model_to_camera, atol=1e-12)
