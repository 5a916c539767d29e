"""Laying a lift back onto the table spread out, where the survey saw free table.

A lift that took two cloths (or the wrong one) goes back onto the table. Lowered on the
spot, the hanging cloths fold onto themselves into a heap that no photo model explains,
and the next survey finds no known cloth there. Laid out instead, the way one lays a
towel down: lower until the hanging cloth's lowest point touches the table, then move on
over the table while lowering further, so that the cloth lies down along the path,
`reach` long (its hanging length), before the fingers let go.

`lay_out_paths` chooses the direction: among `directions` evenly spread ones, those whose
laid strip stays inside the survey's view of the table (by `view_margin`), ordered by how
free the strip is: the mean distance of its points to the other cloths the survey saw,
each counted up to `free_distance` (the start is common to all; most free first). The job tries them
in that order until one is reachable.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from pydantic import Field
from scipy.spatial import cKDTree

from robot_app.arrays import FloatArray
from robot_app.config import StrictModel


class PutBackSettings(StrictModel):
    """How a rejected lift is put back (the `clear.put_back` section). Lengths [m].

    Attributes:
        lay_out: lay the cloth out along a path (False: lower it on the spot, sliding
            `clear.put_down_slide` outwards).
        directions: directions tried, evenly spread over the circle.
        max_length: the laid strip is the cloth's hanging reach long, at most this.
        view_margin: the strip stays this far inside the survey's view of the table.
        waypoints: the lay-out path's rest-to-rest moves.
        free_distance: a strip point this far from every other cloth counts as free.
    """

    lay_out: bool = True
    directions: int = Field(12, ge=1, le=72)
    max_length: float = Field(0.25, gt=0.0, le=0.5)
    view_margin: float = Field(0.04, ge=0.0, le=0.2)
    waypoints: int = Field(3, ge=1, le=10)
    free_distance: float = Field(0.1, gt=0.0, le=0.5)


@dataclass(frozen=True)
class LayOutPath:
    """One way to lay the held cloth down.

    Attributes:
        direction: (2,) unit vector in Σ_W (x, y) the hand moves along.
        waypoints: (K, 3) TCP positions [m] in Σ_W: the first above the start where the
            cloth touches, the last where the fingers let go.
        freedom: the strip points' mean distance to the nearest other cloth, each up to
            `free_distance` [m].
    """

    direction: FloatArray
    waypoints: FloatArray
    freedom: float


def lay_out_paths(
    start_xy: npt.ArrayLike,
    reach: float,
    table_z: float,
    release_height: float,
    obstacles_xy: npt.ArrayLike,
    view_xy: npt.ArrayLike,
    settings: PutBackSettings | None = None,
) -> tuple[LayOutPath, ...]:
    """The lay-out paths inside the view, most free first (module docstring).

    Args:
        start_xy: (2,) where the hand is now, (x, y) in Σ_W [m].
        reach: the held cloth's hanging length below the TCP [m].
        table_z: the table top [m].
        release_height: TCP above the table where the fingers let go [m].
        obstacles_xy: (M, 2) points of the other cloths on the table [m].
        view_xy: (4, 2) the view's corners on the table, in order around it [m].
        settings: see `PutBackSettings`.

    Raises:
        ValueError: a negative reach or release height, or not 4 view corners.
    """
    s = settings or PutBackSettings()
    if reach < 0 or release_height <= 0:
        raise ValueError(f"reach must be >= 0 and release_height > 0 [m], got {reach}, {release_height}")
    corners = np.asarray(view_xy, dtype=float)
    if corners.shape != (4, 2):
        raise ValueError(f"view_xy must be (4, 2) corners, got {corners.shape}")
    start = np.asarray(start_xy, dtype=float).reshape(2)
    length = min(reach, s.max_length)
    touch = table_z + max(release_height, reach)
    obstacles = np.asarray(obstacles_xy, dtype=float).reshape(-1, 2)
    tree = cKDTree(obstacles) if len(obstacles) else None
    paths = []
    for angle in np.arange(s.directions) * 2 * np.pi / s.directions:
        direction = np.array([np.cos(angle), np.sin(angle)])
        strip = start + np.linspace(0.0, 1.0, 11)[:, None] * length * direction
        if not np.all(_inside(strip, corners, s.view_margin)):
            continue
        distances = tree.query(strip)[0] if tree is not None else np.full(len(strip), np.inf)
        freedom = float(np.mean(np.minimum(distances, s.free_distance)))
        t = np.linspace(0.0, 1.0, s.waypoints + 1)[:, None]
        xy = start + t * length * direction
        z = touch + t[:, 0] * (table_z + release_height - touch)
        paths.append(LayOutPath(direction, np.column_stack([xy, z]), freedom))
    return tuple(sorted(paths, key=lambda p: -p.freedom))


def _inside(points: FloatArray, corners: FloatArray, margin: float) -> npt.NDArray[np.bool_]:
    """Which points lie inside the convex quadrilateral by at least `margin` [m]."""
    centre = corners.mean(axis=0)
    inside = np.ones(len(points), dtype=bool)
    for k in range(4):
        a, b = corners[k], corners[(k + 1) % 4]
        edge = b - a
        normal = np.array([-edge[1], edge[0]]) / max(float(np.linalg.norm(edge)), 1e-12)
        if normal @ (centre - a) < 0:
            normal = -normal  # pointing inwards whatever the corners' turning sense
        inside &= (points - a) @ normal >= margin
    return inside


__all__ = ["LayOutPath", "PutBackSettings", "lay_out_paths"]
