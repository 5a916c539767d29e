"""Cloths lying on cloths keep their side of each other (`sim.cloth_layers`): pybullet's
soft contact let resting layers sink through each other within seconds, and lifts then
brought the hooked cloths under the lifted one up with it."""

from __future__ import annotations

import numpy as np

from robot_app.config import load_config
from robot_app.experiments.clear_table import ClearTableConfig
from robot_app.sim import World
from robot_app.sim.cloth_layers import GAP, LayerKeeper
from robot_app.sim.fresh_process import run_in_fresh_process
from robot_app.sim.pile import make_pile
from tests.test_pile_physics import CONFIG, STACK, _below

TABLE = 0.0


class Sheet:
    """A flat square of nodes 35 mm apart, `z` over the table, as the keeper reads a cloth."""

    def __init__(self, body_id: int, z: float, offset: float = 0.0) -> None:
        u, v = np.meshgrid(np.arange(5) * 0.035, np.arange(5) * 0.035)
        self.body_id = body_id
        self.nodes = np.stack([u.ravel() + offset, v.ravel(), np.full(u.size, z)], axis=1)
        self.held = np.zeros(len(self.nodes), dtype=bool)
        self.is_grasped = False

    def simulation_nodes(self) -> np.ndarray:
        return self.nodes.copy()

    def set_free_heights(self, heights: np.ndarray) -> int:
        change = (heights != self.nodes[:, 2]) & ~self.held
        self.nodes[change, 2] = heights[change]
        return int(change.sum())


def test_a_node_that_sinks_through_the_cloth_under_it_is_set_back_on_top() -> None:
    under, over = Sheet(1, 0.008), Sheet(2, 0.024)
    keeper = LayerKeeper()
    assert keeper.keep([under, over], TABLE) == 0  # the sides are taken, nothing crossed
    over.nodes[12, 2] = 0.004  # sank 4 mm through the cloth under it
    over.nodes[13, 2] = 0.010  # lower, but still above it
    assert keeper.keep([under, over], TABLE) >= 1
    # both are set back on their sides, GAP from where the other was
    assert over.nodes[12, 2] == np.float64(0.008 + GAP)
    assert under.nodes[12, 2] < over.nodes[12, 2]
    assert over.nodes[13, 2] == 0.010
    assert np.all(under.nodes[np.arange(25) != 12, 2] == 0.008)  # the rest of it stays


def test_a_held_cloth_and_far_crossings_are_left_alone() -> None:
    under, over = Sheet(1, 0.008), Sheet(2, 0.024)
    keeper = LayerKeeper()
    keeper.keep([under, over], TABLE)
    over.nodes[0, 2] = 0.008 - 0.05  # 5 cm across in one check: not a crossing (a fall)
    assert keeper.keep([under, over], TABLE) == 0
    under, over, keeper = Sheet(1, 0.008), Sheet(2, 0.024), LayerKeeper()
    keeper.keep([under, over], TABLE)
    over.is_grasped = True  # in the hand: what it drags along is friction, kept
    over.nodes[12, 2] = 0.004
    assert keeper.keep([under, over], TABLE) == 0
    assert over.nodes[12, 2] == 0.004 and np.all(under.nodes[:, 2] == 0.008)


def test_with_held_too_the_free_cloths_keep_their_side_of_the_held_one() -> None:
    """`world.cloth.keep_layers_held`: the held cloth is never moved; the cloth lying on it is
    carried up as it rises, the cloth under it is held back under it."""
    under, held = Sheet(1, 0.008), Sheet(2, 0.024)
    keeper = LayerKeeper()
    keeper.keep([under, held], TABLE, held_too=True)
    held.is_grasped = True
    held.nodes[12, 2] = 0.004  # pressed through the cloth under it
    assert keeper.keep([under, held], TABLE, held_too=True) >= 1
    assert held.nodes[12, 2] == 0.004  # the held cloth stays where the hand has it
    assert under.nodes[12, 2] < 0.004  # the free one is kept under it
    held, over, keeper = Sheet(1, 0.008), Sheet(2, 0.024), LayerKeeper()
    keeper.keep([held, over], TABLE, held_too=True)
    held.is_grasped = True
    held.nodes[12, 2] = 0.030  # lifted through the cloth lying on it
    assert keeper.keep([held, over], TABLE, held_too=True) >= 1
    assert held.nodes[12, 2] == 0.030
    assert over.nodes[12, 2] > 0.030  # carried up on it
    assert np.all(over.nodes[np.arange(25) != 12, 2] == 0.024)


def test_a_node_that_went_round_the_edge_forgets_its_side() -> None:
    under, over = Sheet(1, 0.008), Sheet(2, 0.024, offset=0.1)  # two columns over the other
    keeper = LayerKeeper()
    keeper.keep([under, over], TABLE)
    over.nodes[:, 0] += 0.2  # slid off the other cloth: no node of it within reach
    keeper.keep([under, over], TABLE)
    over.nodes[:, 0] -= 0.2
    over.nodes[:, 2] = 0.004  # back, now under it: a new side, not a crossing
    assert keeper.keep([under, over], TABLE) == 0


def _rest_stack() -> tuple[list[tuple[float, int, int]], int]:
    """The stack left for 8 s: (time, No.9's nodes under No.3, No.5's under No.9) every 2 s,
    and the keeper's corrections."""
    config = load_config(ClearTableConfig, CONFIG, STACK)
    crossed = []
    with World(config.world) as world:
        pile = make_pile(world, config.pile, seed=0)
        for _ in range(4):
            world.step(int(2.0 / world.dt))
            nodes = [c.body.nodes() for c in pile.cloths]
            crossed.append((world.time, _below(nodes[0], nodes[1]), _below(nodes[1], nodes[2])))
        return crossed, world.layer_corrections


def test_a_resting_stack_keeps_its_layers() -> None:
    """No.5 on No.9 on No.3, left for 8 s: without the keeper, nodes of No.9 sank through
    No.3 after 6 s (2-3 nodes more than 4 mm under it). In a fresh process
    (`sim.fresh_process`): a pile settles differently after another world ran in the same
    one (after the stack test of test_pile_physics, No.3 folded a flap over No.9, and the
    keeper does not tell two layers of one cloth apart)."""
    crossed, corrections = run_in_fresh_process(_rest_stack)
    assert all(under == 0 and over == 0 for _, under, over in crossed), crossed
    assert corrections > 0  # the keeper had work to do
