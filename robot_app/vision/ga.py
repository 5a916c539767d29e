"""The 72-bit genetic algorithm of the paper (Sec. II-E): one-shot search and multi-step tracking.

A chromosome is six 12-bit genes (t_x, t_y, t_z, ε1, ε2, ε3): the position of Σ_M in Σ_CR
and the vector part ε of a unit quaternion with ε0 = sqrt(1 - |ε|²) ≥ 0. Each gene maps
its 4096 levels linearly onto the `SearchBounds` range of its variable, Gray-coded by
default so that one bit flip moves a variable by one level. The ε box can hold |ε| > 1;
such an ε is repaired by normalising it to |ε| = 1 (ε0 = 0, a half turn), which keeps
every chromosome a valid rotation. The tilt of Σ_M from the camera axis depends only on
ε1² + ε2² (cos tilt = 1 - 2(ε1² + ε2²)), so bounding ε1 and ε2 by sin(max_tilt / 2)
bounds the tilt by `max_tilt_deg` along the axes (and by at most ~1.4x that on diagonals).

One generation: rank the population, copy the `elite` best unchanged, draw parents by
linear ranking selection, two-point crossover over the 72 bits, bit-flip mutation, and
evaluate only the offspring. With `islands` > 1 the population is split into that many
sub-populations that rank and breed only among themselves (their offspring are scored
in one batch): each island converges on its own peak, so one island caught on a wrong
peak does not take the whole search with it. `run` starts from a random population; `track` keeps the
last population, moves every individual by the camera motion and evolves a few
generations. The RNG is a seeded `np.random.Generator`: same seed, same result. With a
`KernelFitness` (the recognizer's), all generations of a call run in one compiled loop
that draws the same random numbers and gives the same population as the loop in Python.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from pydantic import Field, model_validator

from robot_app.arrays import FloatArray
from robot_app.config import StrictModel
from robot_app.vision._kernels import evolve, next_generation, pose_parameters, transforms_from_genes
from robot_app.vision.fitness import KernelFitness

BITS = 12
GENES = 6
LEVELS = (1 << BITS) - 1  # highest gene value, 4095
Genes = npt.NDArray[np.uint16]
Objective = Callable[[FloatArray], FloatArray]  # (P, 4, 4) poses -> (P,) fitness values


class SearchBounds(StrictModel):
    """The search space, in the right camera frame Σ_CR (defaults: docs/architecture.md).

    Attributes:
        x, y, z: ranges of the position of Σ_M [m].
        max_tilt_deg: bound on tilt about the camera x and y axes [deg].
        max_yaw_deg: bound on yaw about the camera z axis [deg] (180 = full turn).
    """

    x: tuple[float, float] = (-0.255, 0.255)
    y: tuple[float, float] = (-0.195, 0.195)
    z: tuple[float, float] = (0.52, 0.64)
    max_tilt_deg: float = Field(default=20.0, ge=0.0, le=90.0)
    max_yaw_deg: float = Field(default=180.0, gt=0.0, le=180.0)

    @model_validator(mode="after")
    def _ranges_increase(self) -> SearchBounds:
        for name in ("x", "y", "z"):
            low, high = getattr(self, name)
            if not low < high:
                raise ValueError(f"{name} range must be (low, high) with low < high")
        if self.z[0] <= 0:
            raise ValueError("z range must be in front of the camera (z > 0)")
        return self

    def gene_ranges(self) -> FloatArray:
        """(6, 2) low/high of (t_x, t_y, t_z, ε1, ε2, ε3)."""
        tilt = np.sin(np.deg2rad(self.max_tilt_deg) / 2.0)
        yaw = np.sin(np.deg2rad(self.max_yaw_deg) / 2.0)
        return np.array([self.x, self.y, self.z, (-tilt, tilt), (-tilt, tilt), (-yaw, yaw)], dtype=float)


class GASettings(StrictModel):
    """GA parameters; 100 generations as in the paper.

    Attributes:
        population: individuals per generation.
        generations: generations of a one-shot `run`.
        tracking_generations: generations per frame of `track`.
        elite: best individuals copied unchanged into the next generation.
        crossover_rate: probability that a pair of parents is crossed.
        mutation_rate: probability of flipping each of the 72 bits of an offspring.
        selection_pressure: linear ranking, expected offspring of the best (1-2).
        gray_code: Gray-code the genes.
        islands: sub-populations that evolve independently (the population is split
            evenly between them; each keeps its own `elite`); 1 is the paper's GA. On the
            synthetic bench (96 scenes) 4 islands of 25 cut gross failures (> 10 mm or
            > 10°) from 9.4 % to 2.1 % at the same number of evaluations.
        uniform_yaw: draw the random population's yaw uniformly in angle (its ε3 gene as
            sin(yaw / 2)) instead of uniformly in the gene. A uniform ε3 samples yaws
            near ±180° sparsely (dε3/dyaw = cos(yaw / 2) / 2: ±10° about 180° is 0.2 % of
            the gene's range, about 0° 8.7 %). On the synthetic bench (scene seeds 1-3)
            a cloth 45 % covered ended > 10 mm or > 10° off in 4 of 300 scenes without
            this, 0 with it; a target beside another cloth was missed in 2 of 300 (both
            within 3° of a half turn), 0 with it.
        seed: seed of the random generator.
    """

    population: int = Field(default=100, ge=4)
    generations: int = Field(default=100, ge=1)
    tracking_generations: int = Field(default=3, ge=0)
    elite: int = Field(default=2, ge=0)
    crossover_rate: float = Field(default=0.9, ge=0.0, le=1.0)
    mutation_rate: float = Field(default=0.02, ge=0.0, le=1.0)
    selection_pressure: float = Field(default=1.8, ge=1.0, le=2.0)
    gray_code: bool = True
    islands: int = Field(default=4, ge=1)
    uniform_yaw: bool = True
    seed: int = Field(default=0, ge=0)

    @model_validator(mode="after")
    def _elite_fits(self) -> GASettings:
        if self.population < 4 * self.islands:
            raise ValueError("population must hold at least 4 individuals per island")
        if self.elite >= self.population // self.islands:
            raise ValueError("elite must be smaller than each island's population")
        return self

    def island_slices(self) -> list[slice]:
        """The individuals of each island in the population array."""
        bounds = np.linspace(0, self.population, self.islands + 1).round().astype(int)
        return [slice(int(a), int(b)) for a, b in itertools.pairwise(bounds)]


def encode(parameters: npt.ArrayLike, bounds: SearchBounds, gray_code: bool = True) -> Genes:
    """(P, 6) (t_x, t_y, t_z, ε1, ε2, ε3) -> (P, 6) genes; values outside the bounds are clipped."""
    x = np.asarray(parameters, dtype=float).reshape(-1, GENES)
    ranges = bounds.gene_ranges()
    scaled = (x - ranges[:, 0]) / (ranges[:, 1] - ranges[:, 0]) * LEVELS
    genes = np.clip(np.rint(scaled), 0, LEVELS).astype(np.uint16)
    return (genes ^ (genes >> 1)).astype(np.uint16) if gray_code else genes


def decode(genes: Genes, bounds: SearchBounds, gray_code: bool = True) -> FloatArray:
    """(P, 6) genes -> (P, 6) (t_x, t_y, t_z, ε1, ε2, ε3) [m, -]."""
    g = np.asarray(genes, dtype=np.uint16).reshape(-1, GENES).copy()
    if gray_code:
        for shift in (1, 2, 4, 8):
            g ^= g >> shift
    ranges = bounds.gene_ranges()
    return ranges[:, 0] + g / LEVELS * (ranges[:, 1] - ranges[:, 0])


def transforms_from_parameters(parameters: npt.ArrayLike) -> FloatArray:
    """(P, 6) (t, ε) -> (P, 4, 4) ^CR T_M; an ε with |ε| > 1 is normalised (ε0 = 0)."""
    x = np.asarray(parameters, dtype=float).reshape(-1, GENES)
    eps = x[:, 3:].copy()
    norm = np.linalg.norm(eps, axis=1)
    long = norm > 1.0
    eps[long] /= norm[long, None]
    e1, e2, e3 = eps.T
    e0 = np.sqrt(np.clip(1.0 - (e1 * e1 + e2 * e2 + e3 * e3), 0.0, 1.0))
    T = np.zeros((len(x), 4, 4))
    T[:, 0, 0] = 1 - 2 * (e2 * e2 + e3 * e3)
    T[:, 0, 1] = 2 * (e1 * e2 - e0 * e3)
    T[:, 0, 2] = 2 * (e1 * e3 + e0 * e2)
    T[:, 1, 0] = 2 * (e1 * e2 + e0 * e3)
    T[:, 1, 1] = 1 - 2 * (e1 * e1 + e3 * e3)
    T[:, 1, 2] = 2 * (e2 * e3 - e0 * e1)
    T[:, 2, 0] = 2 * (e1 * e3 - e0 * e2)
    T[:, 2, 1] = 2 * (e2 * e3 + e0 * e1)
    T[:, 2, 2] = 1 - 2 * (e1 * e1 + e2 * e2)
    T[:, :3, 3] = x[:, :3]
    T[:, 3, 3] = 1.0
    return T


def parameters_from_transforms(transforms: npt.ArrayLike) -> FloatArray:
    """(P, 4, 4) ^CR T_M -> (P, 6) (t, ε) with ε0 ≥ 0 (the inverse of `transforms_from_parameters`)."""
    T = np.ascontiguousarray(np.asarray(transforms, dtype=float).reshape(-1, 4, 4))
    return np.asarray(pose_parameters(T))


@dataclass(frozen=True)
class GAResult:
    """Outcome of `run` or `track`.

    Attributes:
        transform_model_to_camera: (4, 4) best pose ^CR T_M found.
        fitness: its normalised fitness.
        generations: generations evolved in this call.
        evaluations: poses evaluated in this call.
        best_per_generation: (generations + 1,) best fitness after each generation.
    """

    transform_model_to_camera: FloatArray
    fitness: float
    generations: int
    evaluations: int
    best_per_generation: FloatArray


class GeneticAlgorithm:
    """The GA over an objective (a fitness function of poses); holds the population between calls."""

    def __init__(
        self,
        objective: Objective,
        bounds: SearchBounds | None = None,
        settings: GASettings | None = None,
        rng: np.random.Generator | None = None,
    ) -> None:
        self.objective = objective
        self.bounds = bounds if bounds is not None else SearchBounds()
        self.settings = settings if settings is not None else GASettings()
        self.rng = rng if rng is not None else np.random.default_rng(self.settings.seed)
        self.population: Genes | None = None
        self.scores: FloatArray | None = None
        ranges = self.bounds.gene_ranges()
        self._lows, self._spans = ranges[:, 0].copy(), ranges[:, 1] - ranges[:, 0]
        self._islands = self.settings.island_slices()
        self._starts = np.array([sl.start for sl in self._islands] + [self.settings.population], np.int64)
        sizes = [sl.stop - sl.start for sl in self._islands]
        pairs = sum((size - self.settings.elite + 1) // 2 for size in sizes)
        self._uniforms_shape = (pairs, 5 + mutation_draws(self.settings.mutation_rate))  # per generation
        largest = max(sizes)
        self._cdfs = np.ones((len(self._islands), largest))
        for i, sl in enumerate(self._islands):
            size = sl.stop - sl.start
            self._cdfs[i, :size] = _ranking_cdf(size, self.settings.selection_pressure)

    def islands(self) -> list[tuple[Genes, FloatArray]]:
        """(genes, scores) of each island's current individuals."""
        if self.population is None or self.scores is None:
            raise RuntimeError("no population yet: call run() first")
        return [(self.population[sl], self.scores[sl]) for sl in self._islands]

    def transforms(self, genes: Genes) -> FloatArray:
        """(P, 4, 4) poses of (P, 6) genes."""
        return transforms_from_genes(genes, self._lows, self._spans, self.settings.gray_code)

    def run(self, generations: int | None = None) -> GAResult:
        """One-shot search: a random population (see `GASettings.uniform_yaw`) evolved `generations`
        (default: settings) times."""
        s = self.settings
        genes = self.rng.integers(0, LEVELS + 1, (s.population, GENES), dtype=np.uint16)
        if s.uniform_yaw:
            yaw = np.deg2rad(self.bounds.max_yaw_deg) * self.rng.uniform(-1.0, 1.0, s.population)
            parameters = decode(genes, self.bounds, s.gray_code)
            parameters[:, 5] = np.sin(yaw / 2.0)
            genes[:, 5] = encode(parameters, self.bounds, s.gray_code)[:, 5]
        return self._evolve(genes, s.generations if generations is None else generations)

    def evolve(self, generations: int) -> GAResult:
        """Continues from the kept population (re-scored with the current `objective`)."""
        if self.population is None:
            raise RuntimeError("evolve() needs a population: call run() first")
        return self._evolve(self.population, generations)

    def track(
        self, transform_motion: npt.ArrayLike | None = None, generations: int | None = None
    ) -> GAResult:
        """Multi-step search: moves the kept population by the camera motion, then evolves.

        Args:
            transform_motion: (4, 4) ^CR_new T_CR_old; every individual becomes
                transform_motion @ T_old (clipped into the bounds). None: no motion.
            generations: generations this frame (default: settings.tracking_generations).

        Returns:
            The result of this frame. Without a kept population this is a `run`.
        """
        if self.population is None:
            return self.run()
        genes = self.population
        if transform_motion is not None:
            motion = np.asarray(transform_motion, dtype=float)
            if motion.shape != (4, 4) or not np.all(np.isfinite(motion)):
                raise ValueError(f"transform_motion must be a finite 4x4 transform, got shape {motion.shape}")
            moved = motion @ self.transforms(genes)
            genes = encode(parameters_from_transforms(moved), self.bounds, self.settings.gray_code)
        count = self.settings.tracking_generations if generations is None else generations
        return self._evolve(genes, count)

    def _evolve(self, genes: Genes, generations: int) -> GAResult:
        if generations < 0:
            raise ValueError(f"generations must be >= 0, got {generations}")
        scores = self.objective(self.transforms(genes))
        evaluations = len(genes)
        history = [float(scores.max())]
        in_python = generations
        if isinstance(self.objective, KernelFitness) and not self.objective.subpixel and generations > 0:
            compiled = self._compiled_generations(self.objective, genes, scores, generations)
            genes, scores, evaluated, best_history = compiled
            evaluations += evaluated
            history.extend(best_history.tolist())
            in_python = 0
        for _ in range(in_python):
            genes, scores, evaluated = self._generation(genes, scores)
            evaluations += evaluated
            history.append(float(scores.max()))
        self.population, self.scores = genes, scores
        best = int(np.argmax(scores))
        return GAResult(
            self.transforms(genes[best : best + 1])[0],
            float(scores[best]),
            generations,
            evaluations,
            np.array(history),
        )

    def _compiled_generations(
        self, fitness: KernelFitness, genes: Genes, scores: FloatArray, generations: int
    ) -> tuple[Genes, FloatArray, int, FloatArray]:
        """`generations` generations in `_kernels.evolve` (the draws of `_generation`, all at once)."""
        s = self.settings
        uniforms = self.rng.random((generations, *self._uniforms_shape))
        arguments, normalisation = fitness.kernel_arguments()
        genes, scores, evaluated, best = evolve(
            genes, scores, self._starts, s.elite, self._cdfs, uniforms, s.crossover_rate, s.mutation_rate,
            self._lows, self._spans, s.gray_code, arguments, normalisation, fitness.avoid.kernel_arguments(),
        )  # fmt: skip
        fitness.count(evaluated)
        return genes, scores, int(evaluated), best

    def _generation(self, genes: Genes, scores: FloatArray) -> tuple[Genes, FloatArray, int]:
        s = self.settings
        uniforms = self.rng.random(self._uniforms_shape)
        new_genes, source = next_generation(
            genes, scores, self._starts, s.elite, self._cdfs, uniforms, s.crossover_rate, s.mutation_rate
        )
        offspring = source < 0
        new_scores = np.empty(len(new_genes))
        new_scores[~offspring] = scores[source[~offspring]]
        new_scores[offspring] = self.objective(self.transforms(new_genes[offspring]))
        return new_genes, new_scores, int(offspring.sum())


def mutation_draws(rate: float) -> int:
    """Uniform draws per pair of children for the gaps between mutated bits (see `breed`):
    the mean number of mutations over the pair's 144 bits plus 8 standard deviations and 8."""
    n = 2 * GENES * BITS
    mean = n * rate
    return int(min(n, np.ceil(mean + 8.0 * np.sqrt(mean * (1.0 - rate)) + 8.0)))


def _ranking_cdf(size: int, pressure: float) -> FloatArray:
    """Cumulative linear-ranking selection probabilities of `size` individuals, best first."""
    probability = (pressure - 2 * (pressure - 1) * np.arange(size) / (size - 1)) / size
    return np.asarray(np.cumsum(probability / probability.sum()))


__all__ = [
    "BITS",
    "GENES",
    "GAResult",
    "GASettings",
    "GeneticAlgorithm",
    "SearchBounds",
    "decode",
    "encode",
    "parameters_from_transforms",
    "transforms_from_parameters",
]
