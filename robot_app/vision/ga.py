"""The 72-bit genetic algorithm of the paper (Sec. II-E), over a compiled fitness.

A chromosome is six 12-bit genes (t_x, t_y, t_z, ε1, ε2, ε3): the position of Σ_M in Σ_CR
and the vector part ε of a unit quaternion with ε0 = sqrt(1 - |ε|²) ≥ 0. Each gene maps
its 4096 levels linearly onto the `SearchBoundsSettings` range of its variable, Gray-coded by
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
peak does not take the whole search with it.

The objective is an argument of each call (`run(fitness, n)`, `evolve(fitness, n)`), a
`KernelFitness`: all generations of a call run in one compiled loop
(`ga_kernels.evolve`). A caller that wants cheap early generations calls `run` with a
strided fitness and `evolve` with the full one; the kept population is re-scored by the
new objective. The RNG is a seeded `np.random.Generator`: same seed, same result. The
multi-step (tracking) use of the GA is the proposal stage's (`propose.Proposer.track`):
it seeds a GA with moved poses (`seed`) and evolves a few generations.
"""

from __future__ import annotations

import functools
import itertools
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from pydantic import Field, model_validator

from robot_app.arrays import FloatArray
from robot_app.config import SettingValueError, StrictModel
from robot_app.vision.fitness import KernelFitness
from robot_app.vision.ga_kernels import evolve
from robot_app.vision.pose_kernels import transforms_from_genes
from robot_app.vision.poses import GENES, as_poses, parameters_from_transforms

BITS = 12
LEVELS = (1 << BITS) - 1  # highest gene value, 4095
Genes = npt.NDArray[np.uint16]


class SearchBoundsSettings(StrictModel):
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
    def _ranges_increase(self) -> SearchBoundsSettings:
        for name in ("x", "y", "z"):
            low, high = getattr(self, name)
            if not low < high:
                raise SettingValueError(
                    name, f"{name} range must be (low, high) with low < high", list(getattr(self, name))
                )
        if self.z[0] <= 0:
            raise SettingValueError("z", "z range must be in front of the camera (z > 0)", list(self.z))
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
            raise SettingValueError(
                "population", "population must hold at least 4 individuals per island", self.population
            )
        if self.elite >= self.population // self.islands:
            raise SettingValueError(
                "elite", "elite must be smaller than each island's population", self.elite
            )
        return self

    def island_slices(self) -> list[slice]:
        """The individuals of each island in the population array."""
        return list(_island_slices(self.population, self.islands))


def encode(parameters: npt.ArrayLike, bounds: SearchBoundsSettings, gray_code: bool = True) -> Genes:
    """(P, 6) (t_x, t_y, t_z, ε1, ε2, ε3) -> (P, 6) genes; values outside the bounds are clipped."""
    x = np.asarray(parameters, dtype=float).reshape(-1, GENES)
    ranges = bounds.gene_ranges()
    scaled = (x - ranges[:, 0]) / (ranges[:, 1] - ranges[:, 0]) * LEVELS
    genes = np.clip(np.rint(scaled), 0, LEVELS).astype(np.uint16)
    return (genes ^ (genes >> 1)).astype(np.uint16) if gray_code else genes


def decode(genes: Genes, bounds: SearchBoundsSettings, gray_code: bool = True) -> FloatArray:
    """(P, 6) genes -> (P, 6) (t_x, t_y, t_z, ε1, ε2, ε3) [m, -]."""
    g = np.asarray(genes, dtype=np.uint16).reshape(-1, GENES).copy()
    if gray_code:
        for shift in (1, 2, 4, 8):
            g ^= g >> shift
    ranges = bounds.gene_ranges()
    return ranges[:, 0] + g / LEVELS * (ranges[:, 1] - ranges[:, 0])


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
    """The GA's population between calls, its bounds, settings and random generator."""

    def __init__(
        self,
        bounds: SearchBoundsSettings | None = None,
        settings: GASettings | None = None,
        rng: np.random.Generator | None = None,
    ) -> None:
        self.bounds = bounds if bounds is not None else SearchBoundsSettings()
        self.settings = settings if settings is not None else GASettings()
        self.rng = rng if rng is not None else np.random.default_rng(self.settings.seed)
        self.population: Genes | None = None
        self.scores: FloatArray | None = None
        ranges = self.bounds.gene_ranges()
        self._lows, self._spans = ranges[:, 0].copy(), ranges[:, 1] - ranges[:, 0]
        s = self.settings
        self._islands, self._starts, self._uniforms_shape, self._cdfs = _breeding_layout(
            s.population, s.islands, s.elite, s.mutation_rate, s.selection_pressure
        )

    def islands(self) -> list[tuple[Genes, FloatArray]]:
        """(genes, scores) of each island's current individuals."""
        if self.population is None or self.scores is None:
            raise RuntimeError("no population yet: call run() first")
        return [(self.population[sl], self.scores[sl]) for sl in self._islands]

    def transforms(self, genes: Genes) -> FloatArray:
        """(P, 4, 4) poses of (P, 6) genes."""
        return transforms_from_genes(genes, self._lows, self._spans, self.settings.gray_code)

    def best_pose(self) -> FloatArray:
        """(4, 4) the best individual's pose."""
        if self.population is None or self.scores is None:
            raise RuntimeError("no population yet: call run() first")
        best = int(np.argmax(self.scores))
        return self.transforms(self.population[best : best + 1])[0]

    def ranked_poses(self, count: int) -> FloatArray:
        """(min(count, P), 4, 4) the best `count` individuals' poses, best first."""
        if self.population is None or self.scores is None:
            raise RuntimeError("no population yet: call run() first")
        order = np.argsort(-self.scores, kind="stable")[:count]
        return self.transforms(self.population[order])

    def random_genes(self) -> Genes:
        """A random population (see `GASettings.uniform_yaw`), drawn from the generator."""
        s = self.settings
        genes = self.rng.integers(0, LEVELS + 1, (s.population, GENES), dtype=np.uint16)
        if s.uniform_yaw:
            yaw = np.deg2rad(self.bounds.max_yaw_deg) * self.rng.uniform(-1.0, 1.0, s.population)
            parameters = decode(genes, self.bounds, s.gray_code)
            parameters[:, 5] = np.sin(yaw / 2.0)
            genes[:, 5] = encode(parameters, self.bounds, s.gray_code)[:, 5]
        return genes

    def run(self, fitness: KernelFitness, generations: int | None = None) -> GAResult:
        """One-shot search: a random population evolved `generations` (default: settings) times."""
        count = self.settings.generations if generations is None else generations
        return self._evolve(fitness, self.random_genes(), count)

    def seed(self, transforms_model_to_camera: npt.ArrayLike) -> None:
        """Makes (P, 4, 4) poses the population (clipped into the bounds; P = settings.population)."""
        poses = as_poses(transforms_model_to_camera)
        if len(poses) != self.settings.population:
            raise ValueError(f"seed needs {self.settings.population} poses, got {len(poses)}")
        self.population = encode(parameters_from_transforms(poses), self.bounds, self.settings.gray_code)
        self.scores = None

    def evolve(self, fitness: KernelFitness, generations: int) -> GAResult:
        """Continues from the kept population, re-scored by `fitness` first."""
        if self.population is None:
            raise RuntimeError("evolve() needs a population: call run() or seed() first")
        return self._evolve(fitness, self.population, generations)

    def _evolve(self, fitness: KernelFitness, genes: Genes, generations: int) -> GAResult:
        """`generations` generations in `ga_kernels.evolve` (all draws made up front)."""
        if generations < 0:
            raise ValueError(f"generations must be >= 0, got {generations}")
        if fitness.subpixel:
            raise ValueError("the GA scores at the nearest pixel: give it a fitness without subpixel")
        s = self.settings
        scores = fitness(self.transforms(genes))
        history = [float(scores.max())]
        evaluations = len(genes)
        if generations > 0:
            uniforms = self.rng.random((generations, *self._uniforms_shape))
            arguments, normalisation = fitness.kernel_arguments()
            genes, scores, evaluated, best = evolve(
                genes, scores, self._starts, s.elite, self._cdfs, uniforms, s.crossover_rate,
                s.mutation_rate, self._lows, self._spans, s.gray_code, arguments, normalisation,
                fitness.avoid.kernel_arguments(),
            )  # fmt: skip
            fitness.count(int(evaluated))
            evaluations += int(evaluated)
            history.extend(np.asarray(best).tolist())
        self.population, self.scores = genes, scores
        best_index = int(np.argmax(scores))
        return GAResult(
            self.transforms(genes[best_index : best_index + 1])[0],
            float(scores[best_index]),
            generations,
            evaluations,
            np.array(history),
        )

    def draws_per_generation(self) -> tuple[int, int]:
        """Shape of the uniform draws one generation takes (for a test oracle)."""
        return self._uniforms_shape

    def breeding_tables(self) -> tuple[npt.NDArray[np.int64], FloatArray]:
        """(island starts, ranking cdfs), as `ga_kernels.next_generation` takes them."""
        return self._starts, self._cdfs


def mutation_draws(rate: float) -> int:
    """Uniform draws per pair of children for the gaps between mutated bits (see `breed`):
    the mean number of mutations over the pair's 144 bits plus 8 standard deviations and 8."""
    n = 2 * GENES * BITS
    mean = n * rate
    return int(min(n, np.ceil(mean + 8.0 * np.sqrt(mean * (1.0 - rate)) + 8.0)))


def _island_slices(population: int, islands: int) -> tuple[slice, ...]:
    bounds = np.linspace(0, population, islands + 1).round().astype(int)
    return tuple(slice(int(a), int(b)) for a, b in itertools.pairwise(bounds))


@functools.lru_cache(maxsize=16)
def _breeding_layout(
    population: int, islands: int, elite: int, mutation_rate: float, pressure: float
) -> tuple[tuple[slice, ...], npt.NDArray[np.int64], tuple[int, int], FloatArray]:
    """(island slices, island starts, one generation's uniforms shape, ranking cdfs) of
    these settings, computed once per process (a tracking frame builds a GA in a new
    window each time; these tables do not depend on it). Shared: never write into them."""
    slices = _island_slices(population, islands)
    starts = np.array([sl.start for sl in slices] + [population], np.int64)
    sizes = [sl.stop - sl.start for sl in slices]
    pairs = sum((size - elite + 1) // 2 for size in sizes)
    cdfs = np.ones((len(slices), max(sizes)))
    for i, size in enumerate(sizes):
        cdfs[i, :size] = _ranking_cdf(size, pressure)
    return slices, starts, (pairs, 5 + mutation_draws(mutation_rate)), cdfs


def _ranking_cdf(size: int, pressure: float) -> FloatArray:
    """Cumulative linear-ranking selection probabilities of `size` individuals, best first."""
    probability = (pressure - 2 * (pressure - 1) * np.arange(size) / (size - 1)) / size
    return np.asarray(np.cumsum(probability / probability.sum()))


__all__ = [
    "BITS",
    "GAResult",
    "GASettings",
    "GeneticAlgorithm",
    "SearchBoundsSettings",
    "decode",
    "encode",
    "mutation_draws",
]
