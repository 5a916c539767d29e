"""The single-model decision on a scene of another cloth alone (the identification of
`scripts/bench_recognition.py`, no rivals): what tells the wrong model from the right one.

The pairs are the kinds the bench's identification accepts (docs/history.md, session 19): a
plain model on a patch of its colour on a larger cloth of several colours (the other colours
taken as hidden: its cells agree wherever it is in view, and only its outline says it is part of
another object), and a print on a cloth of its ground colour without the print (the outline
fits, the texture does not). The evidence tells them apart; the default decision weighs it with
one outline and one agreeing weight for every model and still accepts some of them. Session 19's
fit of the print terms (`decide.py`, not adopted: it lost a wrinkled knit under a near-hue sheet
in the simulated cell) rejects them and keeps the cloth's own model found.
"""

from __future__ import annotations

import numpy as np
import pytest

from robot_app.geometry import pose_error
from robot_app.vision.decide import DecisionSettings
from robot_app.vision.recognizer import RecognitionSettings, Recognizer
from robot_app.vision.synthetic import render_stereo_pair
from robot_app.vision.synthetic_camera import CameraRealism
from robot_app.vision.synthetic_prints import extended_cloth
from tests.bench_rig import RIG, bench_flat_pose, catalogue_model
from tests.test_verify import SESSION_19_FIT

RED_PLAIN, DOTS, CYAN_ROUNDED, TSHIRT, PATCHWORK = 0, 5, 6, 8, 11
SCENES = 3
FITTED = RecognitionSettings(decide=DecisionSettings(**SESSION_19_FIT))


def scene(cloth: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Cloth `cloth` alone, flat, at a random pose inside the view (as the bench draws one),
    through a camera drawn from the realistic ranges: (left, right, truth)."""
    rng = np.random.default_rng([19, cloth, seed])
    model = catalogue_model(cloth)
    truth = bench_flat_pose(rng, model)
    left, right = render_stereo_pair(
        RIG, [(extended_cloth(cloth), truth)], rng=rng, camera=CameraRealism.draw(rng)
    )
    return left, right, truth


@pytest.mark.parametrize(
    ("wrong", "cloth"),
    [
        (CYAN_ROUNDED, PATCHWORK),  # a plain model on the patchwork's cyan patches
        (RED_PLAIN, PATCHWORK),  # ... on its red patch
        (PATCHWORK, TSHIRT),  # a mostly plain patchwork on the t-shirt's red and cyan halves
        (DOTS, CYAN_ROUNDED),  # yellow dots on cyan, on a plain cyan cloth: the dots are missing
    ],
)
def test_the_print_terms_reject_the_wrong_model_and_find_the_right_one(wrong: int, cloth: int) -> None:
    wrong_model, own_model = catalogue_model(wrong), catalogue_model(cloth)
    for seed in range(SCENES):
        left, right, truth = scene(cloth, seed)
        result = Recognizer(wrong_model, RIG, FITTED).recognize(left, right, seed=seed)
        own = Recognizer(own_model, RIG, FITTED).recognize(left, right, seed=seed)
        if result.textured_share < 0.5:  # a plain model: its outline is what is wrong
            assert result.outline < 0.8 < own.outline, (seed, result.outline, own.outline)
        else:  # a print: its agreement is what is wrong
            assert result.agreeing < 0.4 < own.agreeing, (seed, result.agreeing, own.agreeing)
        assert not result.found, (seed, result.confidence, result.outline, result.agreeing)
        error = pose_error(own.transform_model_to_camera, truth, own_model.symmetry_angles)
        assert own.found, (seed, own.confidence)
        assert max(abs(error.x_mm), abs(error.y_mm)) < 1.5 and abs(error.yaw_deg) < 1.5, (seed, error)
