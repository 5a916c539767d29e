"""Where to grasp: a point well inside the visible part of the recognised cloth.

The model's own grasp point (the maximum of the distance transform of S_in) may lie
under an occluder. Here the S_in points are projected with the recognised pose into
the right image; those whose image colour matches the model (eq. 9's first case) are
visible, and the chosen point is the visible one farthest from anything that is not
visible cloth (S_out points and hidden S_in points), i.e. a distance transform of the
visible surface.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray
from robot_app.control.cell import StereoCapture
from robot_app.vision import ClothModel, FitnessSettings, StereoRig, colour_codes, colours_match, to_hsv

MIN_VISIBLE_FRACTION = 0.1  # below this the visibility test is not trusted


def visible_grasp_point(
    model: ClothModel,
    rig: StereoRig,
    transform_model_to_camera: npt.ArrayLike,
    capture: StereoCapture,
    params: FitnessSettings | None = None,
) -> FloatArray:
    """Grasp point (3,) [m] in Σ_M, inside the part of the cloth the right camera sees.

    `params` (the recognizer's fitness) say which pixel colour matches a model point
    (`hue_threshold_in`, and which pixels have a tone instead of a hue). Falls back to the
    model's grasp point when too few points are visible.
    """
    params = FitnessSettings() if params is None else params
    T = np.asarray(transform_model_to_camera, dtype=float)
    _, pixels = rig.project_model(T, model.points_in)
    p = params
    codes = colour_codes(to_hsv(capture.right_bgr), p.min_saturation, p.min_value, p.value_split)
    height, width = codes.shape
    u = np.round(pixels[:, 0])
    v = np.round(pixels[:, 1])
    inside = np.isfinite(u) & np.isfinite(v) & (u >= 0) & (u < width) & (v >= 0) & (v < height)
    visible = np.zeros(len(model.points_in), dtype=bool)
    observed = codes[v[inside].astype(int), u[inside].astype(int)]
    visible[inside] = colours_match(observed, model.hues_in[inside], params.hue_threshold_in)
    if visible.mean() < MIN_VISIBLE_FRACTION:
        return np.array(model.grasp_point, dtype=float)
    blockers = np.concatenate([model.points_out[:, :2], model.points_in[~visible, :2]])
    candidates = model.points_in[visible, :2]
    gaps = np.linalg.norm(candidates[:, None, :] - blockers[None, :, :], axis=2).min(axis=1)
    best = candidates[int(np.argmax(gaps))]
    return np.array([best[0], best[1], 0.0])


__all__ = ["visible_grasp_point"]
