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
moves it by the camera motion and evolves a few generations per frame (Sec. II-E; docs/architecture.md).
With `report_peaks`, further GA runs that ignore the neighbourhoods of the peaks found so
far report the best pose of each distinct peak (e.g. each cloth in view, Fig. 13 e-f).
"""

from __future__ import annotations

import functools
import gc
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, TypeVar, cast

import numpy as np
import numpy.typing as npt
from pydantic import Field

from robot_app.arrays import FloatArray
from robot_app.config import StrictModel
from robot_app.geometry import (
    quaternion_xyzw_from_matrix,
    rotation_about_z,
    wrap_angle,
    yaw_of,
)
from robot_app.vision.camera import StereoRig
from robot_app.vision.fitness import AvoidedPoses, FitnessEvaluator, FitnessSettings, KernelFitness
from robot_app.vision.ga import GASettings, GeneticAlgorithm, SearchBounds, encode, parameters_from_transforms
from robot_app.vision.photo_model import ClothModel
from robot_app.vision.refinement import (
    PoseLimits,
    RefinementSettings,
    cma_search_compiled,
    compass_search_compiled,
)

_Method = TypeVar("_Method", bound=Callable[..., "Recognition"])


class RecognitionSettings(StrictModel):
    """Everything the recognizer needs besides the model and rig (one config section).

    Attributes:
        fitness: eqs. 9-11 constants; by default pixels with saturation or value below 40
            have a tone (DARK / LIGHT) instead of a hue, the thresholds `ModelSettings`
            gives a model's black and white parts (with every pixel hued, as in the paper,
            a white or black pixel reads hue 0, red, and matches a red cloth).
        ga: GA parameters.
        bounds: search space in Σ_CR.
        acceptance_threshold: normalised fitness from which the cloth counts as found. 0.85:
            over three 12 x 12 model-against-cloth matrices on the synthetic renderer the
            intended cloth scored >= 0.87 and another cloth <= 0.83 (red_cyan_tshirt's
            model on the patchwork, which shares its red and cyan). A cloth partly
            hidden under a sheet scores less (45 % hidden: ~0.55); configs for scenes
            with occluders lower it (configs/pick_place.yaml: 0.45).
        coarse_generations: first generations scored on a point subset.
        coarse_stride: every n-th model point scored in the coarse generations.
        fine_stride: every n-th model point scored in the other generations and while
            tracking (the refinement and the reported fitness always use every point).
        refinement: the local search after the GA.
        max_peaks: peaks reported with `report_peaks`.
        peak_separation: x-y distance between distinct peaks [m].
        peak_min_fitness: weaker peaks are not reported.
        search_out_foreign: the score the search gives an S_out point on a pixel of a
            foreign hue (neither background nor any of the model's hues: an occluder,
            another cloth); None searches with the paper's `score_out_other`. The
            reported fitness and `found` always use `fitness` (the paper's eqs.).
        search_hidden_foreign: the search takes points on a foreign hue as hidden (see
            `FitnessSettings.hidden_foreign`), so that a cloth partly under a sheet of another
            colour matches fully at its true pose; needs `fitness.normalisation` "view".
            On the synthetic bench with 45 % covered, without it the search preferred a
            smaller, farther pose squeezed onto the visible part (median z error +34 mm).
        search_hidden_penalty: the search's `FitnessSettings.hidden_penalty`.
        search_min_view_fraction: the search's `FitnessSettings.min_view_fraction`. 0.3: a
            cloth 45 % under a sheet that also reaches past an image edge has less than
            half of its points seen, and with the floor at 0.5 its true pose scored
            0.81-0.88 while a smaller, farther pose squeezed onto the visible part scored
            0.95 (5 of 96 occluded scenes on the synthetic bench, 15-56 mm off).
        search_out_other: the search's score of an S_out point on a pixel of the model's
            own hues (the model sits inside a cloth like it); None: `fitness.score_out_other`.
            -1.25 balances the outermost S_out ring against the outermost S_in ring, so
            the smoothed peak is not skewed towards a smaller (farther) model: on the
            synthetic bench the median depth error fell from 4.2 to 1.0 mm.
        candidates_per_island: distinct poses (x-y farther apart than `candidate_separation`
            or yaws farther apart than 20°) taken from each island's final population.
        candidate_separation: x-y distance that makes two candidates distinct [m].
        candidate_depths: offsets along the ray through the model origin at which every
            candidate is also scored [m].
        refine_candidates: the best candidates (after adding each one's half turn about
            the cloth normal) that the refinement polishes for
            `refinement.candidate_iterations` before the best goes on.
        restarts: further island runs while the best search fitness is below
            `restart_below` and the best peak is not confirmed (two runs ended on it and
            it scores at least `confirm_above`); the best of all runs is kept. A poor
            result is more often a missed peak than a poor view, while a partly hidden
            cloth scores below `restart_below` at its true pose but ends there twice. An
            absent cloth costs all these runs. With 2 restarts, 2 of 120 plain synthetic
            scenes (checks, diagonals) ended all three runs on a wrong peak (0.85, 0.89);
            4 found both. Later runs search away (`peak_separation`) from a poor peak
            (below `confirm_above`) that two runs ended on: a plain cyan cloth drew all
            five runs of a dotted cyan model (0.66) from its narrow target peak (0.99).
            One that scores at least `avoid_any_yaw_below` is a near miss on the cloth
            itself, so only yaws within `avoid_yaw_deg` of it are avoided (its half or
            quarter turn may be the true pose): a quarter turn of a check cloth 45 %
            under the sheet (0.90) drew 6 of 8 seeds from its true pose (0.95, 19 mm
            away), 3 of 8 with this; avoided at every yaw, the true pose was too.
            (Restarting also when the reported fitness is below `acceptance_threshold`,
            away from that peak, took a model off another cloth it shared a hue with, but
            a cloth 45 % hidden reports below it at its true pose: 4 of 100 such scenes
            ended wrong.)
        restart_below: search fitness under which a restart is run.
        confirm_above: the search fitness from which a peak two runs ended on is taken
            (wrong peaks that two runs ended on scored 0.66-0.85; a cloth 45 % hidden
            scores 0.95-0.98 at its true pose).
        avoid_yaw_deg, avoid_any_yaw_below: see `restarts`.
        tracking_population: individuals kept between tracking frames (the best ones).
        tracking_window: half-width of the x-y search window around the motion-predicted
            pose while tracking [m].
        tracking_depth_window: half-width of the depth window while tracking [m]; the
            window moves with the camera, so a descending camera keeps its cloth.
        pause_garbage_collector: switch Python's cyclic garbage collector off during a
            recognition (it runs again afterwards; a recognition makes no reference
            cycles, so nothing piles up). In a process holding many objects a full
            collection that falls inside a recognition costs 10-20 ms: the one-shot
            median on the benchmark went from 62 to 45 ms.
    """

    fitness: FitnessSettings = FitnessSettings(min_saturation=40, min_value=40)
    ga: GASettings = GASettings()
    bounds: SearchBounds = SearchBounds()
    acceptance_threshold: float = Field(default=0.85, ge=0.0, le=1.0)
    coarse_generations: int = Field(default=60, ge=0)
    coarse_stride: int = Field(default=4, ge=1)
    fine_stride: int = Field(default=3, ge=1)
    refinement: RefinementSettings = RefinementSettings()
    max_peaks: int = Field(default=3, ge=1)
    peak_separation: float = Field(default=0.06, gt=0.0)
    peak_min_fitness: float = Field(default=0.2, ge=0.0, le=1.0)
    search_out_foreign: float | None = 0.0
    search_hidden_foreign: bool = True
    search_hidden_penalty: float = Field(default=0.05, ge=0.0, le=1.0)
    search_min_view_fraction: float = Field(default=0.3, gt=0.0, le=1.0)
    search_out_other: float | None = -1.25
    candidates_per_island: int = Field(default=2, ge=1)
    candidate_separation: float = Field(default=0.01, gt=0.0)
    candidate_depths: tuple[float, ...] = (-0.03, -0.015, 0.0, 0.015, 0.03)
    refine_candidates: int = Field(default=3, ge=1)
    restarts: int = Field(default=4, ge=0)
    restart_below: float = Field(default=0.97, ge=0.0, le=1.0)
    confirm_above: float = Field(default=0.94, ge=0.0, le=1.0)
    avoid_yaw_deg: float = Field(default=45.0, gt=0.0, le=90.0)
    avoid_any_yaw_below: float = Field(default=0.8, ge=0.0, le=1.0)
    tracking_population: int = Field(default=24, ge=4)
    tracking_window: float = Field(default=0.02, gt=0.0)
    tracking_depth_window: float = Field(default=0.03, gt=0.0)
    pause_garbage_collector: bool = True


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
        """The docs/architecture.md recognition record (plus `peaks` when there are any)."""
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


def _collector_paused(method: _Method) -> _Method:
    """Runs a `Recognizer` method with Python's cyclic garbage collector off (if it was on
    and the recognizer's `settings.pause_garbage_collector` says so)."""

    @functools.wraps(method)
    def paused(self: Recognizer, *args: Any, **kwargs: Any) -> Recognition:
        if not self.settings.pause_garbage_collector or not gc.isenabled():
            return method(self, *args, **kwargs)
        gc.disable()
        try:
            return method(self, *args, **kwargs)
        finally:
            gc.enable()

    return cast(_Method, paused)


class Recognizer:
    """Recognises one cloth model in stereo pairs; keeps the best poses for tracking."""

    def __init__(
        self, model: ClothModel, rig: StereoRig, settings: RecognitionSettings | None = None
    ) -> None:
        self.model = model
        self.rig = rig
        self.settings = settings if settings is not None else RecognitionSettings()
        s = self.settings
        search = s.fitness.model_copy(
            update={
                "score_out_foreign": s.search_out_foreign,
                "hidden_foreign": s.search_hidden_foreign and s.fitness.normalisation == "view",
                "hidden_penalty": s.search_hidden_penalty,
                "min_view_fraction": s.search_min_view_fraction,
                "score_out_other": s.fitness.score_out_other
                if s.search_out_other is None
                else s.search_out_other,
            }
        )
        self.evaluator = FitnessEvaluator(model, rig, s.fitness, search)
        self._tracking_ga = s.ga.model_copy(
            update={
                "population": s.tracking_population,
                "elite": min(s.ga.elite, s.tracking_population - 1),
                "islands": 1,
            }
        )
        self.reset()

    @property
    def population(self) -> FloatArray | None:
        """(P, 4, 4) poses kept for tracking, best first (None before the first recognition)."""
        return None if self._poses is None else self._poses.copy()

    def reset(self) -> None:
        """Forgets the tracked poses and reseeds the random generator."""
        self._rng = np.random.default_rng(self.settings.ga.seed)
        self._poses: FloatArray | None = None

    @_collector_paused
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
            centres = np.array([[*p.position[:2], np.nan] for p in peaks]).reshape(-1, 3)
            ga = self._search(rng, centres)
            generations += s.ga.generations
            pose, fitness, search_fitness = self._finish(ga, s.refinement.enabled, rng, centres)
            ends = [pose]  # where each run ended
            avoid = centres  # and poor peaks that draw the runs
            for _ in range(s.restarts):
                if search_fitness >= s.restart_below:
                    break
                again = self._search(rng, avoid)
                generations += s.ga.generations
                result = self._finish(again, s.refinement.enabled, rng, avoid)
                ends.append(result[0])
                if result[2] > search_fitness:
                    ga, (pose, fitness, search_fitness) = again, result
                twice = sum(_same_peak(pose, end, s.candidate_separation) for end in ends) >= 2
                if twice and search_fitness >= s.confirm_above:
                    break  # two runs ended on the best peak, and it is a good one: confirmed
                last = result[0]
                drawn = sum(_same_peak(last, end, s.candidate_separation) for end in ends) >= 2
                if drawn and result[2] < s.confirm_above:
                    yaw = yaw_of(last[:3, :3]) if result[2] >= s.avoid_any_yaw_below else np.nan
                    avoid = np.vstack([avoid, [*last[:2, 3], yaw]])  # a poor peak that draws the runs
            if peaks and fitness < s.peak_min_fitness:
                break
            peaks.append(Peak(pose, fitness))
            if len(peaks) == 1:
                self._keep(ga)  # tracking continues from the target's best poses
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

    @_collector_paused
    def track(
        self,
        image_left_bgr: npt.NDArray[np.uint8],
        image_right_bgr: npt.NDArray[np.uint8],
        transform_motion: FloatArray | None = None,
        *,
        generations: int | None = None,
    ) -> Recognition:
        """Multi-step recognition: continues from the kept poses (a one-shot run if none).

        The kept poses (the best `tracking_population` of the last frame) move by the
        camera motion; a GA of that size then evolves them inside a window of
        ±`tracking_window` (x, y) and ±`tracking_depth_window` (z) around the best moved
        pose, with the full yaw and the configured tilt, and the refinement polishes
        the best for at most `refinement.tracking_iterations` iterations.

        Args:
            image_left_bgr, image_right_bgr: the new stereo pair.
            transform_motion: (4, 4) ^CR_new T_CR_old, the previous right-camera frame in
                the new one; every kept pose moves by it. None: the camera did not move.
            generations: GA generations this frame (default: settings.ga.tracking_generations).

        Raises:
            InputError: images of the wrong type or size, or a motion that is not a 4x4
                transform.
        """
        if self._poses is None:
            return self.recognize(image_left_bgr, image_right_bgr)
        start = time.perf_counter()
        s = self.settings
        count = s.ga.tracking_generations if generations is None else generations
        if count < 0:
            raise ValueError(f"generations must be >= 0, got {count}")
        poses = self._poses
        if transform_motion is not None:
            motion = np.asarray(transform_motion, dtype=float)
            if motion.shape != (4, 4) or not np.all(np.isfinite(motion)):
                raise ValueError(f"transform_motion must be a finite 4x4 transform, got shape {motion.shape}")
            poses = motion @ poses
        self.evaluator.update(image_left_bgr, image_right_bgr)
        before = self.evaluator.evaluations
        x, y, z = poses[0, :3, 3]
        w, wz = s.tracking_window, s.tracking_depth_window
        window = SearchBounds(
            x=(x - w, x + w),
            y=(y - w, y + w),
            z=(max(z - wz, 1e-3), max(z + wz, 2e-3)),
            max_tilt_deg=s.bounds.max_tilt_deg,
            max_yaw_deg=s.bounds.max_yaw_deg,
        )
        ga = GeneticAlgorithm(self._score(s.fine_stride), window, self._tracking_ga, self._rng)
        ga.population = encode(parameters_from_transforms(poses), window, self._tracking_ga.gray_code)
        result = ga.evolve(count)
        refine = s.refinement.enabled and s.refinement.in_tracking
        pose, fitness, _ = self._polish(ga, self._best_pose(ga), s.refinement.tracking_iterations, refine)
        self._keep(ga)
        return Recognition(
            found=fitness >= s.acceptance_threshold,
            fitness=fitness,
            transform_model_to_camera=pose,
            evaluations=self.evaluator.evaluations - before,
            generations=result.generations,
            time_s=time.perf_counter() - start,
        )

    def _score(
        self, stride: int = 1, subpixel: bool = False, centres: FloatArray | None = None
    ) -> KernelFitness:
        """The search fitness of poses; poses `_avoided(centres)` score -1 (and the compiled
        refinement does not visit them)."""
        return KernelFitness(
            self.evaluator, stride=stride, search=True, subpixel=subpixel, avoid=self._avoided(centres)
        )

    def _avoided(self, centres: FloatArray | None) -> AvoidedPoses:
        """Poses within `peak_separation` (x-y) of a centre (x, y, yaw): of a peak already
        reported (yaw NaN: at any yaw), or of a poor peak that drew the runs (at any yaw,
        or within `avoid_yaw_deg` of its yaw: see `RecognitionSettings.restarts`)."""
        s = self.settings
        points = np.zeros((0, 3)) if centres is None else np.asarray(centres, dtype=float).reshape(-1, 3)
        return AvoidedPoses(points, s.peak_separation, float(np.deg2rad(s.avoid_yaw_deg)))

    def _search(self, rng: np.random.Generator, centres: FloatArray) -> GeneticAlgorithm:
        """A GA run (coarse generations on a point subset, then all points), away from `centres`."""
        s = self.settings
        coarse = min(s.coarse_generations, s.ga.generations)
        ga = GeneticAlgorithm(self._score(s.coarse_stride, centres=centres), s.bounds, s.ga, rng)
        ga.run(coarse)
        ga.objective = self._score(s.fine_stride, centres=centres)
        ga.evolve(s.ga.generations - coarse)
        return ga

    def _keep(self, ga: GeneticAlgorithm) -> None:
        """Keeps the best `tracking_population` poses of `ga`, best first."""
        if ga.population is None or ga.scores is None:
            raise RuntimeError("the GA has no population")  # unreachable: it ran
        order = np.argsort(-ga.scores, kind="stable")[: self.settings.tracking_population]
        self._poses = ga.transforms(ga.population[order])

    @staticmethod
    def _best_pose(ga: GeneticAlgorithm) -> FloatArray:
        if ga.population is None or ga.scores is None:
            raise RuntimeError("the GA has no population")  # unreachable: it ran
        best = int(np.argmax(ga.scores))
        return ga.transforms(ga.population[best : best + 1])[0]

    def _candidates(self, ga: GeneticAlgorithm) -> FloatArray:
        """(C, 4, 4) distinct good poses of each island, each also untilted (a cloth on a table
        facing the camera), and all of those also turned by half a turn about the cloth normal.

        Each of them is tried at the depths `candidate_depths` along the ray through the
        model origin. A tilted, deeper pose can imitate a flat cloth's outline
        (foreshortening for scale) and hold the GA on that separate peak; the untilted
        variant at another depth starts the refinement on the true one's slope.
        """
        s = self.settings
        poses = []
        for genes, scores in ga.islands():
            order = np.argsort(-scores, kind="stable")
            transforms = ga.transforms(genes[order])
            chosen: list[FloatArray] = []
            for T in transforms:
                if all(not _same_peak(T, other, s.candidate_separation) for other in chosen):
                    chosen.append(T)
                    if len(chosen) == s.candidates_per_island:
                        break
            poses.extend(chosen)
        level = [_untilted(T) for T in poses]
        half_turn = np.diag([-1.0, -1.0, 1.0, 1.0])  # about the model's z axis, through its origin
        variants = np.array(poses + level + [T @ half_turn for T in poses + level])
        scales = [(T_z + dz) / T_z for T_z in variants[:, 2, 3] for dz in s.candidate_depths]
        out = np.repeat(variants, len(s.candidate_depths), axis=0)
        out[:, :3, 3] *= np.asarray(scales)[:, None]  # along the ray through the model origin
        return out

    def _finish(
        self,
        ga: GeneticAlgorithm,
        refine: bool,
        rng: np.random.Generator,
        centres: FloatArray | None = None,
    ) -> tuple[FloatArray, float, float]:
        """The best of the islands' candidates, refined (and injected back), with its paper and
        search fitness.

        The candidates are scored with the full search fitness; the best
        `refine_candidates` are refined briefly by the compass search, the best of those
        to the end by `refinement.method` (a CMA-ES draws from `rng`). The refinement
        stays inside the bounds and away from `centres`.
        """
        s, r = self.settings, self.settings.refinement
        limits = _limits(ga)
        candidates = self._candidates(ga)
        candidates = candidates[limits.allows(candidates, self._avoided(centres))]
        if not len(candidates) or not refine:
            return self._polish(ga, self._best_pose(ga), r.max_iterations, refine, centres, rng)
        scores = self._score(centres=centres)(candidates)
        order = np.argsort(-scores, kind="stable")[: s.refine_candidates]
        quick = self._score(subpixel=r.candidate_subpixel, centres=centres)
        polished = [
            compass_search_compiled(T, quick, r, r.candidate_iterations, limits) for T in candidates[order]
        ]
        pose = max(polished, key=lambda item: item[1])[0]
        return self._polish(ga, pose, max(r.max_iterations - r.candidate_iterations, 1), True, centres, rng)

    def _polish(
        self,
        ga: GeneticAlgorithm,
        pose: FloatArray,
        iterations: int,
        refine: bool,
        centres: FloatArray | None = None,
        rng: np.random.Generator | None = None,
    ) -> tuple[FloatArray, float, float]:
        """`pose` refined (and injected into `ga`'s population), with its paper and search fitness.

        With `rng` and `refinement.method` "cma" the refinement is a CMA-ES drawing from
        `rng`, else a compass search of at most `iterations`.
        """
        if refine:
            r = self.settings.refinement
            if rng is not None and r.method == "cma":
                fine = self._score(subpixel=True, centres=centres) if r.subpixel else None
                pose, _ = cma_search_compiled(pose, self._score(centres=centres), r, rng, _limits(ga), fine)
            else:
                fitness = self._score(subpixel=r.subpixel, centres=centres)
                pose, _ = compass_search_compiled(pose, fitness, r, iterations, _limits(ga))
        search_fitness = float(self.evaluator.evaluate(pose, search=True)[0])
        if (
            refine
            and ga.population is not None
            and ga.scores is not None
            and search_fitness >= ga.scores.max()
        ):
            worst = int(np.argmin(ga.scores))  # the population keeps the polished pose
            genes = encode(parameters_from_transforms(pose), ga.bounds, ga.settings.gray_code)
            ga.population[worst] = genes[0]
            ga.scores[worst] = search_fitness
        return pose, float(self.evaluator.evaluate(pose)[0]), search_fitness


def _untilted(pose: FloatArray) -> FloatArray:
    """`pose` with the model's normal turned onto the camera axis, keeping its yaw and origin."""
    out = pose.copy()
    out[:3, :3] = rotation_about_z(yaw_of(pose[:3, :3]))
    return out


def _limits(ga: GeneticAlgorithm) -> PoseLimits:
    """The refinement's allowed set: position inside the GA's bounds, tilt within
    `max_tilt_deg` (a cone: the GA's box reaches ~1.4x that on diagonals), yaw within
    `max_yaw_deg`."""
    b = ga.bounds
    return PoseLimits(
        np.array([b.x[0], b.y[0], b.z[0]]),
        np.array([b.x[1], b.y[1], b.z[1]]),
        float(np.cos(np.deg2rad(b.max_tilt_deg))),
        float(np.deg2rad(b.max_yaw_deg)) if b.max_yaw_deg < 180.0 else np.inf,
    )


def _same_peak(a: FloatArray, b: FloatArray, separation: float) -> bool:
    """Two poses closer than `separation` in x-y and 20° in yaw."""
    close = float(np.linalg.norm(a[:2, 3] - b[:2, 3])) < separation
    return close and abs(float(wrap_angle(yaw_of(a[:3, :3]) - yaw_of(b[:3, :3])))) < np.deg2rad(20.0)


__all__ = ["Peak", "Recognition", "RecognitionSettings", "Recognizer", "RefinementSettings"]
