"""`robot-app demo`: the PA10 model, our IK and pybullet agreeing on one motion.

Builds the simulated cell (`robot_app.sim.World`), solves IK with `Kinematics` for a
tcp pose looking straight down at the table, drives the arm there with the cell's
position control, and prints the target, the IK residuals, iterations and time, the
tcp pose pybullet reports afterwards and its error; then shows that an unreachable
target fails quickly with its residual instead of raising.
"""

from __future__ import annotations

import math
import time
from typing import TYPE_CHECKING, Annotated

import numpy as np
import typer

from robot_app.arrays import FloatArray
from robot_app.commands._guards import check_display
from robot_app.errors import InputError
from robot_app.geometry import make_transform, rotation_angle_between

if TYPE_CHECKING:
    from robot_app.control.kinematics import IKResult


READY_POSTURE = np.array([0.0, 0.5, 0.0, 1.3, 0.0, 1.35, 0.0])
"""Elbow-up posture [rad] with the tool pointing down in front of the robot."""
UNREACHABLE_POSITION = (1.6, 0.0, 0.3)
"""1.6 m from the base: beyond the PA10's reach of about 1.3 m from the shoulder [m]."""


def looking_down(position: tuple[float, float, float], yaw: float) -> FloatArray:
    """tcp pose with the tool axis (+z) pointing at the floor; tool x at `yaw` from world +y [rad]."""
    x_axis = np.array([-math.sin(yaw), math.cos(yaw), 0.0])
    z_axis = np.array([0.0, 0.0, -1.0])
    return make_transform(np.column_stack([x_axis, np.cross(z_axis, x_axis), z_axis]), position)


def _describe(result: IKResult) -> str:
    return (
        f"{'success' if result.success else 'FAILED'}, position error {result.position_error:.2e} m, "
        f"orientation error {result.orientation_error:.2e} rad, {result.iterations} iterations, "
        f"{result.restarts} restarts, {result.time_s * 1e3:.2f} ms"
    )


def _drive(q_goal: FloatArray, gui: bool, seconds: float) -> tuple[FloatArray, FloatArray]:
    """Position control in the simulated cell from READY_POSTURE to q_goal; returns
    (tcp pose 4x4, final q)."""
    from robot_app.sim import World  # here, not at the top: every `robot-app` command imports this module

    with World(gui=gui) as world:
        robot = world.robot
        robot.reset_joints(READY_POSTURE)
        robot.command_joints(q_goal)
        for _ in range(round(seconds / world.dt)):
            world.step()
            if gui:
                time.sleep(world.dt)
        return robot.frame_pose("tcp"), robot.q()


def demo(
    x: Annotated[float, typer.Option(help="Target tcp x in the base frame, in m.")] = 0.55,
    y: Annotated[float, typer.Option(help="Target tcp y, in m.")] = 0.10,
    z: Annotated[float, typer.Option(help="Target tcp height above the floor, in m.")] = 0.35,
    yaw_deg: Annotated[float, typer.Option("--yaw-deg", help="Tool x from world +y, in deg.")] = 0.0,
    seconds: Annotated[float, typer.Option(help="Simulated time of position control, in s.")] = 3.0,
    gui: Annotated[bool, typer.Option("--gui", help="Open pybullet's GUI (needs a display).")] = False,
) -> None:
    """Solve IK for a tcp pose looking down, drive the PA10 there in pybullet, compare."""
    if not 0.0 < seconds <= 60.0:
        raise InputError(f"--seconds must be in (0, 60], got {seconds}", key="--seconds", value=seconds)
    check_display(gui)  # pybullet's GUI would print "cannot connect to X server" and end the process
    from robot_app.control.robot_models import pa10_spec

    kin = pa10_spec("tcp").load()
    target = looking_down((x, y, z), math.radians(yaw_deg))
    typer.echo(
        f"PA10 demo: Pinocchio chain {kin.base_link} -> {kin.tip_frame}, "
        f"pybullet {'GUI' if gui else 'DIRECT'}"
    )
    typer.echo(f"target tcp: position ({x:.3f}, {y:.3f}, {z:.3f}) m, tool axis down, yaw {yaw_deg:.1f} deg")
    result = kin.solve_ik(target, READY_POSTURE, time_budget=0.05, preferred_posture=READY_POSTURE)
    typer.echo(f"IK: {_describe(result)}")
    result.raise_if_failed()
    typer.echo(
        "q [deg]: "
        + ", ".join(f"{n} {v:.2f}" for n, v in zip(kin.joint_names, np.rad2deg(result.q), strict=True))
    )
    reached, q_final = _drive(result.q, gui, seconds)
    position_error = float(np.linalg.norm(reached[:3, 3] - target[:3, 3]))
    angle_error = rotation_angle_between(reached[:3, :3], target[:3, :3])
    tracking = float(np.max(np.abs(q_final - result.q)))
    typer.echo(
        f"pybullet after {seconds:.2f} s of position control: tcp at ({reached[0, 3]:.4f}, "
        f"{reached[1, 3]:.4f}, {reached[2, 3]:.4f}) m; error {position_error * 1e3:.3f} mm, "
        f"{math.degrees(angle_error):.4f} deg; largest joint error {math.degrees(tracking):.4f} deg"
    )
    unreachable = looking_down(UNREACHABLE_POSITION, 0.0)
    miss = kin.solve_ik(unreachable, READY_POSTURE, time_budget=0.02)
    typer.echo(f"unreachable target {UNREACHABLE_POSITION} m: IK {_describe(miss)} (expected to fail)")


def register(app: typer.Typer) -> None:
    """Adds `demo` to the `robot-app` CLI."""
    app.command("demo")(demo)


__all__ = ["demo", "looking_down", "register"]
