"""Where the chosen cloth lies on another one, by the survey's stereo pair.

The simulated gripper (like a real pinch into a pile) holds every cloth within its reach
of the fingers: a grasp where the target lies on another cloth lifts both. The survey
knows the cloths it identified and the foreground no model explains, and the grasp is
chosen away from them (`grasp_point.choose_pile_grasp`); it does not know a cloth that
lies wholly under the target. On bench episodes 30-49 (session 19) 24 of 120 lifts held
two cloths in the fingers, most of them with the lower one hidden or seen only at its edge.

The stereo pair shows it: the target's top surface is one cloth's thickness above the
table where it lies on the table and one layer higher (14-18 mm in the simulated cell)
over another cloth. `layer_map` measures the surface (`table_surface.surface_heights`)
at points of the target's seen part every `spacing`; a point whose surface lies above
`limit` (one cloth on the table, `single` above it, or a `step` over the target's lowest
surface, whichever is higher) lies over something, and the job keeps its grasp away from
it as from another cloth. The target's lowest surface is its `low_points`-th lowest trusted
height, so some of its seen points are never raised and one misread patch does not set it;
not a share of them: a cloth draped over a pile may touch the table on a few points only
(bench episode 40: 10 % of them lay one layer up, the limit came out above two layers).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from pydantic import Field

from robot_app.arrays import FloatArray
from robot_app.config import StrictModel
from robot_app.control.cell import StereoCapture
from robot_app.control.table_surface import SurfaceSettings, surface_heights
from robot_app.vision import ClothModel
from robot_app.vision.camera import StereoRig
from robot_app.vision.stereo_depth import DepthCheckSettings


class LayerSettings(StrictModel):
    """Keeping the grasp off where the target lies on another cloth (`clear.layers`).

    Attributes:
        enabled: measure the target's surface over its seen part before each pick (off:
            on bench episodes 29, 30 and 38, session 20, it moved grasps to where the
            target drapes over another cloth's edge, and both came up more often).
        spacing: one measured point per square of this side [m].
        radius: the patch measured around each point [m] (`SurfaceSettings.radius`).
        single: a surface at most this above the table is one cloth lying on it [m].
        step: a surface more than this above the target's lowest one lies over
            something [m] (a layer is 14-18 mm in the simulated cell).
        low_points: the target's lowest surface is its this-th lowest trusted height.
    """

    enabled: bool = False
    spacing: float = Field(0.015, gt=0.0, le=0.1)
    radius: float = Field(0.012, gt=0.0, le=0.05)
    single: float = Field(0.02, gt=0.0, le=0.1)
    step: float = Field(0.012, gt=0.0, le=0.05)
    low_points: int = Field(3, ge=1, le=50)


@dataclass(frozen=True)
class LayerMap:
    """The target's top surface at points of its seen part.

    Attributes:
        points: (N, 3) the measured points in Σ_W [m].
        heights: (N,) the surface there in Σ_W [m] (NaN: not trusted).
        limit: a surface above this lies over something [m] (NaN: nothing trusted).
    """

    points: FloatArray
    heights: FloatArray
    limit: float

    @property
    def raised(self) -> FloatArray:
        """(M, 2) the points (x, y) [m] whose surface lies above `limit`."""
        over = np.zeros(len(self.heights), dtype=bool)
        trusted = np.isfinite(self.heights)
        over[trusted] = self.heights[trusted] > self.limit
        return np.asarray(self.points[over, :2], dtype=float)

    @property
    def trusted(self) -> int:
        """How many points were measured and trusted."""
        return int(np.count_nonzero(np.isfinite(self.heights)))


def grid_points(points_world: npt.ArrayLike, spacing: float) -> FloatArray:
    """(M, 3) one of `points_world` ((N, 3) [m]) per square of side `spacing` [m] in
    (x, y): the one nearest the square's centre."""
    points = np.asarray(points_world, dtype=float).reshape(-1, 3)
    if not len(points):
        return points
    cells = np.floor(points[:, :2] / spacing)
    off = np.hypot(*(points[:, :2] - (cells + 0.5) * spacing).T)
    order = np.lexsort((off, cells[:, 1], cells[:, 0]))
    sorted_cells = cells[order]
    first = np.ones(len(order), dtype=bool)
    first[1:] = np.any(sorted_cells[1:] != sorted_cells[:-1], axis=1)
    return points[order[first]]


def layer_map(
    capture: StereoCapture,
    rig: StereoRig,
    model: ClothModel,
    depth_settings: DepthCheckSettings,
    visible: npt.NDArray[np.bool_],
    seen_points_world: npt.ArrayLike,
    table_z: float,
    settings: LayerSettings,
    surface: SurfaceSettings,
) -> LayerMap:
    """The target's surface over its seen part (module docstring).

    Args:
        capture: the survey's pair; `visible`: (H, W) the target's pixels in its right image.
        model, depth_settings: the target's model and its recogniser's stereo settings.
        seen_points_world: (N, 3) the target's seen model points in Σ_W [m].
        table_z: the table top's height [m].
        settings: see `LayerSettings`; `surface`: the sweep (its radius is `settings.radius`).
    """
    points = grid_points(seen_points_world, settings.spacing)
    patch = SurfaceSettings.model_validate({**surface.model_dump(), "radius": settings.radius})
    found = surface_heights(capture, rig, model, depth_settings, visible, points, table_z, patch)
    heights = np.array([f.z if f.trusted else np.nan for f in found], dtype=float)
    trusted = heights[np.isfinite(heights)]
    if not len(trusted):
        return LayerMap(points, heights, float("nan"))
    low = float(np.sort(trusted)[min(settings.low_points, len(trusted)) - 1])
    return LayerMap(points, heights, max(table_z + settings.single, low + settings.step))


__all__ = ["LayerMap", "LayerSettings", "grid_points", "layer_map"]
