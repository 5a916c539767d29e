"""Propose stage: the paper's GA on the hue fitness finds the pose candidates.

One-shot (`Proposer.propose`): GA runs from a random population (the first
`coarse_generations` score every `coarse_stride`-th model point, the rest every
`fine_stride`-th), the best distinct poses of each island (also untilted, half-turned and
at other depths) climbed briefly by the refine stage's compass search, the best of them
polished by the refine stage. A poor result restarts the GA until two runs agree; a poor
peak that two runs ended on is avoided by the next ones. The best end is also tried moved
by the print's periods and turned about its symmetry points (`print_periods`: a periodic
print's neighbouring peaks, which the polish cannot leave). Every run's polished end is
kept as a candidate, so the verification can compare the peaks. Given a look-alike test
(the verify stage: the model photo's texture disagrees there at every quarter turn), a
run's end on another object of the model's hues (a sheet of a look-alike hue) is avoided
at any yaw by the later runs, and does not stop the restarts or become the best while a
run ended elsewhere. With `peaks`, further runs that
avoid the peaks found so far give one pose per distinct peak (e.g. each cloth in view,
Fig. 13 e-f).

Multi-step (`Proposer.track`, Sec. II-E): the kept poses move by the camera motion, a
small GA evolves them a few generations inside a window around the best moved pose, and
the refine stage polishes the best briefly. The proposer keeps the poses for the next
frame explicitly (`keep`): the polished pose first, then the GA's best.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from pydantic import Field

from robot_app.arrays import FloatArray
from robot_app.config import StrictModel
from robot_app.geometry import rotation_about_z, wrap_angle, yaw_of
from robot_app.vision.fitness import FitnessEvaluator, KernelFitness
from robot_app.vision.ga import GASettings, GeneticAlgorithm, SearchBoundsSettings
from robot_app.vision.poses import AvoidedPoses, PoseLimits, as_poses
from robot_app.vision.print_periods import PeriodSettings, print_periods
from robot_app.vision.refinement import Refiner
from robot_app.vision.tracking_window import (
    TrackingSettings,
    off_plane,
    reach_in_depth,
    reachable_regions,
    search_tilt_sine,
    window_around,
)

HALF_TURN = np.diag([-1.0, -1.0, 1.0, 1.0])  # about the model's z axis, through its origin


@dataclass(frozen=True)
class _TrackingFrame:
    """One tracking frame's motion (a copy; None: no motion), the kept poses moved by it
    and the search window around the best of them."""

    motion: FloatArray | None
    poses: FloatArray
    window: SearchBoundsSettings


class ProposalSettings(StrictModel):
    """The GA search of one-shot recognition and tracking.

    Attributes:
        ga: GA parameters (100 generations of 100 individuals in 4 islands).
        bounds: search space in Σ_CR.
        coarse_generations: first generations scored on a point subset.
        coarse_stride: every n-th model point scored in the coarse generations.
        fine_stride: every n-th model point scored in the other generations and while
            tracking (the refinement and the reported fitness always use every point).
            6 and 4 (before: 4 and 3) save about 3 ms a recognition; on 160 flat and 80
            covered calibration scenes the errors did not grow (flat: 95th percentile
            |x| 0.48 against 0.51 mm, no gross error; covered: gross errors 6 % against 8 %).
        candidates_per_island: distinct poses (x-y farther apart than `candidate_separation`
            or yaws farther apart than 20°) taken from each island's final population.
        candidate_separation: x-y distance that makes two candidates distinct [m].
        candidate_depths: offsets along the ray through the model origin at which every
            candidate is also scored [m].
        refine_candidates: the best candidates (after adding each one's half turn about
            the cloth normal) that the refine stage climbs for
            `refinement.candidate_iterations` before the best is polished.
        restarts: further runs while the best search fitness is below `restart_below` and
            the best peak is not confirmed (two runs ended on it and it scores at least
            `confirm_above`); the best of all runs is kept. A poor result is more often a
            missed peak than a poor view, while a partly hidden cloth scores below
            `restart_below` at its true pose but ends there twice. An absent cloth costs
            all these runs. Later runs search away (`peak_separation`) from a poor peak
            (below `confirm_above`) that two runs ended on; one that scores at least
            `avoid_any_yaw_below` is a near miss on the cloth itself, so only yaws within
            `avoid_yaw_deg` of it are avoided (its half or quarter turn may be the truth).
        restart_below: search fitness under which a restart is run.
        confirm_above: the search fitness from which a peak two runs ended on is taken.
        avoid_yaw_deg, avoid_any_yaw_below: see `restarts`.
        max_peaks: peaks reported with `peaks`.
        peak_separation: x-y distance between distinct peaks [m].
        peak_min_fitness: weaker peaks are not reported.
        periods: the best pose of a one-shot proposal is also tried shifted by each period
            of a periodic print (and half-turned about its other symmetry points,
            `print_periods`); the best shifted pose, climbed, replaces it if it scores
            `period_margin` more after its polish. A pose a period off the truth (a
            neighbouring peak) scores nearly as well and the polish cannot cross the valley.
        period_margin: see `periods`.
        tracking: the multi-step proposal.
    """

    ga: GASettings = GASettings()
    bounds: SearchBoundsSettings = SearchBoundsSettings()
    coarse_generations: int = Field(default=60, ge=0)
    coarse_stride: int = Field(default=6, ge=1)
    fine_stride: int = Field(default=4, ge=1)
    candidates_per_island: int = Field(default=2, ge=1)
    candidate_separation: float = Field(default=0.01, gt=0.0)
    candidate_depths: tuple[float, ...] = (-0.03, -0.015, 0.0, 0.015, 0.03)
    refine_candidates: int = Field(default=3, ge=1)
    restarts: int = Field(default=4, ge=0)
    restart_below: float = Field(default=0.97, ge=0.0, le=1.0)
    confirm_above: float = Field(default=0.94, ge=0.0, le=1.0)
    avoid_yaw_deg: float = Field(default=45.0, gt=0.0, le=90.0)
    avoid_any_yaw_below: float = Field(default=0.8, ge=0.0, le=1.0)
    max_peaks: int = Field(default=3, ge=1)
    peak_separation: float = Field(default=0.06, gt=0.0)
    peak_min_fitness: float = Field(default=0.2, ge=0.0, le=1.0)
    periods: PeriodSettings = PeriodSettings()
    period_margin: float = Field(default=0.005, ge=0.0, le=1.0)
    tracking: TrackingSettings = TrackingSettings()


@dataclass(frozen=True)
class Candidate:
    """A proposed pose and its search fitness (`RecognitionSettings.search`)."""

    transform_model_to_camera: FloatArray
    search_fitness: float


@dataclass(frozen=True)
class Proposal:
    """What the propose stage found.

    Attributes:
        best: the polished best pose of all runs.
        candidates: the polished end of every run, best first (`best` among them).
        peaks: with `peaks`, the best of each distinct peak, in the order found.
        generations: GA generations run.
    """

    best: Candidate
    candidates: tuple[Candidate, ...]
    peaks: tuple[Candidate, ...]
    generations: int


class Proposer:
    """The propose stage of one model on one evaluator; keeps the poses to track.

    Args:
        evaluator: the fitness evaluator (its search parameters are the search fitness).
        settings: the GA search.
        refiner: the refine stage, which climbs candidates and polishes each run's best.
        seed: seed of the generator used when a call gives none.
    """

    def __init__(
        self, evaluator: FitnessEvaluator, settings: ProposalSettings, refiner: Refiner, seed: int = 0
    ) -> None:
        self.evaluator = evaluator
        self.settings = settings
        self.refiner = refiner
        self._seed = seed
        self._print_maps: FloatArray | None = None
        self._tilt_sine = search_tilt_sine(settings.bounds.max_tilt_deg)  # a tracking window's
        self._off_plane = off_plane(evaluator.model)
        self.reset()

    @property
    def print_maps(self) -> FloatArray:
        """(K, 4, 4) maps of Σ_M under which the print looks the same (`print_periods`; measured
        at the first use: 2-150 ms a model; none with `periods.enabled` false)."""
        if self._print_maps is None:
            s = self.settings.periods
            self._print_maps = print_periods(self.evaluator.model, s) if s.enabled else np.zeros((0, 4, 4))
        return self._print_maps

    def reset(self) -> None:
        """Forgets the tracked poses and reseeds the generator."""
        self.rng = np.random.default_rng(self._seed)
        self._poses: FloatArray | None = None
        self._frame: _TrackingFrame | None = None

    @property
    def kept_poses(self) -> FloatArray | None:
        """(P, 4, 4) poses kept for tracking, best first (None before the first proposal)."""
        return None if self._poses is None else self._poses.copy()

    def keep(self, best: FloatArray, others: FloatArray) -> None:
        """Keeps `best` and then the first of `others` (P, 4, 4) for the next tracking frame."""
        count = self.settings.tracking.ga.population
        self._poses = np.concatenate([as_poses(best), as_poses(others)])[:count]
        self._frame = None

    def fitness(
        self,
        stride: int = 1,
        subpixel: bool = False,
        centres: npt.ArrayLike | None = None,
        view_floor: tuple[float, float] | None = None,
    ) -> KernelFitness:
        """The search fitness; poses near `centres` (x, y, yaw; yaw NaN: any) score -1;
        `view_floor`: the normalisation's (min_view_fraction, hidden_penalty) if not None."""
        return KernelFitness(
            self.evaluator,
            stride=stride,
            search=True,
            subpixel=subpixel,
            avoid=self._avoided(centres),
            view_floor=view_floor,
        )

    def limits(self, bounds: SearchBoundsSettings | None = None) -> PoseLimits:
        """The allowed set of the local searches: position inside `bounds` (default: the
        search bounds), tilt within `max_tilt_deg` (a cone), yaw within `max_yaw_deg`."""
        b = self.settings.bounds if bounds is None else bounds
        return PoseLimits(
            np.array([b.x[0], b.y[0], b.z[0]]),
            np.array([b.x[1], b.y[1], b.z[1]]),
            float(np.cos(np.deg2rad(b.max_tilt_deg))),
            float(np.deg2rad(b.max_yaw_deg)) if b.max_yaw_deg < 180.0 else np.inf,
        )

    def propose(
        self,
        rng: np.random.Generator | None = None,
        *,
        peaks: bool = False,
        restarts: int | None = None,
        look_alike: Callable[[FloatArray], bool] | None = None,
    ) -> Proposal:
        """One-shot proposal on the evaluator's current pair (see the module docstring);
        `restarts` caps the restarts below `settings.restarts` (None: the settings');
        `look_alike(pose)` says a run's end is not the cloth but an object of its hues."""
        s = self.settings
        rng = self.rng if rng is None else rng
        found: list[Candidate] = []
        ends: list[Candidate] = []
        generations = 0
        for _ in range(s.max_peaks if peaks else 1):
            centres = np.array([[*p.transform_model_to_camera[:2, 3], np.nan] for p in found]).reshape(-1, 3)
            best, run_ends, best_ga, count = self._runs(rng, centres, restarts, look_alike)
            generations += count
            shifted = self._across_periods(best, rng, centres)
            if shifted is not best:
                best, run_ends = shifted, [shifted, *run_ends]
            if found and best.search_fitness < s.peak_min_fitness:
                break
            found.append(best)
            if len(found) == 1:
                ends = run_ends
                self.keep(best.transform_model_to_camera, best_ga.ranked_poses(s.tracking.ga.population))
        ranked = tuple(sorted(ends, key=lambda c: -c.search_fitness))
        return Proposal(found[0], ranked, tuple(found) if peaks else (), generations)

    def track(
        self, transform_motion: FloatArray | None, generations: int | None = None
    ) -> tuple[Candidate, int]:
        """Multi-step proposal on the evaluator's current pair from the kept poses.

        Args:
            transform_motion: (4, 4) ^CR_new T_CR_old; every kept pose moves by it. None: no motion.
            generations: GA generations this frame (default: `tracking.ga.generations`).

        Returns:
            the polished best pose and the generations run.

        Raises:
            RuntimeError: nothing kept yet (propose first).
        """
        s, t = self.settings, self.settings.tracking
        count = t.ga.generations if generations is None else generations
        if count < 0:
            raise ValueError(f"generations must be >= 0, got {count}")
        frame = self._tracking_frame(transform_motion)
        poses, window = frame.poses, frame.window
        near = _yaw_offsets(poses, poses[0]) <= np.deg2rad(t.yaw_window_deg)
        poses = poses[near]  # the kept poses near the predicted one (a half turn may be among them)
        ga = GeneticAlgorithm(window, t.ga, self.rng)
        ga.seed(np.concatenate([poses, np.repeat(poses[-1:], t.ga.population - len(poses), axis=0)]))
        ga.evolve(self.fitness(s.fine_stride, view_floor=t.view_floor), count)
        ranked = ga.ranked_poses(t.ga.population)
        inside = _yaw_offsets(ranked, poses[0]) <= np.deg2rad(t.yaw_window_deg)
        pose = ranked[int(np.argmax(inside))] if inside.any() else poses[0]
        r = self.refiner.settings
        if r.enabled and r.in_tracking:
            fine = self.fitness(subpixel=r.subpixel, view_floor=t.view_floor)
            pose = self.refiner.climb(
                pose, fine, r.tracking_iterations, self.limits(window)
            ).transform_model_to_camera
        best = Candidate(pose, float(self.fitness()(pose)[0]))
        self.keep(pose, ranked)
        return best, count

    def tracking_window(self, transform_motion: FloatArray | None) -> SearchBoundsSettings:
        """The window the next `track(transform_motion)` searches: around the best kept pose
        moved by the motion, `tracking.window` in x-y and `tracking.depth_window` in depth.

        Raises:
            RuntimeError: nothing kept yet (propose first).
            ValueError: a motion that is not a finite 4x4 transform.
        """
        return self._tracking_frame(transform_motion).window

    def tracking_regions(
        self, transform_motion: FloatArray | None
    ) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]:
        """Per image (left, right), the box the model can reach from the next tracking
        window (`tracking_window.reachable_regions`): the only pixels a tracking frame
        needs colour codes of (`FitnessEvaluator.update(regions=...)`).

        Raises:
            RuntimeError: nothing kept yet (propose first).
        """
        frame = self._tracking_frame(transform_motion)
        # the moved best pose is scored unclipped if no GA pose is in the yaw window (`track`):
        # the box covers its tilt too, so every pose the frame scores reads coded pixels
        tilt_sine = max(self._tilt_sine, float(np.hypot(frame.poses[0][2, 0], frame.poses[0][2, 1])))
        model = self.evaluator.model
        depth = reach_in_depth(model.radius, self._off_plane, tilt_sine)
        return reachable_regions(frame.window, model, self.evaluator.rig, depth)

    def _tracking_frame(self, transform_motion: FloatArray | None) -> _TrackingFrame:
        """The kept poses moved by `transform_motion` and the window around the best, built
        once per kept poses and motion: a frame's `tracking_regions` and `track` share them."""
        frame = self._frame
        if frame is not None and (
            (transform_motion is None and frame.motion is None)
            or (
                transform_motion is not None
                and frame.motion is not None
                and np.array_equal(transform_motion, frame.motion)
            )
        ):
            return frame
        poses = self._moved_poses(transform_motion)
        motion = None if transform_motion is None else np.array(transform_motion, dtype=float)
        self._frame = _TrackingFrame(
            motion, poses, window_around(poses[0], self.settings.tracking, self.settings.bounds)
        )
        return self._frame

    def _moved_poses(self, transform_motion: FloatArray | None) -> FloatArray:
        if self._poses is None:
            raise RuntimeError("nothing to track: propose() first")
        if transform_motion is None:
            return self._poses
        motion = np.asarray(transform_motion, dtype=float)
        if motion.shape != (4, 4) or not np.all(np.isfinite(motion)):
            raise ValueError(f"transform_motion must be a finite 4x4 transform, got shape {motion.shape}")
        return motion @ self._poses

    # ------------------------------------------------------------------ one-shot internals
    def _runs(
        self,
        rng: np.random.Generator,
        centres: FloatArray,
        restarts: int | None = None,
        look_alike: Callable[[FloatArray], bool] | None = None,
    ) -> tuple[Candidate, list[Candidate], GeneticAlgorithm, int]:
        """GA runs with restarts away from `centres` (and from the look-alikes found): the
        best end (not a look-alike if any run ended elsewhere), every end, the best run's GA
        and the generations run."""
        s = self.settings
        ga = self._search(rng, centres)
        best = self._finish(ga, rng, centres)
        generations = s.ga.generations
        ends, avoid = [best], centres
        alike = look_alike is not None and look_alike(best.transform_model_to_camera)
        if alike:
            avoid = np.vstack([avoid, [*best.transform_model_to_camera[:2, 3], np.nan]])
        for _ in range(s.restarts if restarts is None else min(restarts, s.restarts)):
            if best.search_fitness >= s.restart_below and not alike:
                break
            again = self._search(rng, avoid)
            generations += s.ga.generations
            result = self._finish(again, rng, avoid)
            ends.append(result)
            last = result.transform_model_to_camera
            last_alike = look_alike is not None and look_alike(last)
            if last_alike:
                avoid = np.vstack([avoid, [*last[:2, 3], np.nan]])  # not the cloth: elsewhere, at any yaw
            if (alike and not last_alike) or (
                alike == last_alike and result.search_fitness > best.search_fitness
            ):
                ga, best, alike = again, result, last_alike
            pose = best.transform_model_to_camera
            twice = (
                sum(_same_peak(pose, e.transform_model_to_camera, s.candidate_separation) for e in ends) >= 2
            )
            if twice and best.search_fitness >= s.confirm_above and not alike:
                break  # two runs ended on the best peak, and it is a good one: confirmed
            drawn = (
                sum(_same_peak(last, e.transform_model_to_camera, s.candidate_separation) for e in ends) >= 2
            )
            if drawn and result.search_fitness < s.confirm_above and not last_alike:
                yaw = yaw_of(last[:3, :3]) if result.search_fitness >= s.avoid_any_yaw_below else np.nan
                avoid = np.vstack([avoid, [*last[:2, 3], yaw]])  # a poor peak that draws the runs
        return best, ends, ga, generations

    def _across_periods(self, best: Candidate, rng: np.random.Generator, centres: FloatArray) -> Candidate:
        """`best` or, if one scores `period_margin` more once climbed and polished, the best of
        it moved by the print's periods (`print_maps`): the neighbouring peaks of a periodic print."""
        s, r = self.settings, self.refiner.settings
        if not len(self.print_maps) or not r.enabled:
            return best
        limits = self.limits()
        poses = best.transform_model_to_camera @ self.print_maps
        poses = poses[limits.allows(poses, self._avoided(centres))]
        if not len(poses):
            return best
        fitness = self.fitness(centres=centres)
        order = np.argsort(-fitness(poses), kind="stable")[: s.refine_candidates]
        quick = self.fitness(subpixel=r.candidate_subpixel, centres=centres)
        climbed = [self.refiner.climb(T, quick, r.candidate_iterations, limits) for T in poses[order]]
        start = max(climbed, key=lambda c: c.score)
        if start.score <= best.search_fitness + s.period_margin:
            return best
        fine = self.fitness(subpixel=True, centres=centres)
        iterations = max(r.max_iterations - r.candidate_iterations, 1)
        pose = self.refiner.polish(
            start.transform_model_to_camera, fitness, fine, limits, rng, iterations
        ).transform_model_to_camera
        score = float(fitness(pose)[0])
        return Candidate(pose, score) if score > best.search_fitness + s.period_margin else best

    def _search(self, rng: np.random.Generator, centres: FloatArray) -> GeneticAlgorithm:
        """A GA run: coarse generations on a point subset, then on more points."""
        s = self.settings
        coarse = min(s.coarse_generations, s.ga.generations)
        ga = GeneticAlgorithm(s.bounds, s.ga, rng)
        ga.run(self.fitness(s.coarse_stride, centres=centres), coarse)
        ga.evolve(self.fitness(s.fine_stride, centres=centres), s.ga.generations - coarse)
        return ga

    def _finish(self, ga: GeneticAlgorithm, rng: np.random.Generator, centres: FloatArray) -> Candidate:
        """The best of the islands' candidates, climbed and then polished by the refine stage."""
        s, r = self.settings, self.refiner.settings
        limits = self.limits()
        candidates = self._candidates(ga)
        candidates = candidates[limits.allows(candidates, self._avoided(centres))]
        fitness = self.fitness(centres=centres)
        fine = self.fitness(subpixel=True, centres=centres)
        if not r.enabled or not len(candidates):
            pose = ga.best_pose()
            if r.enabled:
                pose = self.refiner.polish(pose, fitness, fine, limits, rng).transform_model_to_camera
            return Candidate(pose, float(fitness(pose)[0]))
        scores = fitness(candidates)
        order = np.argsort(-scores, kind="stable")[: s.refine_candidates]
        quick = self.fitness(subpixel=r.candidate_subpixel, centres=centres)
        climbed = [self.refiner.climb(T, quick, r.candidate_iterations, limits) for T in candidates[order]]
        start = max(climbed, key=lambda c: c.score).transform_model_to_camera
        iterations = max(r.max_iterations - r.candidate_iterations, 1)
        pose = self.refiner.polish(start, fitness, fine, limits, rng, iterations).transform_model_to_camera
        return Candidate(pose, float(fitness(pose)[0]))

    def _candidates(self, ga: GeneticAlgorithm) -> FloatArray:
        """(C, 4, 4) distinct good poses of each island, each also untilted (a cloth on a table
        facing the camera), all of those also half-turned about the cloth normal, and each
        at the depths `candidate_depths` along the ray through the model origin. A tilted,
        deeper pose can imitate a flat cloth's outline (foreshortening for scale) and hold
        the GA on that separate peak; the untilted variant at another depth starts the
        climb on the true one's slope."""
        s = self.settings
        poses = []
        for genes, scores in ga.islands():
            ranked = ga.transforms(genes[np.argsort(-scores, kind="stable")])
            xy, yaws = ranked[:, :2, 3], np.arctan2(ranked[:, 1, 0], ranked[:, 0, 0])
            distinct = np.ones(len(ranked), dtype=bool)  # not on the peak of a pose chosen before
            for _ in range(s.candidates_per_island):
                if not distinct.any():
                    break
                k = int(np.argmax(distinct))  # the best distinct one
                poses.append(ranked[k])
                near = np.linalg.norm(xy - xy[k], axis=1) < s.candidate_separation
                turned = np.abs(np.asarray(wrap_angle(yaws - yaws[k]))) < np.deg2rad(20.0)
                distinct &= ~(near & turned)  # `_same_peak`, for the whole island at once
        level = [untilted(T) for T in poses]
        variants = np.array(poses + level + [T @ HALF_TURN for T in poses + level])
        scales = [(T_z + dz) / T_z for T_z in variants[:, 2, 3] for dz in s.candidate_depths]
        out = np.repeat(variants, len(s.candidate_depths), axis=0)
        out[:, :3, 3] *= np.asarray(scales)[:, None]  # along the ray through the model origin
        return out

    def _avoided(self, centres: npt.ArrayLike | None) -> AvoidedPoses:
        s = self.settings
        points = np.zeros((0, 3)) if centres is None else np.asarray(centres, dtype=float).reshape(-1, 3)
        return AvoidedPoses(points, s.peak_separation, float(np.deg2rad(s.avoid_yaw_deg)))


def untilted(pose: FloatArray) -> FloatArray:
    """`pose` with the model's normal turned onto the camera axis, keeping its yaw and origin."""
    out = np.array(pose, dtype=float)
    out[:3, :3] = rotation_about_z(yaw_of(out[:3, :3]))
    return out


def _same_peak(a: FloatArray, b: FloatArray, separation: float) -> bool:
    """Two poses closer than `separation` in x-y and 20° in yaw."""
    close = float(np.linalg.norm(a[:2, 3] - b[:2, 3])) < separation
    return close and abs(float(wrap_angle(yaw_of(a[:3, :3]) - yaw_of(b[:3, :3])))) < np.deg2rad(20.0)


def _yaw_offsets(poses: FloatArray, reference: FloatArray) -> FloatArray:
    """|yaw difference| [rad] of (P, 4, 4) poses from a reference pose, on the circle."""
    yaws = np.arctan2(poses[:, 1, 0], poses[:, 0, 0])
    return np.abs(np.asarray(wrap_angle(yaws - yaw_of(reference[:3, :3])), dtype=float)).reshape(-1)


__all__ = [
    "HALF_TURN",
    "Candidate",
    "Proposal",
    "ProposalSettings",
    "Proposer",
    "untilted",
]
