"""Closed-loop regression tests: the whole pick and place in the simulated cell (320x240).

Each test runs one real episode (pybullet world, station-made model, GA recognition,
Kalman filter, Pinocchio IK, ruckig) and judges it by the simulator's ground truth.
"""

from __future__ import annotations

import numpy as np
import pytest

from robot_app.config import load_config
from robot_app.control.episode import Outcome
from robot_app.errors import ConfigError
from robot_app.experiments.pick_place_episode import PickPlaceConfig, run_episode

BASE = ["world.cameras.image_size=[320,240]"]


def episode(*overrides: str):
    return run_episode(load_config(PickPlaceConfig, None, [*BASE, *overrides])).result


def assert_placed(result) -> None:
    assert result.outcome is Outcome.PLACED, result.reason
    assert result.placed_fraction is not None and result.placed_fraction >= 0.9
    assert result.limit_report.violations == 0
    assert result.collisions == 0
    assert result.success


def test_plain_pick_and_place_puts_the_cloth_in_the_box() -> None:
    result = episode("seed=1", "scene.target=3")
    assert_placed(result)
    assert result.grasp_attempts == 1
    # the recognitions that steered the arm were accurate against ground truth
    tracked = [r for r in result.recognitions if r.accepted]
    assert tracked and max(abs(r.error_x_mm) for r in tracked) < 10
    assert max(abs(r.error_y_mm) for r in tracked) < 10
    # the fingers closed where the loop meant them to, on the true cloth
    assert len(result.grasp_offsets) == 1 and np.hypot(*result.grasp_offsets[0]) < 0.005


def test_pick_and_place_with_the_calibrated_rig_file() -> None:
    # configs/rig_calibrated_320x240.yaml came from `robot-app sim calibration-views` and
    # `robot-app calibrate stereo | hand-eye` (README): the loop sees only what they measured
    result = episode("seed=1", "scene.target=3", "world.cameras.rig_file=configs/rig_calibrated_320x240.yaml")
    assert_placed(result)
    assert np.hypot(*result.grasp_offsets[0]) < 0.005


def test_pick_and_place_with_45_percent_occluded_cloth() -> None:
    assert_placed(episode("seed=2", "scene.target=11", "scene.occluder=true"))


def test_with_a_distractor_the_target_is_picked() -> None:
    result = episode("seed=3", "scene.target=3", "scene.distractor=4")
    assert_placed(result)  # placed_fraction is measured on the target cloth itself


def test_absent_target_is_reported_not_present_without_grasping() -> None:
    result = episode("seed=4", "scene.target=4", "model_cloth=3")
    assert result.outcome is Outcome.NOT_PRESENT
    assert result.grasp_attempts == 0
    assert result.success  # saying "not present" is the right answer here
    assert not any(r.found for r in result.recognitions)


def test_cloth_nudged_during_approach_is_followed() -> None:
    result = episode("seed=5", "scene.target=3", "nudge.after=0.1", "nudge.dx=0.025", "nudge.dy=-0.015")
    assert_placed(result)  # grasped where the cloth went, not where it was first seen
    accepted = [r for r in result.recognitions if r.accepted]
    first, last = accepted[0], accepted[-1]
    moved = np.hypot(last.x - first.x, last.y - first.y)
    assert moved == pytest.approx(np.hypot(0.025, 0.015), abs=0.005)  # the filter followed the push


def test_bad_config_is_a_config_error() -> None:
    with pytest.raises(ConfigError) as too_fast:
        load_config(PickPlaceConfig, None, ["loop.vision_rate_hz=100"])
    assert (too_fast.value.key, too_fast.value.value) == ("loop.vision_rate_hz", 100)
    with pytest.raises(ConfigError) as unknown:
        load_config(PickPlaceConfig, None, ["loop.speed=3"])
    assert unknown.value.key == "loop.speed" and unknown.value.problems[0].problem == "unknown key"
