"""Tests of vision/hue.py: HSV_FULL conversion and distances on the hue circle."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from robot_app.vision.hue import HUE_RANGE, circular_mean_hue, hue_distance, to_hsv, to_hue


def test_primary_colours_have_full_range_hues():
    bgr = np.array([[[0, 0, 255], [0, 255, 0], [255, 0, 0], [0, 255, 255]]], np.uint8)
    assert to_hue(bgr).tolist() == [[0, 85, 171, 43]]  # red, green, blue, yellow: 0/120/240/60 deg
    assert to_hsv(bgr).shape == (1, 4, 3)


@given(st.integers(0, 255), st.integers(0, 255))
def test_hue_distance_is_a_metric_on_the_circle(a, b):
    d = int(hue_distance(a, b))
    assert 0 <= d <= HUE_RANGE // 2 and d == int(hue_distance(b, a))
    assert d == min((a - b) % 256, (b - a) % 256)


def test_hue_distance_wraps_and_broadcasts():
    assert hue_distance(250, 5) == 11
    assert hue_distance(np.array([0, 128, 255]), 0).tolist() == [0, 128, 1]


def test_circular_mean_across_zero():
    assert circular_mean_hue([250, 6]) == pytest.approx(0.0, abs=1e-9)
    assert circular_mean_hue([10, 20, 30]) == pytest.approx(20.0)
    with pytest.raises(ValueError):
        circular_mean_hue([])


@pytest.mark.parametrize(
    "image", [np.zeros((4, 4), np.uint8), np.zeros((4, 4, 3)), np.zeros((4, 4, 4), np.uint8)]
)
def test_non_bgr_arrays_are_programming_errors(image):
    # the user's images are checked where they enter (pixel_codes.checked_image, make_model)
    with pytest.raises(ValueError, match="uint8 BGR"):
        to_hue(image)
