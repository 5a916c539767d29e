"""The crumpled test cloth of the decision's calibration scenes (`synthetic_prints.crumpled`)."""

from __future__ import annotations

import cv2
import numpy as np

from robot_app.vision.synthetic_prints import crumpled, extended_cloth


def test_a_crumpled_cloth_keeps_its_frame_and_shows_its_back_over_a_smaller_outline() -> None:
    flat = extended_cloth(2)  # red-yellow stripes: no grey of its own
    cloth = crumpled(flat, np.random.default_rng(4))
    np.testing.assert_allclose(cloth.centroid, flat.centroid)
    assert cloth.size == flat.size
    assert 0.5 * flat.alpha.sum() < cloth.alpha.sum() < 0.9 * flat.alpha.sum()  # two corners over
    hsv = cv2.cvtColor(cloth.texture_bgr, cv2.COLOR_BGR2HSV_FULL)[cloth.alpha]
    back = (hsv[:, 1] < 90) & (hsv[:, 2] > 120)  # the faded back side
    assert 0.1 < back.mean() < 0.6
    again = crumpled(flat, np.random.default_rng(4))
    np.testing.assert_array_equal(again.texture_bgr, cloth.texture_bgr)
