"""A pick's recogniser held to the depth its one-shot recognitions measured.

On a pile, the hue fitness hardly fixes a cloth's depth: a plain red towel lying on
orange stripes looks larger when the orange is taken for red, and tracking, which has no
stereo depth check, lets it creep towards the camera frame by frame (40 mm in 30 frames:
the loop then closes the fingers 60 mm above the cloth). The one-shot recognition, with
its depth range and stereo check, is much better. `AnchoredRecognizer` therefore

- searches one-shot only within `window` of an expected depth (the survey's), and
- keeps every tracked pose within `window` of the depth its last one-shot recognition
  found, carried through the camera's motions between frames (so it holds for a camera
  that moves, also along its axis): a pose beyond is moved back along its viewing ray
  (its image position unchanged) and tracking goes on from there.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray
from robot_app.vision import Recognition, RecognitionSettings, Recognizer


class AnchoredRecognizer(Recognizer):
    """`base`'s model, rig and settings, with the depth held near `depth`.

    Args:
        base: the cloth's recogniser.
        depth: expected depth of Σ_M's origin in the right camera at the search pose [m].
        window: allowed deviation from the expected (then the measured) depth [m].
    """

    def __init__(self, base: Recognizer, depth: float, window: float) -> None:
        if not (depth > 0 and window > 0):
            raise ValueError(f"depth and window must be positive [m], got {depth}, {window}")
        data = base.settings.model_dump()
        data["propose"]["bounds"]["z"] = (depth - window, depth + window)
        super().__init__(base.model, base.rig, RecognitionSettings.model_validate(data))
        self.window = window
        self._anchor: FloatArray | None = None  # Σ_M's origin in the current camera frame [m]

    def recognize(
        self,
        image_left_bgr: npt.NDArray[np.uint8],
        image_right_bgr: npt.NDArray[np.uint8],
        *,
        seed: int | None = None,
        report_peaks: bool = False,
    ) -> Recognition:
        result = super().recognize(image_left_bgr, image_right_bgr, seed=seed, report_peaks=report_peaks)
        self._anchor = result.transform_model_to_camera[:3, 3].copy()
        return result

    def track(
        self,
        image_left_bgr: npt.NDArray[np.uint8],
        image_right_bgr: npt.NDArray[np.uint8],
        transform_motion: FloatArray | None = None,
        *,
        generations: int | None = None,
    ) -> Recognition:
        result = super().track(image_left_bgr, image_right_bgr, transform_motion, generations=generations)
        if self._anchor is None:
            return result
        if transform_motion is not None:
            motion = np.asarray(transform_motion, dtype=float)
            self._anchor = motion[:3, :3] @ self._anchor + motion[:3, 3]
        pose = result.transform_model_to_camera
        expected = float(self._anchor[2])
        if abs(pose[2, 3] - expected) <= self.window:
            return result
        held = np.array(pose, dtype=float)
        target = expected + np.clip(pose[2, 3] - expected, -self.window, self.window)
        held[:3, 3] *= target / pose[2, 3]  # along the viewing ray: same image position
        kept = self.proposer.kept_poses
        if kept is not None:
            self.proposer.keep(held, kept[1:])
        return replace(result, transform_model_to_camera=held)


__all__ = ["AnchoredRecognizer"]
