"""The `recognition` trial kind: a static scene, one recognition, its errors against the truth.

Each trial draws a scene from its seed (`sample_scene`), renders it from the
observation pose, recognises the target's model with the GA and compares the
recognised ^CR T_M with the ground truth, both in the right camera frame:
x, y, z [mm], yaw [deg] (modulo the model's symmetry angles) and tilt [deg] (angle
between the recognised and true cloth normals).
"""

from __future__ import annotations

import functools
import json
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from robot_app.experiments.experiment_config import RecognitionTrialConfig
from robot_app.experiments.image_sources import image_source
from robot_app.experiments.scenes import sample_scene
from robot_app.geometry import PoseError, pose_error, yaw_of
from robot_app.vision.photo_model import ClothModel

NAN = float("nan")


@dataclass(frozen=True)
class RecognitionOutcome:
    """One recognition trial (a CSV row).

    Attributes:
        cloth_id: target cloth No.
        target_present: the target was on the table.
        distractor_id: the second cloth's No., 0 if none.
        occluded_fraction: share of the target hidden.
        found: the recogniser decided the target is there.
        success: found within tolerance when present; not found when absent.
        fitness: best normalised fitness (1.0 = perfect match).
        second_peak_fitness: fitness of the next peak (NaN unless `peaks`).
        true_x_mm, true_y_mm, true_yaw_deg: the target's true pose (NaN if absent).
        error_x_mm, error_y_mm, error_z_mm, error_yaw_deg, error_tilt_deg: pose error
            (NaN if the target is absent).
        generations: GA generations run.
        evaluations: fitness evaluations.
        recognition_time_s: recogniser wall time [s].
        render_time_s: scene rendering wall time [s].
    """

    cloth_id: int
    target_present: bool
    distractor_id: int
    occluded_fraction: float
    found: bool
    success: bool
    fitness: float
    second_peak_fitness: float
    true_x_mm: float
    true_y_mm: float
    true_yaw_deg: float
    error_x_mm: float
    error_y_mm: float
    error_z_mm: float
    error_yaw_deg: float
    error_tilt_deg: float
    generations: int
    evaluations: int
    recognition_time_s: float
    render_time_s: float


def recognizer_settings(overrides: dict[str, Any]) -> Any:
    """The recogniser's settings with the trial config's `recognition` overrides.

    Raises:
        ConfigError: an override names an unknown setting or has a bad value; the
            message names the key under `recognition.`.
    """
    from robot_app.config import apply_overrides, validate
    from robot_app.vision.recognizer import RecognitionSettings

    data = apply_overrides({}, [f"{k}={json.dumps(v)}" for k, v in overrides.items()])
    return validate(RecognitionSettings, data, "recognition settings (config key 'recognition')")


@functools.lru_cache(maxsize=64)
def _recognizer(source_name: str, cloth_id: int, overrides_json: str) -> Any:
    """This process's recogniser of cloth No.`cloth_id` (built once)."""
    from robot_app.vision.recognizer import Recognizer

    source = image_source(source_name)
    settings = recognizer_settings(json.loads(overrides_json))
    return Recognizer(source.model(cloth_id), source.rig, settings)


def recognizer_for(source_name: str, cloth_id: int, overrides: dict[str, Any]) -> Any:
    """A cached `Recognizer` of cloth No.`cloth_id` on the source's rig."""
    return _recognizer(source_name, cloth_id, json.dumps(overrides, sort_keys=True))


def run_recognition_trial(config: RecognitionTrialConfig, scene_index: int, seed: int) -> RecognitionOutcome:
    """One recognition trial; deterministic in (config, scene_index, seed).

    Args:
        config: the trial config at its sweep point.
        scene_index: picks the target cloth (cloth_ids[scene_index % len]).
        seed: seeds the scene, the image noise and the GA.
    """
    rng = np.random.default_rng(seed)
    source = image_source(config.source)
    scene = sample_scene(config.scene, scene_index, rng, source.radii())
    start = time.perf_counter()
    rendered = source.render(scene, rng)
    render_time = time.perf_counter() - start
    recognizer = recognizer_for(config.source, scene.target_id, config.recognition)
    result = recognizer.recognize(
        rendered.left_bgr, rendered.right_bgr, seed=int(rng.integers(2**31)), report_peaks=config.peaks
    )
    model: ClothModel = source.model(scene.target_id)
    truth = rendered.transform_target_to_right
    tolerance_mm, tolerance_deg = config.tolerance_mm, config.tolerance_deg
    if truth is not None:
        error = pose_error(np.asarray(result.transform_model_to_camera), truth, tuple(model.symmetry_angles))
        within = max(abs(error.x_mm), abs(error.y_mm)) <= tolerance_mm and abs(error.yaw_deg) <= tolerance_deg
        success = bool(result.found) and within
        true_xy = 1000.0 * truth[:2, 3]
        true_yaw = float(np.rad2deg(yaw_of(truth[:3, :3])))
    else:
        error = PoseError(NAN, NAN, NAN, NAN, NAN)
        success = not result.found
        true_xy, true_yaw = np.array([NAN, NAN]), NAN
    peaks = list(getattr(result, "peaks", None) or [])
    second = float(peaks[1].fitness) if len(peaks) > 1 else NAN
    return RecognitionOutcome(
        cloth_id=scene.target_id,
        target_present=truth is not None,
        distractor_id=scene.distractor.cloth_id if scene.distractor is not None else 0,
        occluded_fraction=scene.occluded_fraction,
        found=bool(result.found),
        success=success,
        fitness=float(result.fitness),
        second_peak_fitness=second,
        true_x_mm=float(true_xy[0]),
        true_y_mm=float(true_xy[1]),
        true_yaw_deg=true_yaw,
        error_x_mm=error.x_mm,
        error_y_mm=error.y_mm,
        error_z_mm=error.z_mm,
        error_yaw_deg=error.yaw_deg,
        error_tilt_deg=error.tilt_deg,
        generations=int(result.generations),
        evaluations=int(result.evaluations),
        recognition_time_s=float(result.time_s),
        render_time_s=render_time,
    )


def check_recognition_config(config: RecognitionTrialConfig) -> None:
    """Validates the `recognition` overrides against the recogniser's settings up front."""
    recognizer_settings(config.recognition)


__all__ = [
    "RecognitionOutcome",
    "check_recognition_config",
    "recognizer_for",
    "recognizer_settings",
    "run_recognition_trial",
]
