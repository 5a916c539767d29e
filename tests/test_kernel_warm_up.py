"""The kernel warm-up: a synthetic view of the model that the recogniser really finds."""

from __future__ import annotations

import numpy as np

import robot_app.vision.kernel_warm_up as kernel_warm_up_module
from robot_app.vision.kernel_warm_up import synthetic_pose, warm_up
from robot_app.vision.recognizer import Recognizer
from tests.test_recognizer import RIG, model


def test_warm_up_finds_the_model_in_its_view_once_per_process_and_leaves_the_caller_alone(
    monkeypatch,
) -> None:
    monkeypatch.setattr(kernel_warm_up_module, "_done", False)
    recognizer = Recognizer(model(8), RIG)
    result = warm_up(recognizer)
    assert result is not None and result.found  # the view is the model, where it was drawn
    error = result.transform_model_to_camera[:3, 3] - synthetic_pose(recognizer)[:3, 3]
    assert np.all(np.abs(error[:2]) < 0.003) and abs(error[2]) < 0.015
    assert warm_up(recognizer) is None  # once per process
    assert recognizer.population is None  # the caller's recogniser kept nothing
