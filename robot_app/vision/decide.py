"""Decide stage: found or not, by one calibrated confidence.

The confidence combines what the other stages measured at the final pose:

    confidence = 1 / (1 + exp(-(bias + w_f · fitness + w_a · appearance + w_v · visible)))

with `fitness` the search fitness (eqs. 9-11 with occluders taken as hidden, 1.0 = a
perfect match), `appearance` the verification's agreement of the model photo's texture
with the images (-1 to 1) and `visible` its visible fraction. The weights are a logistic
regression fitted on synthetic scenes of present cloths (flat, wrinkled, folded, 45 %
covered by sheets of several colours) against absent ones (other cloths, same-hue-family
cloths), on scene seeds apart from those the benchmark reports on
(`scripts/bench_recognition.py --calibrate --scenes 100`: 226 present scenes recognised
at the right pose, 100 absent; present scenes recognised at a wrong pose were left out),
and the threshold is the one that separated them best there. `threshold` is THE
acceptance threshold of the project: the recogniser's `found`, the pick-and-place loop
and the trials all use it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from pydantic import Field

from robot_app.config import StrictModel


class DecisionSettings(StrictModel):
    """The confidence and its threshold.

    Attributes:
        threshold: confidence from which the cloth counts as found (the one acceptance
            threshold).
        bias, weight_fitness, weight_appearance, weight_visible: the logistic model.
        appearance_without_texture: the appearance a model without texture (a version 1-2
            file) is taken to have; such a model is decided by hue alone.
        appearance_nothing_seen: the appearance when no cell of the texture is in view.
    """

    threshold: float = Field(default=0.54, gt=0.0, lt=1.0)
    bias: float = -15.7
    weight_fitness: float = 3.9
    weight_appearance: float = 11.2
    weight_visible: float = 11.3
    appearance_without_texture: float = Field(default=0.6, ge=-1.0, le=1.0)
    appearance_nothing_seen: float = Field(default=-1.0, ge=-1.0, le=1.0)


@dataclass(frozen=True)
class Decision:
    """The decision at one pose.

    Attributes:
        found: confidence >= threshold.
        confidence: in [0, 1].
    """

    found: bool
    confidence: float


def confidence(
    settings: DecisionSettings, fitness: float, appearance: float, visible_fraction: float, has_texture: bool
) -> float:
    """The calibrated confidence in [0, 1] (see the module docstring); a NaN appearance is
    replaced by `appearance_without_texture` (no texture) or `appearance_nothing_seen`."""
    if math.isnan(appearance):
        appearance = settings.appearance_nothing_seen if has_texture else settings.appearance_without_texture
    z = (
        settings.bias
        + settings.weight_fitness * fitness
        + settings.weight_appearance * appearance
        + settings.weight_visible * visible_fraction
    )
    return 1.0 / (1.0 + math.exp(-max(min(z, 60.0), -60.0)))


def decide(
    settings: DecisionSettings, fitness: float, appearance: float, visible_fraction: float, has_texture: bool
) -> Decision:
    """Found or not at one pose (see `confidence`)."""
    value = confidence(settings, fitness, appearance, visible_fraction, has_texture)
    return Decision(value >= settings.threshold, value)


__all__ = ["Decision", "DecisionSettings", "confidence", "decide"]
