"""The 72-bit GA: chromosome coding, repair, seeded determinism, convergence and tracking."""

from __future__ import annotations

import numpy as np
import pytest

from robot_app.config import validate
from robot_app.errors import ConfigError
from robot_app.geometry import is_rotation, make_transform, rotation_about_z, rotation_from_rpy, yaw_of
from robot_app.vision.ga import (
    GASettings,
    GeneticAlgorithm,
    SearchBoundsSettings,
    decode,
    encode,
)
from robot_app.vision.poses import parameters_from_transforms, transforms_from_parameters
from tests.vision_oracles import ga_evolve, ga_run

BOUNDS = SearchBoundsSettings()


def random_parameters(rng: np.random.Generator, n: int) -> np.ndarray:
    ranges = BOUNDS.gene_ranges()
    x = rng.uniform(ranges[:, 0], ranges[:, 1], (n, 6))
    x[:, 5] = rng.uniform(-0.95, 0.95, n)  # keep |ε| < 1: no repair
    return x


@pytest.mark.parametrize("gray", [True, False])
def test_encode_decode_round_trip_to_one_level(gray: bool) -> None:
    rng = np.random.default_rng(0)
    x = random_parameters(rng, 500)
    back = decode(encode(x, BOUNDS, gray), BOUNDS, gray)
    level = np.ptp(BOUNDS.gene_ranges(), axis=1) / 4095
    assert np.all(np.abs(back - x) <= level / 2 + 1e-12)
    assert np.all(encode(x, BOUNDS, gray) < 4096)


def test_gray_code_neighbouring_levels_differ_by_one_bit() -> None:
    ranges = BOUNDS.gene_ranges()
    values = np.zeros((4095, 6))
    values[:, 0] = ranges[0, 0] + np.arange(4095) / 4095 * np.ptp(ranges[0])
    values[:, 1:] = ranges[1:, 0]
    a = encode(values, BOUNDS)[:, 0].astype(int)
    b = encode(values + np.array([np.ptp(ranges[0]) / 4095, 0, 0, 0, 0, 0]), BOUNDS)[:, 0].astype(int)
    assert all(bin(x ^ y).count("1") == 1 for x, y in zip(a, b, strict=True))


def test_parameters_and_transforms_are_inverse_and_repair_long_epsilon() -> None:
    rng = np.random.default_rng(1)
    x = random_parameters(rng, 200)
    T = transforms_from_parameters(x)
    assert all(is_rotation(R, tol=1e-9) for R in T[:, :3, :3])
    np.testing.assert_allclose(parameters_from_transforms(T), x, atol=1e-9)
    # Half turns about x, y and z (each of Shepperd's four branches) come back exactly.
    diagonals = ((1, -1, -1), (-1, 1, -1), (-1, -1, 1))
    half_turns = np.array([make_transform(np.diag(d), [0.01, 0.02, 0.6]) for d in diagonals])
    back = transforms_from_parameters(parameters_from_transforms(half_turns))
    np.testing.assert_allclose(back, half_turns, atol=1e-12)
    long = transforms_from_parameters([[0, 0, 0.6, 0.17, 0.17, 1.0]])[0]  # |ε| > 1: normalised
    assert is_rotation(long[:3, :3], tol=1e-9)
    # A yaw of the cloth is a rotation about the camera z axis with ε = (0, 0, sin(yaw / 2)).
    yaw = transforms_from_parameters([[0, 0, 0.6, 0, 0, np.sin(0.7 / 2)]])[0]
    np.testing.assert_allclose(yaw[:3, :3], rotation_about_z(0.7), atol=1e-12)


def test_tilt_bound_is_respected_along_the_axes() -> None:
    ranges = SearchBoundsSettings(max_tilt_deg=20).gene_ranges()
    T = transforms_from_parameters([[0, 0, 0.6, ranges[3, 1], 0, 0]])[0]
    assert np.rad2deg(np.arccos(T[2, 2])) == pytest.approx(20.0)


def target_fitness(target: np.ndarray):
    def fitness(T: np.ndarray) -> np.ndarray:
        d = np.linalg.norm(T[:, :3, 3] - target[:3, 3], axis=1)
        angle = np.linalg.norm(T[:, :3, :3] - target[:3, :3], axis=(1, 2))
        return 1.0 / (1.0 + 100 * d + angle)

    return fitness


TARGET = make_transform(rotation_from_rpy(0.05, -0.03, 2.0), [0.1, -0.05, 0.6])


@pytest.mark.parametrize("islands", [1, 4])
def test_run_converges_and_same_seed_gives_same_result(islands: int) -> None:
    # The algorithm (the compiled breeding of `next_generation`) on an analytic fitness,
    # through the Python oracle loop that the compiled loop equals bit for bit (below).
    settings = GASettings(population=60, generations=80, seed=4, islands=islands)
    first = ga_run(GeneticAlgorithm(BOUNDS, settings), target_fitness(TARGET), 80)
    again = ga_run(GeneticAlgorithm(BOUNDS, settings), target_fitness(TARGET), 80)
    other_settings = GASettings(population=60, generations=80, seed=5, islands=islands)
    other = ga_run(GeneticAlgorithm(BOUNDS, other_settings), target_fitness(TARGET), 80)
    assert np.linalg.norm(first.transform_model_to_camera[:3, 3] - TARGET[:3, 3]) < 0.01
    np.testing.assert_array_equal(first.transform_model_to_camera, again.transform_model_to_camera)
    assert not np.array_equal(first.transform_model_to_camera, other.transform_model_to_camera)
    assert first.evaluations == 60 + 80 * (60 - islands * settings.elite)  # each island keeps its elite
    assert np.all(np.diff(first.best_per_generation) >= 0)  # elitism: the best never gets worse


@pytest.mark.parametrize("uniform_yaw", [True, False])
def test_the_random_population_covers_every_yaw_evenly(uniform_yaw: bool) -> None:
    settings = GASettings(population=4000, islands=1, uniform_yaw=uniform_yaw)
    ga = GeneticAlgorithm(BOUNDS, settings)
    ga.population = ga.random_genes()
    yaws = np.array([yaw_of(T[:3, :3]) for T in ga.transforms(ga.population)])
    near_half_turn = np.mean(np.abs(yaws) > np.deg2rad(160.0))  # 40° of the 360°: 11 %
    near_zero = np.mean(np.abs(yaws) < np.deg2rad(20.0))
    if uniform_yaw:  # (|ε| > 1 is normalised onto ε0 = 0, a half turn: a little more there)
        assert 0.09 < near_zero < 0.13 and 0.8 < near_half_turn / near_zero < 1.5
    else:  # uniform in ε3 = sin(yaw / 2): a half turn is drawn several times less often than 0°
        assert near_half_turn / near_zero < 0.25


def test_seed_makes_poses_the_population_clipped_into_the_bounds() -> None:
    ga = GeneticAlgorithm(BOUNDS, GASettings(population=8, islands=1))
    poses = np.repeat(TARGET[None], 8, axis=0)
    poses[-1, 0, 3] = 1.0  # far outside x
    ga.seed(poses)
    back = ga.transforms(ga.population)
    np.testing.assert_allclose(back[:7, :3, 3], poses[:7, :3, 3], atol=2e-4)
    assert back[-1, 0, 3] == pytest.approx(BOUNDS.x[1])
    with pytest.raises(ValueError, match="8 poses"):
        ga.seed(poses[:3])


def test_settings_are_validated() -> None:
    cases = [
        (GASettings, {"population": 16, "islands": 4, "elite": 4}, "elite", 4),  # 4 per island
        (GASettings, {"population": 12, "islands": 4}, "population", 12),
        (GASettings, {"mutation_rate": 2}, "mutation_rate", 2),
        (SearchBoundsSettings, {"x": [0.1, -0.1]}, "x", [0.1, -0.1]),
        (SearchBoundsSettings, {"z": [-0.1, 0.5]}, "z", [-0.1, 0.5]),
    ]
    for settings, data, key, value in cases:
        with pytest.raises(ConfigError) as bad:
            validate(settings, data)
        assert (bad.value.key, bad.value.value) == (key, value)
    validate(GASettings, {"population": 16, "islands": 4, "elite": 3})


def test_islands_breed_only_among_themselves() -> None:
    # Two targets far apart: islands that converged on different ones stay there.
    other = make_transform(rotation_from_rpy(0.0, 0.0, -1.0), [-0.15, 0.1, 0.6])
    near_a, near_b = target_fitness(TARGET), target_fitness(other)

    def two_peaks(T: np.ndarray) -> np.ndarray:
        return np.maximum(near_a(T), near_b(T))

    ga = GeneticAlgorithm(BOUNDS, GASettings(population=40, generations=1, seed=1, islands=2))
    ga.population = ga.random_genes()
    half = len(ga.population) // 2
    # Seed each island with copies of one target only; evolution must not mix them.
    ga.population[:half] = encode(parameters_from_transforms(np.repeat(TARGET[None], half, 0)), BOUNDS)
    ga.population[half:] = encode(parameters_from_transforms(np.repeat(other[None], half, 0)), BOUNDS)
    ga_evolve(ga, two_peaks, ga.population, 5)
    for (genes, _), centre in zip(ga.islands(), (TARGET, other), strict=True):
        positions = ga.transforms(genes)[:, :3, 3]
        # mutation moves individuals a little, never to the other island's target
        assert np.median(np.linalg.norm(positions - centre[:3, 3], axis=1)) < 0.02


@pytest.mark.parametrize("rate", [0.0, 0.02, 0.3, 1.0])
def test_mutation_flips_each_bit_with_the_mutation_rate(rate: float) -> None:
    from robot_app.vision.ga import mutation_draws
    from robot_app.vision.ga_kernels import breed

    rng = np.random.default_rng(3)
    parent = rng.integers(0, 4096, (1, 6)).astype(np.uint16)
    uniforms = rng.random((10000, 5 + mutation_draws(rate)))
    uniforms[:, 2] = 1.0  # no crossover: every difference from the parent is a mutation
    children = breed(parent, np.array([1.0]), uniforms, 20000, 0.9, rate)
    flipped = np.unpackbits((children ^ parent).view(np.uint8)).reshape(len(children), -1).sum(axis=1)
    assert flipped.mean() / 72 == pytest.approx(rate, abs=0.003)


def test_two_point_crossover_swaps_the_bits_between_the_cuts() -> None:
    from robot_app.vision.ga_kernels import breed

    parents = np.array([[0] * 6, [4095] * 6], np.uint16)
    cut_6, cut_15 = 6.5 / 73, 15.5 / 73  # bits [6, 15) of the 72 are swapped
    uniforms = np.array([[0.1, 0.9, 0.0, cut_6, cut_15]])
    first, second = breed(parents, np.array([0.5, 1.0]), uniforms, 2, 1.0, 0.0)
    assert [int(g) for g in first] == [0b000000111111, 0b111000000000, 0, 0, 0, 0]
    assert [int(g) for g in second] == [0b111111000000, 0b000111111111] + [4095] * 4


@pytest.mark.parametrize("avoiding", [False, True])
def test_compiled_generations_equal_the_python_loop_bit_for_bit(avoiding: bool) -> None:
    from robot_app.vision.camera import ModelCamera, PinholeCamera, StereoRig
    from robot_app.vision.fitness import FitnessEvaluator, KernelFitness
    from robot_app.vision.photo_model import make_model
    from robot_app.vision.poses import AvoidedPoses
    from robot_app.vision.synthetic import render_model_photo, render_stereo_pair
    from robot_app.vision.synthetic_catalogue import synthetic_cloth

    camera = PinholeCamera.from_fov((320, 240), np.deg2rad(48))
    rig = StereoRig(camera, camera, make_transform(np.eye(3), [-0.1, 0.0, 0.0]))
    model_camera = ModelCamera(PinholeCamera.from_fov((640, 480), np.deg2rad(48)), 0.40)
    photo, background = render_model_photo(synthetic_cloth(5), model_camera)
    pose = make_transform(rotation_about_z(0.3), [0.01, 0.02, 0.58])
    left, right = render_stereo_pair(rig, [(synthetic_cloth(5), pose)], rng=np.random.default_rng(2))
    evaluator = FitnessEvaluator(make_model(photo, model_camera, background), rig)
    evaluator.update(left, right)
    # avoiding: the cloth's own pose (within 45° of its yaw) and a spot beside it (any yaw)
    avoid = AvoidedPoses(np.array([[0.01, 0.02, 0.3], [-0.05, 0.0, np.nan]]), 0.03, np.deg2rad(45.0))
    compiled = KernelFitness(evaluator, stride=2, avoid=avoid if avoiding else None)
    settings = GASettings(islands=4)
    before = evaluator.evaluations
    ga_a = GeneticAlgorithm(BOUNDS, settings, np.random.default_rng(9))
    run_a = ga_a.run(compiled, 30)
    count_a = evaluator.evaluations - before
    before = evaluator.evaluations
    ga_b = GeneticAlgorithm(BOUNDS, settings, np.random.default_rng(9))
    run_b = ga_run(ga_b, lambda T: compiled(T), 30)  # the Python oracle loop
    count_b = evaluator.evaluations - before
    assert np.array_equal(ga_a.population, ga_b.population) and np.array_equal(ga_a.scores, ga_b.scores)
    assert np.array_equal(run_a.best_per_generation, run_b.best_per_generation)
    assert run_a.evaluations == run_b.evaluations == count_a == count_b
    assert run_a.generations == run_b.generations == 30
    assert run_a.fitness > 0.5  # it did search: the cloth is there
    if avoiding:  # every pose in the avoided regions scored -1, and the best lies outside them
        poses = ga_a.transforms(ga_a.population)
        inside = avoid.mask(poses)
        assert inside.any() and np.all(ga_a.scores[inside] == -1.0)
        assert not avoid.mask(run_a.transform_model_to_camera[None])[0]


def test_the_ga_refuses_a_subpixel_fitness() -> None:
    from robot_app.vision.fitness import KernelFitness

    fitness = KernelFitness(object(), subpixel=True)  # never called: refused before
    with pytest.raises(ValueError, match="nearest pixel"):
        GeneticAlgorithm(BOUNDS, GASettings(population=8, islands=1)).run(fitness, 1)
