"""What the clear-table job hands each pick's `PickPlaceLoop`: the target's recogniser
held near the survey's depth, the grasp point chosen on the pile (away from every other
cloth) turned into the frame of the loop's own recognition, and the check that the
loop's search found the target where the survey saw it.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from robot_app.arrays import FloatArray
from robot_app.control.anchored_recognizer import AnchoredRecognizer
from robot_app.control.episode import EpisodeAbortError, Outcome, RecognitionRecord
from robot_app.control.grasp_point import PileGrasp, PileGraspSettings, choose_pile_grasp, points_in_mask
from robot_app.control.pick_checks import AttemptState
from robot_app.geometry import invert_transform
from robot_app.vision import ClothModel, Recognizer
from robot_app.vision.identify import Detection


def pick_recognizer(base: Recognizer, target: Detection, window: float | None) -> Recognizer:
    """The target's recogniser, held within `window` [m] of the survey's depth
    (`AnchoredRecognizer`; None: `base` itself)."""
    if window is None:
        return base
    return AnchoredRecognizer(base, float(target.transform_model_to_camera[2, 3]), window)


def pile_grasp(
    target: Detection,
    pose_world: FloatArray,
    model: ClothModel,
    camera_matrix: FloatArray,
    obstacles_xy: FloatArray,
    settings: PileGraspSettings,
    reachable: Callable[[FloatArray], bool] | None = None,
) -> PileGrasp | None:
    """Where on `target` (at `pose_world`) to grasp: seen by the survey and away from every
    other cloth it saw (`obstacles_xy`, (M, 2) [m]; `grasp_point.choose_pile_grasp`), where
    the hand reaches (`reachable`, if given)."""
    seen = points_in_mask(model.points_in, target.transform_model_to_camera, camera_matrix, target.explained)
    return choose_pile_grasp(model, pose_world, seen, obstacles_xy, settings, reachable)


def grasp_in_model(
    grasp_world: FloatArray, transform_model_to_world: FloatArray, model: ClothModel, min_edge_gap: float
) -> FloatArray | None:
    """The job's grasp point (Σ_W [m]) in the frame of the loop's own recognition (a
    symmetric cloth may have been seen turned), on the model plane; None if it lies
    farther than `min_edge_gap` [m] from every point of the recognised cloth."""
    point = (invert_transform(transform_model_to_world) @ np.append(grasp_world, 1.0))[:3]
    point[2] = 0.0
    nearest = float(np.min(np.hypot(*(np.asarray(model.points_in)[:, :2] - point[:2]).T)))
    return point if nearest <= min_edge_gap else None


def check_found_in_place(record: RecognitionRecord, attempt: AttemptState, same_place: float) -> None:
    """Raises `EpisodeAbortError` (`NOT_PRESENT`) if the loop's accepted search result lies
    more than `same_place` [m] from where the survey saw the target (a look-alike?)."""
    distance = float(
        np.hypot(
            record.x - attempt.transform_target_to_world[0, 3],
            record.y - attempt.transform_target_to_world[1, 3],
        )
    )
    if distance > same_place:
        raise EpisodeAbortError(
            Outcome.NOT_PRESENT,
            f"{attempt.name} found {distance * 1000:.0f} mm from where the survey saw it "
            "(another cloth of its look?)",
        )


__all__ = ["check_found_in_place", "grasp_in_model", "pick_recognizer", "pile_grasp"]
