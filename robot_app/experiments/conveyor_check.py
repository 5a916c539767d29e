"""Can the robot get to a cloth on this belt at all? Checked before an episode starts.

The belt is the green sheet (`sim/conveyor.py`); a cloth it has carried to its end bunches
up against the still table beyond, where its photo model no longer matches. So the robot
has to take the cloth off the belt before it gets there, at a place the arm can reach
(with the hand pointing down, the PA10 cannot reach the sheet's edge next to its base).
Whether it can is a property of the settings, not of one scene, so the check takes the
most favourable cloth: its centre entering at the range's upstream edge, on the line
through the range centre along the belt. If even that cloth cannot be reached on the
belt, the episode is refused with outcome `unreachable` and the reason: a belt too fast,
or one heading out of the arm's reach before the arm could get there.

Timing, in cell time from the belt's start: the first look after `loop.settle_time`;
its result after the camera's latency and the recognition (`loop.vision_latency`, or
`NOMINAL_SEARCH_TIME` when it is measured); then the arm's own jerk-limited move from the
observation joints to the grasp pose over the cloth (the controller's IK and ruckig).
"""

from __future__ import annotations

import math

import numpy as np

from robot_app.arrays import FloatArray
from robot_app.control import JointLimits, Kinematics, LoopSettings, plan_point_to_point
from robot_app.geometry import make_transform
from robot_app.sim import BeltArea, BeltMotion, WorldConfig
from robot_app.sim.config import SceneSettings

NOMINAL_SEARCH_TIME = 0.5  # [s] a one-shot search when loop.vision_latency is null (measured: 0.3-0.6 s)
HORIZON = 20.0  # [s] of belt time searched for an intercept
STEP = 0.05  # [s] between the intercept times tried


def conveyor_problem(
    world: WorldConfig,
    scene: SceneSettings,
    loop: LoopSettings,
    kinematics: Kinematics,
    limits: JointLimits,
    observation_joints: FloatArray,
) -> str | None:
    """Why no cloth on this belt can be picked, or None when the most favourable one can."""
    belt = BeltMotion.from_scene(scene)
    if belt.speed == 0.0:
        return None
    direction = belt.direction[:2]
    centre = np.asarray(world.range.centre_xy, dtype=float)
    half_range = np.asarray(world.range.size_xy, dtype=float) / 2
    area = BeltArea.under_sheet(world)
    half_belt = np.array([area.x_range[1] - area.x_range[0], area.y_range[1] - area.y_range[0]]) / 2
    entry = centre - direction * _to_edge(direction, half_range)
    length = _to_edge(direction, half_range) + _to_edge(direction, half_belt)  # entry to the belt's end
    search = NOMINAL_SEARCH_TIME if loop.vision_latency is None else loop.vision_latency
    result_time = loop.settle_time + world.imaging.latency + search
    times = np.arange(0.0, result_time + HORIZON + STEP, 1e-3)
    speeds = np.array([belt.speed_at(float(t)) for t in times])
    travelled = np.concatenate([[0.0], np.cumsum((speeds[1:] + speeds[:-1]) * np.diff(times) / 2)])
    at_end = float(np.interp(length, travelled, times)) if travelled[-1] >= length else math.inf
    rotation = kinematics.frame_pose(observation_joints, "tcp")[:3, :3]
    z = world.table.top_z + loop.grasp_height
    out_of_reach: FloatArray | None = None  # where the cloth last left the arm's reach
    for t in np.arange(result_time, min(at_end, result_time + HORIZON), STEP):
        xy = entry + direction * float(np.interp(t, times, travelled))
        ik = kinematics.solve_ik(
            make_transform(rotation, [xy[0], xy[1], z]),
            observation_joints,
            frame="tcp",
            time_budget=loop.ik_time_budget,
            position_tolerance=loop.ik_tolerance,
            orientation_tolerance=loop.ik_tolerance,
            preferred_posture=observation_joints,
        )
        if not (ik.success and limits.contains(ik.q)):
            out_of_reach = xy
            continue
        out_of_reach = None
        move = plan_point_to_point(observation_joints, ik.q, limits, dt=0.01).duration
        if result_time + move <= t:
            return None
    where = (
        "to its end"
        if out_of_reach is None
        else f"out of the arm's reach (x={out_of_reach[0]:.2f}, y={out_of_reach[1]:.2f} m)"
    )
    return (
        f"at {belt.speed:.3f} m/s along {belt.direction_deg:.0f} deg the belt carries a cloth {where} "
        f"before the arm could get to it (first result at {result_time:.2f} s, "
        f"{length:.2f} m of belt to its end)"
    )


def _to_edge(direction: FloatArray, half: FloatArray) -> float:
    """Distance [m] from a rectangle's centre to its edge along a unit direction."""
    with np.errstate(divide="ignore"):
        reach = np.where(np.abs(direction) > 1e-12, half / np.abs(direction), math.inf)
    return float(np.min(reach))


__all__ = ["NOMINAL_SEARCH_TIME", "conveyor_problem"]
