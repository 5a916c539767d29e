"""Crossed cloth meshes (`sim.mesh_crossing`): two square sheets, stacked or through each other."""

from __future__ import annotations

import numpy as np

from robot_app.sim.mesh_crossing import crossed_edges, edges_through

# a unit square of two triangles, its four sides and the diagonal
NODES = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]])
TRIANGLES = np.array([[0, 1, 2], [0, 2, 3]])
EDGES = np.array([[0, 1], [1, 2], [2, 3], [3, 0], [0, 2]])


def _crossed(other: np.ndarray) -> int:
    return crossed_edges(NODES, EDGES, TRIANGLES, other, EDGES, TRIANGLES)


def test_stacked_sheets_do_not_cross() -> None:
    assert _crossed(NODES + np.array([0.2, 0.3, 0.01])) == 0  # lying on it, 1 cm up
    assert _crossed(NODES + np.array([3.0, 0.0, 0.0])) == 0  # beside it


def test_a_sheet_through_another_crosses_it() -> None:
    # the second sheet stands upright through the first's middle: its edges pierce the first
    upright = np.array([[0.3, 0.5, -0.5], [0.7, 0.5, -0.5], [0.7, 0.5, 0.5], [0.3, 0.5, 0.5]])
    assert _crossed(upright) > 0
    # tilted a little through the first: crossed; lifted clear of it: not
    tilted = NODES * [0.5, 0.5, 1.0] + [0.25, 0.25, 0.0]
    tilted[:, 2] = [-0.1, -0.1, 0.1, 0.1]
    assert _crossed(tilted) > 0
    tilted[:, 2] += 0.2
    assert _crossed(tilted) == 0


def test_a_segment_is_counted_once_per_triangle_it_passes() -> None:
    tri = NODES[TRIANGLES]
    down = (np.array([[0.8, 0.2, 1.0]]), np.array([[0.8, 0.2, -1.0]]))
    assert edges_through(*down, tri) == 1  # through the first triangle only
    assert edges_through(np.array([[0.8, 0.2, 1.0]]), np.array([[0.8, 0.2, 0.5]]), tri) == 0  # stops above
    assert edges_through(np.empty((0, 3)), np.empty((0, 3)), tri) == 0


def test_the_pile_trial_counts_crossings_only_with_a_held_cloth() -> None:
    from types import SimpleNamespace

    from robot_app.sim.checks import _crossed_with_held

    mesh = SimpleNamespace(edges=EDGES, triangles=TRIANGLES)
    standing = np.array([[0.5, 0.5, -0.5], [0.5, 0.5, 0.5], [0.6, 0.5, 0.5], [0.6, 0.5, -0.5]])

    def pile(*held: bool) -> SimpleNamespace:
        sheets = (NODES, standing, NODES + np.array([3.0, 0.0, 0.0]))  # the third far away
        bodies = [
            SimpleNamespace(nodes=lambda n=n: n, mesh=mesh, is_grasped=h)
            for n, h in zip(sheets, held, strict=False)
        ]
        return SimpleNamespace(cloths=[SimpleNamespace(body=b) for b in bodies])

    crossed = _crossed(standing)
    assert crossed > 0
    assert _crossed_with_held(pile(True, False, False)) == crossed
    assert _crossed_with_held(pile(False, True, False)) == crossed
    assert _crossed_with_held(pile(True, True, False)) == crossed  # a held pair once
    assert _crossed_with_held(pile(False, False, True)) == 0  # the held one crosses nothing
    assert _crossed_with_held(pile(False, False, False)) == 0
