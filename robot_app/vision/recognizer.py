"""Recognition: a cloth model, a stereo rig and a stereo pair -> the cloth's pose, or "not there".

One-shot recognition (`Recognizer.recognize`) runs the GA of the paper from a random
population: the first `coarse_generations` score every `coarse_stride`-th model point
(a cheaper estimate of the same fitness), the rest score all points. A local refinement
then polishes the GA's best pose: a compass search over the continuous pose (position
along the camera axes, rotation about them through the model origin) that halves its
steps when no neighbour is better, on the sub-pixel (bilinear score) fitness, which is
smooth where the paper's nearest-pixel fitness is a staircase. Its evaluations are
counted. `found` compares the paper's (nearest-pixel) fitness at the final pose with the
acceptance threshold.

Multi-step recognition (`Recognizer.track`) keeps the GA population between frames,
moves it by the camera motion and evolves a few generations per frame (Sec. II-E, DESIGN).
With `report_peaks`, further GA runs that ignore the neighbourhoods of the peaks found so
far report the best pose of each distinct peak (e.g. each cloth in view, Fig. 13 e-f).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
from pydantic import Field

from robot_app.config import StrictModel
from robot_app.geometry import FloatArray, quaternion_xyzw_from_matrix, yaw_of
from robot_app.vision.camera import StereoRig
from robot_app.vision.fitness import FitnessEvaluator, FitnessParams
from robot_app.vision.ga import GASettings, GeneticAlgorithm, SearchBounds, encode, parameters_from_transforms
from robot_app.vision.photo_model import ClothModel


class RefinementSettings(StrictModel):
    """Compass search after the GA (set `enabled: false` for the paper's GA alone).

    Attributes:
        enabled: refine one-shot results.
        in_tracking: refine tracking results too.
        subpixel: search on the bilinear-score fitness (else the nearest-pixel one).
        step_position: first step along camera x and y [m].
        step_depth: first step along the camera axis [m].
        step_angle_deg: first rotation step about each camera axis [deg].
        min_step_position: stop when the x-y step falls below this [m].
        max_iterations: cap on search iterations (12 poses each).
        tracking_iterations: cap when tracking.
    """

    enabled: bool = True
    in_tracking: bool = True
    subpixel: bool = True
    step_position: float = Field(default=0.002, gt=0.0)
    step_depth: float = Field(default=0.006, gt=0.0)
    step_angle_deg: float = Field(default=1.0, gt=0.0)
    min_step_position: float = Field(default=0.0001, gt=0.0)
    max_iterations: int = Field(default=40, ge=1)
    tracking_iterations: int = Field(default=6, ge=1)


class RecognitionSettings(StrictModel):
    """Everything the recognizer needs besides the model and rig (one config section).

    Attributes:
        fitness: eqs. 9-11 constants.
        ga: GA parameters.
        bounds: search space in Σ_CR.
        acceptance_threshold: normalised fitness from which the cloth counts as found.
        coarse_generations: first generations scored on a point subset.
        coarse_stride: every n-th model point scored in the coarse generations.
        fine_stride: every n-th model point scored in the other generations (the
            refinement and the reported fitness always use every point).
        refinement: the local search after the GA.
        max_peaks: peaks reported with `report_peaks`.
        peak_separation: x-y distance between distinct peaks [m].
        peak_min_fitness: weaker peaks are not reported.
    """

    fitness: FitnessParams = FitnessParams()
    ga: GASettings = GASettings()
    bounds: SearchBounds = SearchBounds()
    acceptance_threshold: float = Field(default=0.6, ge=0.0, le=1.0)
    coarse_generations: int = Field(default=60, ge=0)
    coarse_stride: int = Field(default=4, ge=1)
    fine_stride: int = Field(default=1, ge=1)
    refinement: RefinementSettings = RefinementSettings()
    max_peaks: int = Field(default=3, ge=1)
    peak_separation: float = Field(default=0.06, gt=0.0)
    peak_min_fitness: float = Field(default=0.2, ge=0.0, le=1.0)


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
        found: fitness >= the acceptance threshold: the intended cloth is in view.
        fitness: normalised fitness of the reported pose (1.0 = perfect match).
        transform_model_to_camera: (4, 4) ^CR T_M, Σ_M in the right camera.
        evaluations: poses evaluated (GA, refinement and peaks).
        generations: GA generations run.
        time_s: wall time of the call [s].
        peaks: with `report_peaks`, the best pose of each distinct peak, best first.
    """

    found: bool
    fitness: float
    transform_model_to_camera: FloatArray
    evaluations: int
    generations: int
    time_s: float
    peaks: tuple[Peak, ...] = field(default=())

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
        """The DESIGN.md recognition record (plus `peaks` when there are any)."""
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
        }
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


class Recognizer:
    """Recognises one cloth model in stereo pairs; keeps the GA population for tracking."""

    def __init__(
        self, model: ClothModel, rig: StereoRig, settings: RecognitionSettings | None = None
    ) -> None:
        self.model = model
        self.rig = rig
        self.settings = settings if settings is not None else RecognitionSettings()
        self.evaluator = FitnessEvaluator(model, rig, self.settings.fitness)
        self.reset()

    @property
    def population(self) -> FloatArray | None:
        """(P, 4, 4) poses of the kept GA population (None before the first recognition)."""
        if self._ga is None or self._ga.population is None:
            return None
        return self._ga.transforms(self._ga.population)

    def reset(self) -> None:
        """Forgets the tracked population and reseeds the random generator."""
        self._rng = np.random.default_rng(self.settings.ga.seed)
        self._ga: GeneticAlgorithm | None = None

    def recognize(
        self,
        image_left_bgr: npt.NDArray[np.uint8],
        image_right_bgr: npt.NDArray[np.uint8],
        *,
        seed: int | None = None,
        report_peaks: bool = False,
    ) -> Recognition:
        """One-shot recognition from a random population.

        Args:
            image_left_bgr, image_right_bgr: the stereo pair, (H, W, 3) uint8 of the rig's size.
            seed: seed of this run (default: the recognizer's own generator).
            report_peaks: also find the best pose of each distinct peak.

        Raises:
            InputError: images of the wrong type or size.
        """
        start = time.perf_counter()
        s = self.settings
        self.evaluator.update(image_left_bgr, image_right_bgr)
        before = self.evaluator.evaluations
        rng = np.random.default_rng(seed) if seed is not None else self._rng
        peaks: list[Peak] = []
        generations = 0
        for _ in range(s.max_peaks if report_peaks else 1):
            centres = np.array([p.position[:2] for p in peaks]).reshape(-1, 2)
            ga = self._search(rng, centres)
            generations += s.ga.generations
            pose, fitness = self._finish(ga, s.refinement.max_iterations, s.refinement.enabled, centres)
            if peaks and fitness < s.peak_min_fitness:
                break
            peaks.append(Peak(pose, fitness))
            if len(peaks) == 1:
                self._ga = ga  # tracking continues from the target's population
        best = peaks[0]
        return Recognition(
            found=best.fitness >= s.acceptance_threshold,
            fitness=best.fitness,
            transform_model_to_camera=best.transform_model_to_camera,
            evaluations=self.evaluator.evaluations - before,
            generations=generations,
            time_s=time.perf_counter() - start,
            peaks=tuple(sorted(peaks, key=lambda p: -p.fitness)) if report_peaks else (),
        )

    def track(
        self,
        image_left_bgr: npt.NDArray[np.uint8],
        image_right_bgr: npt.NDArray[np.uint8],
        transform_motion: FloatArray | None = None,
        *,
        generations: int | None = None,
    ) -> Recognition:
        """Multi-step recognition: continues from the last population (a one-shot run if none).

        Args:
            image_left_bgr, image_right_bgr: the new stereo pair.
            transform_motion: (4, 4) ^CR_new T_CR_old, the previous right-camera frame in
                the new one; every individual moves by it. None: the camera did not move.
            generations: GA generations this frame (default: settings.ga.tracking_generations).
        """
        if self._ga is None:
            return self.recognize(image_left_bgr, image_right_bgr)
        start = time.perf_counter()
        s = self.settings
        self.evaluator.update(image_left_bgr, image_right_bgr)
        before = self.evaluator.evaluations
        result = self._ga.track(transform_motion, generations)
        refine = s.refinement.enabled and s.refinement.in_tracking
        pose, fitness = self._finish(self._ga, s.refinement.tracking_iterations, refine)
        return Recognition(
            found=fitness >= s.acceptance_threshold,
            fitness=fitness,
            transform_model_to_camera=pose,
            evaluations=self.evaluator.evaluations - before,
            generations=result.generations,
            time_s=time.perf_counter() - start,
        )

    def _search(self, rng: np.random.Generator, centres: FloatArray) -> GeneticAlgorithm:
        """A GA run (coarse generations on a point subset, then all points), away from `centres`."""
        s = self.settings

        def fitness(stride: int) -> Callable[[FloatArray], FloatArray]:
            def f(transforms: FloatArray) -> FloatArray:
                scores = self.evaluator.evaluate(transforms, stride=stride)
                scores[self._excluded(transforms, centres)] = -1.0
                return scores

            return f

        coarse = min(s.coarse_generations, s.ga.generations)
        ga = GeneticAlgorithm(fitness(s.coarse_stride), s.bounds, s.ga, rng)
        ga.run(coarse)
        ga.fitness = fitness(s.fine_stride)
        ga.evolve(s.ga.generations - coarse)
        return ga

    def _excluded(self, transforms: FloatArray, centres: FloatArray) -> npt.NDArray[np.bool_]:
        """Poses within `peak_separation` (x-y) of a peak already reported."""
        if not len(centres):
            return np.zeros(len(transforms), dtype=bool)
        d = np.linalg.norm(transforms[:, None, :2, 3] - centres[None], axis=2).min(axis=1)
        return np.asarray(d < self.settings.peak_separation)

    def _finish(
        self, ga: GeneticAlgorithm, iterations: int, refine: bool, centres: FloatArray | None = None
    ) -> tuple[FloatArray, float]:
        """Best pose of the population, refined (and injected back), with its paper fitness."""
        if ga.population is None or ga.scores is None:
            raise RuntimeError("the GA has no population")  # unreachable: _search/track ran it
        best = int(np.argmax(ga.scores))
        pose = ga.transforms(ga.population[best : best + 1])[0]
        if not refine:
            return pose, float(ga.scores[best])
        pose = self._refine(pose, iterations, np.zeros((0, 2)) if centres is None else centres)
        fitness = float(self.evaluator.evaluate(pose)[0])
        if fitness >= ga.scores[best]:  # the population keeps the polished pose for tracking
            worst = int(np.argmin(ga.scores))
            ga.population[worst] = encode(parameters_from_transforms(pose), ga.bounds, ga.settings.gray_code)[
                0
            ]
            ga.scores[worst] = fitness
        return pose, fitness

    def _refine(self, pose: FloatArray, iterations: int, centres: FloatArray) -> FloatArray:
        """Compass search on (x, y, z, rotation about camera x, y, z), halving steps on failure.

        Neighbours outside the search bounds or near `centres` (peaks already reported)
        are not evaluated.
        """
        r = self.settings.refinement
        steps = np.array(
            [r.step_position, r.step_position, r.step_depth, *[np.deg2rad(r.step_angle_deg)] * 3]
        )
        ranges = self.settings.bounds.gene_ranges()  # the refinement stays inside the search space
        current = float(self.evaluator.evaluate(pose, subpixel=r.subpixel)[0])
        for _ in range(iterations):
            candidates = _neighbours(pose, steps)
            parameters = parameters_from_transforms(candidates)
            inside = np.all((parameters >= ranges[:, 0]) & (parameters <= ranges[:, 1]), axis=1)
            inside &= ~self._excluded(candidates, centres)
            if not inside.any():
                break
            scores = np.full(len(candidates), -np.inf)
            scores[inside] = self.evaluator.evaluate(candidates[inside], subpixel=r.subpixel)
            best = int(np.argmax(scores))
            if scores[best] > current:
                pose, current = candidates[best], float(scores[best])
                continue
            steps /= 2.0
            if steps[0] < r.min_step_position:
                break
        return pose


def _neighbours(pose: FloatArray, steps: FloatArray) -> FloatArray:
    """The 12 poses one step away along each of the six coordinates, both ways."""
    out = np.repeat(pose[None], 12, axis=0)
    for k in range(3):
        out[2 * k, k, 3] += steps[k]
        out[2 * k + 1, k, 3] -= steps[k]
    for k in range(3):
        for sign, index in ((1.0, 6 + 2 * k), (-1.0, 7 + 2 * k)):
            axis = np.zeros(3)
            axis[k] = sign * steps[3 + k]
            out[index, :3, :3] = _rotation_vector(axis) @ pose[:3, :3]
    return out


def _rotation_vector(omega: FloatArray) -> FloatArray:
    """Rodrigues: rotation by |omega| [rad] about omega."""
    angle = float(np.linalg.norm(omega))
    k = omega / angle
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


__all__ = ["Peak", "Recognition", "RecognitionSettings", "Recognizer", "RefinementSettings"]
