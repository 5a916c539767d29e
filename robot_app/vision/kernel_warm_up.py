"""Compiling the recogniser's kernels before anything is timed.

The search's kernels are numba functions cached on disk (`__pycache__`), compiled by the
first recognition of a process that finds no cache: on a fresh checkout that takes tens
of seconds. A caller that maps a recognition's measured wall time to cell time (the
loop's `loop.vision_latency: null`) would otherwise charge that compilation to the first
search: on a fresh machine the README's main job held the arm for 128 s and timed out.
`warm_up` runs one search and one tracking step (and a search under a shadow band, for the
shaded pixel codes of `exposure.py`) on a synthetic view of the model (the
model photo's texture, flat, in the middle of the search range) with a recogniser of its
own, so the caller's recogniser (kept poses, random generator) is untouched.
"""

from __future__ import annotations

import numpy as np

from robot_app.arrays import FloatArray
from robot_app.geometry import make_transform
from robot_app.vision.recognition import Recognition
from robot_app.vision.recognizer import Recognizer
from robot_app.vision.synthetic import SyntheticCloth, render_stereo_pair

_done = False  # the kernels are compiled once per process, for every model and rig


def warm_up(recognizer: Recognizer) -> Recognition | None:
    """Compiles the kernels `recognizer` uses, once per process.

    Returns:
        The warm-up's own one-shot recognition of the synthetic view (the model flat at
        `synthetic_pose(recognizer)`), if this call did the work; None if it was done
        before, or the model has no texture to draw a view from (the first recognition
        then compiles).
    """
    global _done
    model = recognizer.model
    if _done or model.texture_bgr is None or model.texture_mask is None or model.texture_from_model is None:
        return None
    affine = np.asarray(model.texture_from_model, dtype=float)
    sx, sy = affine[0, 0], affine[1, 1]  # texture px per metre along Σ_M's x and y
    if sx <= 0 or sy <= 0 or abs(affine[0, 1]) > 1e-9 * sx or abs(affine[1, 0]) > 1e-9 * sy:
        return None  # a turned texture: not worth a general warp here
    height, width = model.texture_mask.shape
    cloth = SyntheticCloth(
        "warm-up",
        model.texture_bgr,
        model.texture_mask,
        (width / sx, height / sy),
        ((affine[0, 2] + 0.5) / sx, (affine[1, 2] + 0.5) / sy),
    )
    left, right = render_stereo_pair(
        recognizer.rig, [(cloth, synthetic_pose(recognizer))], rng=np.random.default_rng(0)
    )
    scratch = Recognizer(model, recognizer.rig, recognizer.settings)
    result = scratch.recognize(left, right, seed=0)
    scratch.track(left, right)
    if recognizer.settings.exposure.shading:  # the shaded pixel codes: a shadow over a third of the view
        band = slice(left.shape[1] // 3, 2 * left.shape[1] // 3)
        for image in (left, right):
            image[:, band] //= 2
        scratch.recognize(left, right, seed=0)
    _done = True
    return result


def synthetic_pose(recognizer: Recognizer) -> FloatArray:
    """^CR T_M of the warm-up's view: flat, in the middle of the search bounds [m]."""
    bounds = recognizer.settings.propose.bounds
    centre = [float(np.mean(bounds.x)), float(np.mean(bounds.y)), float(np.mean(bounds.z))]
    return make_transform(np.eye(3), centre)


__all__ = ["synthetic_pose", "warm_up"]
