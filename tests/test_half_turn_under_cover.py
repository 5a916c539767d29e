"""A covered striped print: the texture overrules the hue's best pose only where it clearly agrees better."""

from __future__ import annotations

import numpy as np

from robot_app.geometry import make_transform, pose_error, rotation_from_rpy
from robot_app.vision.camera import ModelCamera
from robot_app.vision.photo_model import make_model
from robot_app.vision.recognizer import Recognizer
from robot_app.vision.synthetic import (
    OCCLUDER_COLOURS,
    SyntheticCloth,
    occluder_covering,
    render_model_photo,
    render_stereo_pair,
)
from robot_app.vision.synthetic_camera import CameraRealism
from tests.bench_rig import CAMERA, RIG


def even_stripes(width: float = 0.0075) -> SyntheticCloth:
    """An 18 x 15 cm rectangle of 24 magenta and yellow stripes `width` wide [m]: half-turned
    and shifted by one stripe it matches itself everywhere but at the two short edges."""
    x = (np.arange(180) + 0.5) * 0.001
    magenta = np.floor(x / width).astype(int) % 2 == 0
    texture = np.empty((150, 180, 3), np.uint8)
    texture[:, magenta] = (180, 40, 200)
    texture[:, ~magenta] = (40, 210, 230)
    return SyntheticCloth("even stripes", texture, np.ones((150, 180), bool), (0.18, 0.15))


def test_a_covered_even_striped_print_is_not_taken_half_turned() -> None:
    # Before the margin the most confident alternative won on the decision's log-odds, in
    # which a half-turned placement beside the sheet (more of its footprint visible, the
    # stripes agreeing as well) beat the hue's best: 3 of these 12 scenes came back
    # half-turned. Known miss (seed 10): the search itself ends half-turned (two runs, hue
    # 0.947 against 0.958 at the truth) and the truth is never among the alternatives.
    cloth = even_stripes()
    photo, background = render_model_photo(cloth, ModelCamera(CAMERA, 0.40))
    model = make_model(photo, ModelCamera(CAMERA, 0.40), background, name=cloth.name)
    assert model.symmetry_angles == ()  # the outline tells the half turn, the stripes do not
    half_turned = []
    for seed in range(12):
        rng = np.random.default_rng(seed)
        truth = make_transform(
            rotation_from_rpy(0.0, 0.03, rng.uniform(-np.pi, np.pi)),
            [rng.uniform(-0.05, 0.05), rng.uniform(-0.03, 0.03), 0.58],
        )
        colour = list(OCCLUDER_COLOURS.values())[seed % len(OCCLUDER_COLOURS)]
        cover = occluder_covering(cloth, truth, 0.45, float(rng.uniform(0, 2 * np.pi)), colour_bgr=colour)
        left, right = render_stereo_pair(
            RIG, [(cloth, truth)], occluder=cover, rng=rng, camera=CameraRealism.draw(rng)
        )
        result = Recognizer(model, RIG).recognize(left, right, seed=seed)
        error = pose_error(result.transform_model_to_camera, truth, model.symmetry_angles)
        if abs(error.yaw_deg) > 90:
            half_turned.append(seed)
    assert len(half_turned) <= 1, half_turned
