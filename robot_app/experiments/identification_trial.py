"""The identification trial: model No.i searched in a scene holding only cloth No.j."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from robot_app.experiments.experiment_config import RecognitionTrialConfig
from robot_app.experiments.image_sources import image_source
from robot_app.experiments.recognition_trial import recognizer_for
from robot_app.experiments.scenes import sample_scene


@dataclass(frozen=True)
class IdentificationOutcome:
    """Model No.`model_id` searched in a scene holding only cloth No.`scene_id`.

    Attributes:
        model_id: the model searched for.
        scene_id: the cloth on the table.
        found: the recogniser's decision.
        fitness: best normalised fitness.
        recognition_time_s: recogniser wall time [s].
    """

    model_id: int
    scene_id: int
    found: bool
    fitness: float
    recognition_time_s: float


def run_identification_trial(
    config: RecognitionTrialConfig, scene_index: int, seed: int
) -> IdentificationOutcome:
    """Trial k of the matrix: model ids[k // n] in a scene with cloth ids[k % n] alone."""
    ids = config.scene.cloth_ids
    n = len(ids)
    model_id, scene_id = ids[(scene_index // n) % n], ids[scene_index % n]
    rng = np.random.default_rng(seed)
    source = image_source(config.source)
    alone = config.scene.model_copy(update={"cloth_ids": [scene_id]})
    scene = sample_scene(alone, 0, rng, source.radii())
    rendered = source.render(scene, rng)
    recognizer = recognizer_for(config.source, model_id, config.recognition)
    result = recognizer.recognize(rendered.left_bgr, rendered.right_bgr, seed=int(rng.integers(2**31)))
    found, fitness = bool(result.found), float(result.fitness)
    return IdentificationOutcome(model_id, scene_id, found, fitness, float(result.time_s))


__all__ = ["IdentificationOutcome", "run_identification_trial"]
