"""The closed-form hand-eye solutions against a known X (and OpenCV's where it is bound)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from robot_app.calibration import HAND_EYE_METHODS, motion_pairs
from robot_app.calibration.hand_eye_methods import rotation_log
from robot_app.geometry import invert_transform, make_transform, rotation_angle_between


def _random_transform(rng: np.random.Generator, angle: float, distance: float) -> np.ndarray:
    return make_transform(cv2.Rodrigues(rng.normal(size=3) * angle)[0], rng.normal(size=3) * distance)


def _views(seed: int, count: int = 12, noise: float = 0.0):
    rng = np.random.default_rng(seed)
    X = _random_transform(rng, 1.0, 0.1)
    W = _random_transform(rng, 1.0, 0.5)
    H = [_random_transform(rng, 0.5, 0.4) for _ in range(count)]
    C = []
    for h in H:
        c = invert_transform(X) @ invert_transform(h) @ W
        C.append(c @ _random_transform(rng, noise, noise) if noise else c)
    return X, H, C


@pytest.mark.parametrize("method", sorted(HAND_EYE_METHODS))
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_exact_motions_give_x_exactly(method, seed) -> None:
    X, H, C = _views(seed)
    estimate = HAND_EYE_METHODS[method](*motion_pairs(H, C))
    np.testing.assert_allclose(estimate, X, atol=1e-9)


@pytest.mark.parametrize("method", sorted(HAND_EYE_METHODS))
def test_noisy_motions_give_x_within_the_noise(method) -> None:
    # 1 mrad and 1 mm of noise on every board pose, 20 views
    X, H, C = _views(5, count=20, noise=1e-3)
    estimate = HAND_EYE_METHODS[method](*motion_pairs(H, C))
    assert np.linalg.norm(estimate[:3, 3] - X[:3, 3]) < 1.5e-3
    assert rotation_angle_between(estimate[:3, :3], X[:3, :3]) < np.deg2rad(0.1)


def test_rotation_log_near_a_half_turn() -> None:
    for axis in ([1.0, 0.0, 0.0], [0.3, -0.5, 0.81], [0.0, 0.6, -0.8]):
        w = (np.pi - 1e-8) * np.asarray(axis) / np.linalg.norm(axis)
        np.testing.assert_allclose(rotation_log(cv2.Rodrigues(w)[0]), w, atol=1e-6)


@pytest.mark.skipif(not hasattr(cv2, "calibrateHandEye"), reason="this OpenCV build has no calibrateHandEye")
@pytest.mark.parametrize(
    ("method", "flag"),
    [
        ("tsai", "CALIB_HAND_EYE_TSAI"),
        ("park", "CALIB_HAND_EYE_PARK"),
        ("daniilidis", "CALIB_HAND_EYE_DANIILIDIS"),
    ],
)
def test_agrees_with_opencv(method, flag) -> None:  # pragma: no cover - OpenCV 4 only
    _, H, C = _views(3, count=15, noise=5e-4)
    R, t = cv2.calibrateHandEye(
        [h[:3, :3] for h in H], [h[:3, 3] for h in H], [c[:3, :3] for c in C], [c[:3, 3] for c in C],
        method=getattr(cv2, flag),
    )  # fmt: skip
    ours = HAND_EYE_METHODS[method](*motion_pairs(H, C))
    assert np.linalg.norm(ours[:3, 3] - np.ravel(t)) < 2e-3
    assert rotation_angle_between(ours[:3, :3], R) < np.deg2rad(0.1)
