"""The pile grasp with the gripper's reach (`PileGraspSettings.reach`): the preferences for a
point deep inside the target and a short hanging length give way when only a point nearer the
edge or farther out lies out of the gripper's reach of every other cloth. Ground truth: the
clearance and edge gap computed point by point on synthetic cloths."""

from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError

from robot_app.control.grasp_point import PileGraspSettings, choose_pile_grasp
from robot_app.vision import ClothModel

REACH = 0.035
POSE = np.eye(4)
POSE[:3, 3] = (0.5, 0.1, 0.72)  # Σ_M's origin at (0.5, 0.1) on the table, axes as Σ_W's


def _square(side: float = 0.2, step: float = 0.005) -> ClothModel:
    """A square cloth of `side` [m]: S_in on a grid, S_out a band 10 mm outside its edge."""
    grid = np.arange(-side / 2, side / 2 + 1e-9, step)
    u, v = np.meshgrid(grid, grid)
    points = np.column_stack([u.ravel(), v.ravel(), np.zeros(u.size)])
    ring = np.arange(-side / 2 - 0.01, side / 2 + 0.01 + 1e-9, step)
    edge = side / 2 + 0.01
    out = np.concatenate(
        [np.column_stack([ring, np.full(ring.size, s * edge)]) for s in (-1, 1)]
        + [np.column_stack([np.full(ring.size, s * edge), ring]) for s in (-1, 1)]
    )
    out = np.column_stack([out, np.zeros(len(out))])
    return ClothModel("sq", points, np.full(len(points), 10, np.uint16), out, 85.0, np.zeros(3), (side, side))


def _cloth_under(x_min: float, x_max: float, y_min: float = -0.2, y_max: float = 0.2) -> np.ndarray:
    """(M, 2) Σ_W points of another cloth covering x_M in [x_min, x_max] (a 2.5 mm grid)."""
    xs, ys = np.meshgrid(np.arange(x_min, x_max + 1e-9, 0.0025), np.arange(y_min, y_max + 1e-9, 0.0025))
    return np.column_stack([xs.ravel(), ys.ravel()]) + POSE[:2, 3]


def _truth(model: ClothModel, obstacles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per S_in point: the distance to the nearest obstacle and to the nearest S_out point, brute force."""
    world = model.points_in[:, :2] + POSE[:2, 3]
    clear = np.sqrt(((world[:, None] - obstacles[None]) ** 2).sum(axis=2)).min(axis=1)
    inside, outside = model.points_in[:, None, :2], model.points_out[None, :, :2]
    edge = np.sqrt(((inside - outside) ** 2).sum(axis=2)).min(axis=1)
    return clear, edge


def _index(model: ClothModel, point_model: np.ndarray) -> int:
    return int(np.argmin(np.linalg.norm(model.points_in[:, :2] - point_model[:2], axis=1)))


def test_a_clear_point_near_the_edge_beats_a_deep_one_within_reach() -> None:
    model = _square()
    seen = np.ones(len(model.points_in), bool)
    under = _cloth_under(-0.3, 0.052)  # another cloth under all but the target's strip x_M > 0.052
    clear, edge = _truth(model, under)
    deep = choose_pile_grasp(model, POSE, seen, under, PileGraspSettings(min_edge_gap=0.027))
    assert deep is not None and deep.clearance < REACH  # the old rule: 27 mm inside, within reach
    settings = PileGraspSettings(min_edge_gap=0.027, reach=REACH, edge_gap_floor=0.012)
    chosen = choose_pile_grasp(model, POSE, seen, under, settings)
    assert chosen is not None
    k = _index(model, chosen.point_model)
    assert chosen.clearance == pytest.approx(clear[k]) and chosen.edge_gap == pytest.approx(edge[k])
    assert chosen.clearance >= REACH and chosen.edge_gap >= 0.012
    # the clearest point of all those at least the floor inside the edge
    assert clear[k] == pytest.approx(np.minimum(clear[edge >= 0.012], 0.06).max())
    np.testing.assert_allclose(chosen.point_world, POSE[:3, :3] @ chosen.point_model + POSE[:3, 3])


def test_a_clear_point_with_a_longer_hanging_length_beats_a_short_one_within_reach() -> None:
    model = _square()
    seen = np.ones(len(model.points_in), bool)
    under = _cloth_under(-0.02, 0.3)  # under the half x_M > -0.02; the middle is within reach
    clear, edge = _truth(model, under)
    short = PileGraspSettings(min_edge_gap=0.02, max_reach=0.15)
    old = choose_pile_grasp(model, POSE, seen, under, short)
    assert old is not None and old.clearance < REACH
    chosen = choose_pile_grasp(model, POSE, seen, under, short.model_copy(update={"reach": REACH}))
    assert chosen is not None
    k = _index(model, chosen.point_model)
    assert clear[k] >= REACH and edge[k] >= 0.02 - 1e-9  # still the full edge gap: the first widening
    assert chosen.point_model[0] < -0.02 - REACH + 1e-9


def test_without_a_clear_point_or_with_one_in_the_first_pool_the_choice_is_unchanged() -> None:
    model = _square()
    seen = np.ones(len(model.points_in), bool)
    settings = PileGraspSettings(min_edge_gap=0.02)
    with_reach = settings.model_copy(update={"reach": REACH})
    for under in (_cloth_under(-0.3, 0.3), _cloth_under(0.03, 0.3), np.empty((0, 2))):
        old = choose_pile_grasp(model, POSE, seen, under, settings)
        new = choose_pile_grasp(model, POSE, seen, under, with_reach)
        assert old is not None and new is not None
        np.testing.assert_array_equal(old.point_model, new.point_model)
    covered = choose_pile_grasp(model, POSE, seen, _cloth_under(-0.3, 0.3), with_reach)
    assert covered is not None and covered.clearance < REACH and covered.edge_gap >= 0.02 - 1e-9


def test_reach_settings_are_validated() -> None:
    assert PileGraspSettings().reach == 0.0  # off unless configured
    with pytest.raises(ValidationError):
        PileGraspSettings(reach=-0.01)
    with pytest.raises(ValidationError):
        PileGraspSettings(edge_gap_floor=-0.001)
