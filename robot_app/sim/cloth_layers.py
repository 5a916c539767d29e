"""Cloths lying on cloths keep their side of each other (`world.cloth.keep_layers`).

pybullet's deformable-deformable contact does not keep two resting cloths apart for long:
it holds a layer about twice the collision margin above the one under it when they land,
and then lets it sink, a few millimetres a second, through the other. In a pile of bench
episode 661 left alone, the gaps between layers went from 15-16 mm to 0 within 4 s and
to -16 mm (crossed) within 8 s (notes `s32/creep.py`). Crossed cloths are hooked into
each other: the top cloth of that pile, lifted after 8 s at a point 10 cm from any other
cloth, brought the cloth under it up whole (lifted straight after the drop, it came up
alone), and in the bench such lifts brought two or three cloths up at every attempt
(held-out episodes 661, 668, 669, 684). Real cloths do not pass through each other.

So after every `CHECK_EVERY` physics steps, each free node of a cloth lying low (within
`LOW` of the table top) is compared with every other cloth's height there (its nodes within
`REACH` along the table, weighted by nearness): the side it lies on (above or below, once
more than `GAP` apart) is remembered, and a node found on the other side a check later
(less than `JUMP` across) is set back `GAP` on its side. Only heights change, as with the solid table
(`ClothBody.lift_free_nodes`). A node with no node of that cloth within reach forgets its
side (it went round the edge, or away). A cloth held by the gripper is never moved; with
`held_too` (`world.cloth.keep_layers_held`) the free cloths keep their side of it as well: a
cloth under the lifted one stays under it, one on it is carried up with it until both are
above `LOW` (it then falls back). Without that, a lift threaded the held cloth's edges
through a cloth beside it and the two came up together at every lift (session 37: a replay
of held-out 1017, No.2's lift crossed 2 edges with No.15 as the lift began, 4 at its top;
No.2 then hung down to the table and swept No.15 and No.17 along into its box).

Heights compared node by node miss a pair already through each other: two cloths put back
together, crossed while they hung from the fingers, land crossed, and the sides then learnt
are the crossed ones (a replay of held-out 1042: No.5 and No.17, put back as a pair, lay with
23-36 edges of one through the other's triangles from then on, and came up together at every
later lift). So with `uncross` (`world.cloth.uncross_layers`), every `UNCROSS_EVERY` checks,
each pair of free cloths whose meshes cross (`sim.mesh_crossing`: an edge of one through a
triangle of the other) is given one order, the one most of its remembered sides say (the
cloth above on the larger part of their overlap stays above): every node of the upper cloth
is to be above the lower one, every node of the lower under it, and the check then sets the
nodes on the wrong side back as it does any crossed node (within `JUMP`, heights only).
"""

from __future__ import annotations

from collections.abc import Sequence
from itertools import combinations

import numpy as np
import numpy.typing as npt
from scipy.spatial import cKDTree

from robot_app.arrays import FloatArray
from robot_app.sim.cloth_body import ClothBody
from robot_app.sim.mesh_crossing import crossed_edges

CHECK_EVERY = 2  # physics steps between checks
REACH = 0.02  # [m] along the table: a node of another cloth this near lies over or under it
GAP = 0.002  # [m] a side is taken beyond this; a node that crossed is set back this far
JUMP = 0.03  # [m] farther across than this is not a crossing (a cloth falling onto another)
LOW = 0.06  # [m] above the table top: nodes higher up (a hanging cloth) are not compared
NEIGHBOURS = 8  # nearest nodes looked at per node
UNCROSS_EVERY = 6  # checks between two looks for crossed meshes (with `uncross`)


class LayerKeeper:
    """Remembers which side of each other cloth every low free node lies on, and keeps it there."""

    def __init__(self) -> None:
        # (body id, other body id) -> per node of the first (pybullet's order): +1 above, -1 below, 0 unknown
        self._sides: dict[tuple[int, int], npt.NDArray[np.int8]] = {}
        self._checks = 0
        self.uncrossed = 0  # crossed pairs given one order (`uncross`)

    def keep(
        self, cloths: Sequence[ClothBody], table_z: float, held_too: bool = False, uncross: bool = False
    ) -> int:
        """One check of the free cloths' low nodes; returns how many were set back. With
        `held_too`, held cloths are sides to keep too (they themselves are never moved); with
        `uncross`, free cloths whose meshes cross are given one order first (every
        `UNCROSS_EVERY` checks)."""
        compared = list(cloths) if held_too else [c for c in cloths if not c.is_grasped]  # held: sides only
        if len(compared) < 2:
            self._sides.clear()
            return 0
        nodes = [c.simulation_nodes() for c in compared]
        self._checks += 1
        if uncross and self._checks % UNCROSS_EVERY == 0:
            self._order_crossed(compared, nodes)
        points = np.concatenate(nodes)
        owner = np.concatenate([np.full(len(n), k) for k, n in enumerate(nodes)])
        first = np.cumsum([0] + [len(n) for n in nodes])[:-1]
        low = np.flatnonzero(points[:, 2] < table_z + LOW)
        if len(low) < 2:
            return 0
        distance, near = cKDTree(points[low, :2]).query(
            points[low, :2], k=min(NEIGHBOURS, len(low)), distance_upper_bound=REACH
        )
        distance, near = distance.reshape(len(low), -1), near.reshape(len(low), -1)
        found = np.isfinite(distance)
        neighbour_owner = np.where(found, owner[low[np.where(found, near, 0)]], -1)
        moved = 0
        for k, cloth in enumerate(compared):
            if cloth.is_grasped:
                continue
            rows = np.flatnonzero(owner[low] == k)
            index = low[rows] - first[k]  # this cloth's nodes, pybullet's order
            changed = False
            for j, other in enumerate(compared):
                if j == k:
                    continue
                key = (cloth.body_id, other.body_id)
                side = self._sides.setdefault(key, np.zeros(len(nodes[k]), np.int8))
                of_other = neighbour_owner[rows] == j
                has = of_other.any(axis=1)
                seen = np.zeros(len(side), dtype=bool)
                seen[index[has]] = True
                side[~seen] = 0
                if not np.any(has):
                    continue
                r = np.flatnonzero(has)
                # the other cloth's height there: its nodes within reach, weighted by nearness
                weight = of_other[r] / np.maximum(distance[rows[r]], 1e-3)
                heights = points[low[np.where(of_other[r], near[rows[r]], 0)], 2]
                sheet = np.sum(weight * heights, axis=1) / np.sum(weight, axis=1)
                mine = index[r]
                dz = nodes[k][mine, 2] - sheet
                was = side[mine]
                crossed = (was != 0) & (np.sign(dz) != was) & (np.abs(dz) < JUMP)
                if np.any(crossed):
                    nodes[k][mine[crossed], 2] = sheet[crossed] + was[crossed] * GAP
                    moved += int(np.count_nonzero(crossed))
                    changed = True
                clear = ~crossed & (np.abs(dz) > GAP)
                side[mine[clear]] = np.sign(dz[clear]).astype(np.int8)
            if changed:
                cloth.set_free_heights(nodes[k][:, 2])
        return moved

    def _order_crossed(self, cloths: Sequence[ClothBody], nodes: Sequence[FloatArray]) -> None:
        """Each pair of free cloths whose meshes cross gets the order most of its remembered
        sides say: the upper one's nodes are to be above the lower one, the lower's under it."""
        for a, b in combinations(range(len(cloths)), 2):
            first, second = cloths[a], cloths[b]
            if first.is_grasped or second.is_grasped or not _boxes_meet(nodes[a], nodes[b]):
                continue
            ab, ba = (first.body_id, second.body_id), (second.body_id, first.body_id)
            if ab not in self._sides or ba not in self._sides:
                continue  # no sides taken yet: nothing says which lies on which
            if not _meshes_cross(first, nodes[a], second, nodes[b]):
                continue
            votes = int(self._sides[ab].sum()) - int(self._sides[ba].sum())  # > 0: first above
            if votes == 0:
                continue
            self._sides[ab][:] = np.sign(votes)
            self._sides[ba][:] = -np.sign(votes)
            self.uncrossed += 1


def _boxes_meet(a: FloatArray, b: FloatArray) -> bool:
    """The two node sets' bounding boxes overlap."""
    return bool(np.all(a.min(axis=0) <= b.max(axis=0)) and np.all(b.min(axis=0) <= a.max(axis=0)))


def _meshes_cross(first: ClothBody, a: FloatArray, second: ClothBody, b: FloatArray) -> bool:
    """An edge of one cloth passes through a triangle of the other (nodes in pybullet's order)."""
    return crossed_edges(a, *first.simulation_mesh(), b, *second.simulation_mesh()) > 0


__all__ = ["CHECK_EVERY", "UNCROSS_EVERY", "LayerKeeper"]
