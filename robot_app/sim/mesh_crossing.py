"""Crossed cloth meshes: the edges of one simulated cloth that pass through the other's
triangles. No real cloth goes through another; pybullet's soft-soft contact lets two meshes
pass through each other, in a pile and at a lift, and a pair crossed at a lift hangs together
(session 36: a replay of held-out 983, No.18 rose with No.13 with 6-8 edges through it, none
before the lift). The clear-table bench counts double lifts that were crossed
(`experiments.clear_table_faults.LiftTruth.crossed`).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray

CHUNK = 256  # edges tested against the triangles at a time


def edges_through(starts: FloatArray, ends: FloatArray, triangles: FloatArray) -> int:
    """How many segments (`starts` -> `ends`, (E, 3) each [m]) pass through a triangle of
    `triangles` ((T, 3, 3) [m]): Möller-Trumbore, the segment's open interior only (a
    shared end point is no crossing); boxes overlap first."""
    p, q, tri = (np.asarray(a, dtype=float) for a in (starts, ends, triangles))
    if not len(p) or not len(tri):
        return 0
    low, high = np.minimum(p, q), np.maximum(p, q)
    tri_low, tri_high = tri.min(axis=1), tri.max(axis=1)
    count = 0
    for i in range(0, len(p), CHUNK):
        below, above = low[i : i + CHUNK, None], high[i : i + CHUNK, None]
        near = np.all((below <= tri_high[None]) & (above >= tri_low[None]), axis=2)
        e, t = np.nonzero(near)
        if not len(e):
            continue
        origin, direction = p[i + e], q[i + e] - p[i + e]
        v0 = tri[t, 0]
        e1, e2 = tri[t, 1] - v0, tri[t, 2] - v0
        h = np.cross(direction, e2)
        det = np.einsum("ij,ij->i", e1, h)
        ok = np.abs(det) > 1e-15
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
        s = origin - v0
        u = inv * np.einsum("ij,ij->i", s, h)
        qv = np.cross(s, e1)
        v = inv * np.einsum("ij,ij->i", direction, qv)
        along = inv * np.einsum("ij,ij->i", e2, qv)
        hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (along > 0) & (along < 1)
        count += int(np.count_nonzero(hit))
    return count


def crossed_edges(
    nodes_a: FloatArray,
    edges_a: npt.ArrayLike,
    triangles_a: npt.ArrayLike,
    nodes_b: FloatArray,
    edges_b: npt.ArrayLike,
    triangles_b: npt.ArrayLike,
) -> int:
    """Edges of mesh a through mesh b's triangles plus b's through a's (nodes (N, 3) [m],
    edges (E, 2) and triangles (T, 3) node indices): 0 for two cloths that only touch."""
    a, b = np.asarray(nodes_a, dtype=float), np.asarray(nodes_b, dtype=float)
    ea, eb = np.asarray(edges_a, dtype=int), np.asarray(edges_b, dtype=int)
    ta, tb = np.asarray(triangles_a, dtype=int), np.asarray(triangles_b, dtype=int)
    return edges_through(a[ea[:, 0]], a[ea[:, 1]], b[tb]) + edges_through(b[eb[:, 0]], b[eb[:, 1]], a[ta])


__all__ = ["crossed_edges", "edges_through"]
