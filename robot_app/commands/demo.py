"""`robot-app demo`: the PA10 model, our IK and pybullet agreeing on one motion.

Builds a pybullet scene (floor + PA10 with its tool), solves IK with `Kinematics` for a
tcp pose looking straight down at the table, drives the arm there with pybullet's
position control, and prints the target, the IK residuals, iterations and time, the
tcp pose pybullet reports afterwards and its error; then shows that an unreachable
target fails quickly with its residual instead of raising.
"""

from __future__ import annotations

import math
import os
import sys
import time
from typing import TYPE_CHECKING, Annotated

import numpy as np
import numpy.typing as npt
import typer

from robot_app.errors import InputError, SimulationError
from robot_app.geometry import make_transform, matrix_from_quaternion_xyzw, rotation_angle_between

if TYPE_CHECKING:
    from robot_app.control.kinematics import IKResult, Kinematics

FloatArray = npt.NDArray[np.float64]

READY_POSTURE = np.array([0.0, 0.5, 0.0, 1.3, 0.0, 1.35, 0.0])
"""Elbow-up posture [rad] with the tool pointing down in front of the robot."""
UNREACHABLE_POSITION = (1.6, 0.0, 0.3)
"""1.6 m from the base: beyond the PA10's reach of about 1.3 m from the shoulder [m]."""
TIME_STEP = 1.0 / 240.0


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


def _drive(kin: Kinematics, q_goal: FloatArray, gui: bool, seconds: float) -> tuple[FloatArray, FloatArray]:
    """Position control from READY_POSTURE to q_goal; returns (tcp pose 4x4, final q)."""
    import pybullet as p  # here, not at the top: every `robot-app` command imports this module

    from robot_app.control.robot_models import pa10_spec

    if gui and sys.platform.startswith("linux") and not os.environ.get("DISPLAY"):
        # pybullet's GUI would print "cannot connect to X server" and exit the process.
        raise SimulationError("--gui needs a display (DISPLAY is not set); run without --gui")
    try:
        client = p.connect(p.GUI if gui else p.DIRECT)
    except p.error as err:
        raise SimulationError(
            f"pybullet could not open a {'GUI' if gui else 'DIRECT'} client: {err}"
        ) from err
    if client < 0:
        raise SimulationError("pybullet could not connect (no display for --gui?)")
    try:
        p.setGravity(0.0, 0.0, -9.81, physicsClientId=client)
        p.setTimeStep(TIME_STEP, physicsClientId=client)
        floor = p.createCollisionShape(p.GEOM_PLANE, physicsClientId=client)
        p.createMultiBody(0.0, floor, physicsClientId=client)
        robot = p.loadURDF(
            str(pa10_spec().urdf_path),
            useFixedBase=True,
            flags=p.URDF_USE_INERTIA_FROM_FILE,
            physicsClientId=client,
        )
        index = {}
        for i in range(p.getNumJoints(robot, physicsClientId=client)):
            info = p.getJointInfo(robot, i, physicsClientId=client)
            index[info[1].decode()] = i
            index[info[12].decode()] = i
        joints = [index[name] for name in kin.joint_names]
        for j, value in zip(joints, READY_POSTURE, strict=True):
            p.resetJointState(robot, j, float(value), physicsClientId=client)
        efforts = [p.getJointInfo(robot, j, physicsClientId=client)[10] for j in joints]
        for j, target, effort, speed in zip(joints, q_goal, efforts, kin.velocity_limits, strict=True):
            p.setJointMotorControl2(
                robot,
                j,
                p.POSITION_CONTROL,
                targetPosition=float(target),
                force=effort,
                maxVelocity=float(speed),
                physicsClientId=client,
            )
        for _ in range(round(seconds / TIME_STEP)):
            p.stepSimulation(physicsClientId=client)
            if gui:
                time.sleep(TIME_STEP)
        state = p.getLinkState(robot, index["tcp"], computeForwardKinematics=True, physicsClientId=client)
        q_final = np.array([s[0] for s in p.getJointStates(robot, joints, physicsClientId=client)])
        return make_transform(matrix_from_quaternion_xyzw(state[5]), state[4]), q_final
    finally:
        p.disconnect(client)


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
        raise InputError(f"--seconds must be in (0, 60], got {seconds}")
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
    reached, q_final = _drive(kin, result.q, gui, seconds)
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
