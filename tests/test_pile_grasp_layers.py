"""The pile grasp's layers (`grasp_point.choose_pile_grasp` with a `surface`): a cloth hidden
under the target, which no survey sees, shows as a higher top surface there; the grasp goes
where the surface lies one layer above the table. Synthetic surface functions of known
heights over a square target."""

from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError

from robot_app.control.grasp_point import PileGraspSettings, choose_pile_grasp, layers_beneath
from tests.test_clear_table_parts import _square

TABLE_Z = 0.7
ONE_LAYER = 0.008  # a lone cloth's surface above the table [m]
THREE_LAYERS = 0.040  # over two hidden cloths


def _pose() -> np.ndarray:
    pose = np.eye(4)
    pose[:3, 3] = (0.5, 0.1, TABLE_Z + 0.02)
    return pose


def _surface(low_from_x: float, calls: list[np.ndarray] | None = None):
    """The target lies on hidden cloths for x_W < 0.5 + `low_from_x`, on the table beyond."""

    def height(point_world: np.ndarray) -> float:
        if calls is not None:
            calls.append(np.array(point_world))
        return ONE_LAYER if point_world[0] >= 0.5 + low_from_x else THREE_LAYERS

    return height


def test_layers_beneath_count_from_the_table() -> None:
    heights = [0.004, 0.016, 0.020, 0.030, 0.040, np.nan, -0.002]
    np.testing.assert_array_equal(layers_beneath(heights, 0.017, 0.016), [0, 0, 1, 1, 2, np.nan, 0])


def test_the_grasp_goes_where_nothing_lies_under_the_target() -> None:
    model, pose = _square(), _pose()
    seen = np.ones(len(model.points_in), bool)
    # without the layers: the middle, over the hidden cloths (x_W < 0.53)
    old = choose_pile_grasp(model, pose, seen, np.empty((0, 2)))
    assert old is not None and abs(old.point_model[0]) < 1e-9
    calls: list[np.ndarray] = []
    chosen = choose_pile_grasp(model, pose, seen, np.empty((0, 2)), surface=_surface(0.03, calls))
    assert chosen is not None
    assert chosen.point_world[0] >= 0.53  # on the part lying on the table
    assert chosen.layers == 0 and chosen.surface == pytest.approx(ONE_LAYER) and chosen.moved
    assert chosen.edge_gap >= PileGraspSettings().min_edge_gap - 1e-9
    # the probes: the clearance choice first, at most `probes`, spread over the target
    probed = np.array(calls)
    assert chosen.probed == len(probed) <= PileGraspSettings().probes
    np.testing.assert_allclose(probed[0], old.point_world)
    assert np.ptp(probed[:, 0]) >= 0.1 and np.ptp(probed[:, 1]) >= 0.1
    assert chosen.layered == (int(np.sum(probed[:, 0] >= 0.53)), len(probed))
    # the same target all on the table, or all on the pile, or not measured: the old choice
    for height in (ONE_LAYER, THREE_LAYERS, np.nan):
        same = choose_pile_grasp(model, pose, seen, np.empty((0, 2)), surface=lambda _p, h=height: h)
        assert same is not None and not same.moved
        np.testing.assert_allclose(same.point_model, old.point_model)
    off = choose_pile_grasp(
        model, pose, seen, np.empty((0, 2)), PileGraspSettings(layers=False), surface=_surface(0.03)
    )
    assert off is not None and off.probed == 0 and np.isnan(off.layers)
    np.testing.assert_allclose(off.point_model, old.point_model)


def test_a_measured_single_layer_beats_an_unmeasured_point() -> None:
    model, pose = _square(), _pose()
    seen = np.ones(len(model.points_in), bool)

    def partly(point_world: np.ndarray) -> float:  # only the -y side is textured enough
        return ONE_LAYER if point_world[1] < 0.1 - 0.04 else np.nan

    chosen = choose_pile_grasp(model, pose, seen, np.empty((0, 2)), surface=partly)
    assert chosen is not None and chosen.layers == 0 and chosen.point_world[1] < 0.06

    def pile_or_unmeasured(point_world: np.ndarray) -> float:  # measured only where 2 layers lie under
        return THREE_LAYERS if point_world[1] < 0.1 - 0.04 else np.nan

    kept = choose_pile_grasp(model, pose, seen, np.empty((0, 2)), surface=pile_or_unmeasured)
    assert kept is not None and not kept.moved and np.isnan(kept.layers)


def test_the_layers_do_not_bring_the_grasp_next_to_another_cloth() -> None:
    model, pose = _square(), _pose()
    seen = np.ones(len(model.points_in), bool)
    # another cloth the survey saw lies 5 mm beyond the target's +x edge; the target lies on
    # the table only along that edge (x_M > 0.07), where the fingers would reach the other one
    xs, ys = np.meshgrid(np.arange(0.105, 0.2, 0.005), np.arange(-0.1, 0.1, 0.005))
    beside = np.column_stack([xs.ravel() + 0.5, ys.ravel() + 0.1])
    kept = choose_pile_grasp(model, pose, seen, beside, surface=_surface(0.071))
    assert kept is not None and not kept.moved and kept.clearance >= 0.06 - 1e-9
    near = choose_pile_grasp(
        model,
        pose,
        seen,
        beside,
        PileGraspSettings(layer_min_clearance=0.0, probes=20),
        surface=_surface(0.071),
    )
    assert near is not None and near.moved and near.layers == 0 and near.clearance < 0.04


@pytest.mark.parametrize(
    "bad",
    [
        {"probes": 0},
        {"probe_spacing": 0.0},
        {"on_table": -0.01},
        {"layer_step": 0.0},
        {"layer_min_clearance": -1},
    ],
)
def test_layer_settings_are_bounded(bad) -> None:
    with pytest.raises(ValidationError):
        PileGraspSettings(**bad)
