"""Cloths lying on cloths keep their side of each other (`sim.cloth_layers`): pybullet's
soft contact let resting layers sink through each other within seconds, and lifts then
brought the hooked cloths under the lifted one up with it."""

from __future__ import annotations

import numpy as np

from robot_app.config import load_config
from robot_app.experiments.clear_table import ClearTableConfig
from robot_app.sim import World
from robot_app.sim.cloth_layers import GAP, UNCROSS_EVERY, LayerKeeper
from robot_app.sim.fresh_process import run_in_fresh_process
from robot_app.sim.mesh_crossing import crossed_edges
from robot_app.sim.pile import make_pile
from tests.test_pile_physics import CONFIG, STACK, _below

TABLE = 0.0


class Sheet:
    """A flat square of nodes 35 mm apart, `z` over the table, as the keeper reads a cloth."""

    def __init__(self, body_id: int, z: float, offset: float = 0.0, shift: float = 0.0) -> None:
        u, v = np.meshgrid(np.arange(5) * 0.035, np.arange(5) * 0.035)
        self.body_id = body_id
        self.nodes = np.stack([u.ravel() + offset, v.ravel() + shift, np.full(u.size, z)], axis=1)
        self.held = np.zeros(len(self.nodes), dtype=bool)
        self.is_grasped = False
        corner = (np.arange(4)[:, None] * 5 + np.arange(4)[None, :]).ravel()  # node k at row k // 5
        self.triangles = np.concatenate(
            [np.stack([corner, corner + 1, corner + 6], 1), np.stack([corner, corner + 6, corner + 5], 1)]
        )
        pairs = np.concatenate([self.triangles[:, [i, (i + 1) % 3]] for i in range(3)])
        self.edges = np.unique(np.sort(pairs, axis=1), axis=0)

    def simulation_nodes(self) -> np.ndarray:
        return self.nodes.copy()

    def simulation_mesh(self) -> tuple[np.ndarray, np.ndarray]:
        return self.edges, self.triangles

    def crossed(self, other: Sheet) -> int:
        mine, theirs = (self.nodes, self.edges, self.triangles), (other.nodes, other.edges, other.triangles)
        return crossed_edges(*mine, *theirs)

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


def _crossed_pair() -> tuple[Sheet, Sheet]:
    """Two sheets through each other, as a pair put back together lands: the second lies
    above the first on three of its five columns and under it on two."""
    under, over = Sheet(1, 0.008), Sheet(2, 0.024, shift=0.01)
    over.nodes[over.nodes[:, 0] < 0.05, 2] = 0.002  # columns 0 and 1 under the other sheet
    assert over.crossed(under) > 0
    return under, over


def test_a_crossed_pair_is_given_the_order_most_of_it_lies_in() -> None:
    """`world.cloth.uncross_layers`: the sides learnt lying crossed say "above" on three
    columns and "below" on two; the pair is given the order of the three, and the nodes on
    the wrong side are set back, so no edge of one goes through the other."""
    under, over = _crossed_pair()
    keeper = LayerKeeper()
    for _ in range(UNCROSS_EVERY + 1):
        keeper.keep([under, over], TABLE, uncross=True)
    assert keeper.uncrossed == 1
    assert over.crossed(under) == 0
    assert np.all(over.nodes[:, 2] > under.nodes[:, 2])  # above it everywhere now
    assert np.all(over.nodes[over.nodes[:, 0] > 0.05, 2] == 0.024)  # the part that lay right stays
    # without it the sides learnt crossed are kept: the pair stays through each other
    under, over = _crossed_pair()
    keeper = LayerKeeper()
    for _ in range(UNCROSS_EVERY + 1):
        keeper.keep([under, over], TABLE)
    assert over.crossed(under) > 0 and keeper.uncrossed == 0


def test_a_pair_not_crossed_keeps_its_layers_as_they_lie() -> None:
    """A cloth lying on another and under a third: no mesh crosses, no order is forced."""
    under, over = Sheet(1, 0.008), Sheet(2, 0.024, shift=0.01)
    keeper = LayerKeeper()
    for _ in range(2 * UNCROSS_EVERY):
        assert keeper.keep([under, over], TABLE, uncross=True) == 0
    assert keeper.uncrossed == 0
    assert np.all(under.nodes[:, 2] == 0.008) and np.all(over.nodes[:, 2] == 0.024)


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
