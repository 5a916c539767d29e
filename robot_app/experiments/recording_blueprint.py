"""The viewer layout a recording opens with: the cell in 3D, both cameras, the signals, the log.

Stored in the .rrd as its default blueprint (`rerun FILE.rrd` shows it; the viewer's
"reset blueprint" returns to it). Entity paths are those of `recording.py`.
"""

from __future__ import annotations

from types import ModuleType
from typing import Any

EYE_POSITION = (1.15, -0.95, 0.75)  # [m] in Σ_W: in front of the cell, right of the box
EYE_TARGET = (0.35, -0.2, 0.3)


def default_blueprint(rr: ModuleType) -> Any:
    """The layout: 3D cell and log | both camera images | recognition, error and joint plots.

    Args:
        rr: the imported `rerun` module (rerun-sdk is optional; the caller imports it).
    """
    rrb = rr.blueprint
    cell = rrb.Spatial3DView(
        origin="/",
        contents=["+ /cell/**", "+ /cloth/**", "+ /cameras/**"],
        name="cell",
        eye_controls=rrb.EyeControls3D(
            kind="Orbital", position=EYE_POSITION, look_target=EYE_TARGET, eye_up=(0.0, 0.0, 1.0)
        ),
    )
    cameras = rrb.Vertical(
        rrb.Spatial2DView(origin="/cameras/left", name="left camera"),
        rrb.Spatial2DView(origin="/cameras/right", name="right camera"),
    )
    plots = rrb.Vertical(
        rrb.TimeSeriesView(origin="/signals/recognition", name="fitness, confidence, visible fraction"),
        rrb.TimeSeriesView(
            origin="/signals",
            contents=["+ /signals/error/**", "+ /signals/filter/**"],
            name="error vs truth [mm], filter",
        ),
        rrb.TimeSeriesView(
            origin="/signals/joints",
            contents=["+ /signals/joints/position_of_range", "+ /signals/joints/limit_*"],
            name="joint positions / limits",
        ),
        rrb.TimeSeriesView(
            origin="/signals/joints",
            contents=["+ /signals/joints/velocity_of_limit", "+ /signals/joints/limit_*"],
            name="joint velocities / limits",
        ),
    )
    layout = rrb.Horizontal(
        rrb.Vertical(
            cell, rrb.TextLogView(origin="/log", name="phases, recognitions, outcome"), row_shares=[3, 1]
        ),
        cameras,
        plots,
        column_shares=[4, 3, 3],
    )
    return rrb.Blueprint(layout, rrb.TimePanel(timeline="cell_time"), collapse_panels=True)


__all__ = ["default_blueprint"]
