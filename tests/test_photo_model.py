"""Tests of the photo model (paper Sec. II-B): ClothModel file round trip, make_model."""

from __future__ import annotations

import numpy as np
import pytest

from robot_app.errors import InputError, ModelError
from robot_app.vision.photo_model import ClothModel


def _handmade_model() -> ClothModel:
    rng = np.random.default_rng(0)
    return ClothModel(
        name="handmade",
        points_in=rng.uniform(-0.1, 0.1, (40, 3)) * [1, 1, 0],
        hues_in=rng.integers(0, 256, 40),
        points_out=rng.uniform(-0.12, 0.12, (30, 3)) * [1, 1, 0],
        background_hue=85.5,
        grasp_point=[0.01, -0.02, 0.0],
        extent=(0.2, 0.15),
        symmetry_angles=(np.pi,),
        metadata={"metres_per_pixel": 0.0007, "source": "none"},
    )


def test_model_file_round_trips_exactly(tmp_path):
    model = _handmade_model()
    path = tmp_path / "m.npz"
    model.save(path)
    loaded = ClothModel.load(path)
    assert loaded == model
    assert loaded.hues_in.dtype == np.uint8
    assert not loaded.points_in.flags.writeable


def test_loading_a_missing_file_is_an_input_error(tmp_path):
    with pytest.raises(InputError, match="not found"):
        ClothModel.load(tmp_path / "nothing.npz")


def test_loading_another_npz_is_a_model_error(tmp_path):
    path = tmp_path / "other.npz"
    np.savez(path, points=np.zeros((3, 3)))
    with pytest.raises(ModelError, match="not a cloth model"):
        ClothModel.load(path)


def test_loading_a_text_file_is_a_model_error(tmp_path):
    path = tmp_path / "text.npz"
    path.write_text("not a zip")
    with pytest.raises(ModelError, match="not a cloth model"):
        ClothModel.load(path)


def test_model_rejects_mismatched_hues():
    with pytest.raises(ModelError, match="hues_in"):
        ClothModel("x", np.zeros((3, 3)), np.zeros(2), np.zeros((0, 3)), 80.0, np.zeros(3), (0, 0))
