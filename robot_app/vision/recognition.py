"""The result of a recognition (`Recognition`) and of each distinct fitness peak (`Peak`)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from robot_app.arrays import FloatArray
from robot_app.geometry import quaternion_xyzw_from_matrix, yaw_of


@dataclass(frozen=True)
class Peak:
    """The best pose of one distinct peak of the fitness.

    Attributes:
        transform_model_to_camera: (4, 4) ^CR T_M.
        fitness: normalised fitness there (nearest pixel).
    """

    transform_model_to_camera: FloatArray
    fitness: float

    @property
    def position(self) -> FloatArray:
        """Origin of Σ_M in Σ_CR [m]."""
        return self.transform_model_to_camera[:3, 3].copy()

    @property
    def yaw(self) -> float:
        """Rotation of Σ_M about the camera z axis [rad]."""
        return yaw_of(self.transform_model_to_camera[:3, :3])


@dataclass(frozen=True)
class Recognition:
    """Result of one recognition.

    Attributes:
        found: the decision: confidence >= `decide.threshold` (and, with rivals, no rival
            explains the region better: `rival`), the intended cloth is in view.
        fitness: normalised hue fitness (`RecognitionSettings.fitness`, eqs. 9-11) of the
            reported pose (1.0 = perfect match).
        transform_model_to_camera: (4, 4) ^CR T_M, Σ_M in the right camera.
        evaluations: poses evaluated (GA, refinement and peaks).
        generations: GA generations run.
        time_s: wall time of the call [s].
        peaks: with `report_peaks`, the best pose of each distinct peak, best first.
        confidence: the calibrated confidence in [0, 1] that `found` decides on.
        visible_fraction: share of the model's texture in view and not under a foreign colour.
        appearance: the texture's agreement with the images, -1 to 1 (NaN: no texture).
        search_fitness: the search fitness (occluders hidden) of the reported pose.
        depth_offset: the stereo depth check's offset of the pose the search ended on
            (`stereo_depth.DepthMeasurement.offset`; a trusted small one has been taken
            into the reported pose) [m]; NaN: not measured.
        interleaved: the verification's share of the visible texture in partly hidden
            cells (`verify.Verification.interleaved`).
        agreeing: the verification's share of compared cells that agree
            (`verify.Verification.agreeing`).
        outline: the verification's share of the outline lying on an edge of the model's
            colour (`verify.Verification.outline`; NaN: not measured).
        occluded: the verification's share of the texture read as behind a plain occluder
            of a hue the model has (`verify.Verification.occluded`; left out of the visible
            fraction and the agreement).
        textured_share: the verification's share of the compared texture on cells compared by
            correlation (`verify.Verification.textured_share`; 0: a plain cloth or no texture).
        rival: the catalogue model that explains the recognised region better (`decide.judge`;
            then `found` is False), "" if none did or none was asked.
        rivals_asked: rivals recognised in the pair for this decision (0: not asked).
    """

    found: bool
    fitness: float
    transform_model_to_camera: FloatArray
    evaluations: int
    generations: int
    time_s: float
    peaks: tuple[Peak, ...] = field(default=())
    confidence: float = 0.0
    visible_fraction: float = 0.0
    appearance: float = float("nan")
    search_fitness: float = 0.0
    depth_offset: float = float("nan")
    interleaved: float = 0.0
    agreeing: float = float("nan")
    outline: float = float("nan")
    occluded: float = 0.0
    textured_share: float = 0.0
    rival: str = ""
    rivals_asked: int = 0

    @property
    def position(self) -> FloatArray:
        """Origin of Σ_M in Σ_CR [m]."""
        return self.transform_model_to_camera[:3, 3].copy()

    @property
    def quaternion_xyzw(self) -> FloatArray:
        """Orientation of Σ_M in Σ_CR, (x, y, z, w) with w >= 0."""
        return quaternion_xyzw_from_matrix(self.transform_model_to_camera[:3, :3])

    @property
    def yaw(self) -> float:
        """Rotation of Σ_M about the camera z axis [rad]."""
        return yaw_of(self.transform_model_to_camera[:3, :3])

    def to_json(self) -> dict[str, object]:
        """The DESIGN.md recognition record (plus `appearance`, `rival` and `rivals_asked` when
        rivals were asked, and `peaks` when there are any)."""
        data: dict[str, object] = {
            "found": bool(self.found),
            "fitness": float(self.fitness),
            "position": [float(v) for v in self.position],
            "quaternion_xyzw": [float(v) for v in self.quaternion_xyzw],
            "yaw_deg": float(np.rad2deg(self.yaw)),
            "frame": "right_camera",
            "generations": int(self.generations),
            "evaluations": int(self.evaluations),
            "time_s": float(self.time_s),
            "confidence": float(self.confidence),
            "visible_fraction": float(self.visible_fraction),
            "appearance": None if np.isnan(self.appearance) else float(self.appearance),
        }
        if self.rivals_asked:
            data["rival"] = self.rival or None
            data["rivals_asked"] = int(self.rivals_asked)
        if self.peaks:
            data["peaks"] = [
                {
                    "fitness": float(p.fitness),
                    "position": [float(v) for v in p.position],
                    "yaw_deg": float(np.rad2deg(p.yaw)),
                }
                for p in self.peaks
            ]
        return data


__all__ = ["Peak", "Recognition"]
