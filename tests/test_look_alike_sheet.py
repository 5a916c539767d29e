"""The search past a look-alike: a plain sheet of the print's own hue family is not the cloth."""

from __future__ import annotations

import numpy as np

from robot_app.geometry import make_transform, pose_error, rotation_about_z
from robot_app.vision.camera import ModelCamera
from robot_app.vision.photo_model import make_model
from robot_app.vision.recognizer import Recognizer
from robot_app.vision.synthetic import (
    SyntheticCloth,
    occluder_covering,
    render_model_photo,
    render_stereo_pair,
)
from robot_app.vision.synthetic_camera import CameraRealism
from robot_app.vision.synthetic_prints import extended_cloth
from tests.bench_rig import CAMERA, RIG

AMBER_CAT = 15  # an amber photograph on an ellipse


def mean_colour(cloth: SyntheticCloth) -> tuple[int, int, int]:
    """The print's mean colour (b, g, r): a hue inside the print's own hue band."""
    b, g, r = np.round(cloth.texture_bgr[cloth.alpha].mean(axis=0)).astype(int)
    return int(b), int(g), int(r)


def plain_like(cloth: SyntheticCloth) -> SyntheticCloth:
    """A plain sheet of the print's outline and mean colour: its hue, none of its texture."""
    texture = np.empty_like(cloth.texture_bgr)
    texture[:] = mean_colour(cloth)
    return SyntheticCloth("look-alike", texture, cloth.alpha, cloth.size)


def scene(model_cloth: SyntheticCloth, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The print 45 % under a plain sheet of its own colour, and beside it (about 22 cm
    away) a plain sheet of its outline and colour: (left, right, truth, the sheet's pose)."""
    rng = np.random.default_rng(seed)
    truth = make_transform(
        rotation_about_z(rng.uniform(-np.pi, np.pi)), [-0.1, rng.uniform(-0.03, 0.03), 0.58]
    )
    decoy = make_transform(
        rotation_about_z(rng.uniform(-np.pi, np.pi)), [0.12, rng.uniform(-0.03, 0.03), 0.58]
    )
    direction = float(rng.uniform(0, 2 * np.pi))
    cover = occluder_covering(model_cloth, truth, 0.45, direction, colour_bgr=mean_colour(model_cloth))
    left, right = render_stereo_pair(
        RIG,
        [(model_cloth, truth), (plain_like(model_cloth), decoy)],
        occluder=cover,
        rng=rng,
        camera=CameraRealism.draw(rng),
    )
    return left, right, truth, decoy


def test_a_covered_print_is_found_past_plain_sheets_of_its_own_hue() -> None:
    # the look-alike fits the hue better than the covered print (0.99 against 0.93): the
    # search ends on it first, and only the texture says it is not the print. Before the
    # look-alike rule every scene came back on the look-alike (0 of 8). Known miss (seed
    # 0): a later run ends half on the print and half on the covering sheet, 22 mm off,
    # which is a look-alike too, and avoiding it (60 mm, any yaw) avoids the print.
    cloth = extended_cloth(AMBER_CAT)
    photo, background = render_model_photo(cloth, ModelCamera(CAMERA, 0.40))
    model = make_model(photo, ModelCamera(CAMERA, 0.40), background, name=cloth.name)
    right_pose = []
    for seed in range(8):
        left, right, truth, decoy = scene(cloth, seed)
        recognizer = Recognizer(model, RIG)
        result = recognizer.recognize(left, right, seed=seed)
        error = pose_error(result.transform_model_to_camera, truth, model.symmetry_angles)
        right_pose.append(
            abs(error.x_mm) < 6 and abs(error.y_mm) < 6 and abs(error.yaw_deg) < 6 and result.found
        )
        hue = recognizer.proposer.fitness()(np.array([truth, decoy]))
        assert hue[1] > hue[0]  # the look-alike fits the hue better
    # seeded, but the search is chaotic in the last bits of its arithmetic: 7 of 8 on the machines
    # before session 14, 6 of 8 on its AVX-512 one (seed 0 and one more); 0 of 8 before the rule
    assert sum(right_pose) >= 6, right_pose
