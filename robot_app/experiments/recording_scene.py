"""The simulated cell as a recording sees it: its layout once, then samples at a fixed rate.

`cell_layout` describes the table, the green sheet, the collection box, the robot's URDF
visual primitives (per rigid body, `recording_robot.py`) and the cloths' meshes and prints;
`SceneSampler` reads the joint state and the cloths' nodes from the pybullet world while
the loop runs, and places the links by forward kinematics. Both feed `EpisodeRecorder` (recording.py),
which knows nothing of pybullet.
"""

from __future__ import annotations

import cv2
import numpy as np

from robot_app.control.limits import JointLimits
from robot_app.experiments.recording import EpisodeRecorder
from robot_app.experiments.recording_layout import CellLayout, ClothSurface, SceneSample, Shape
from robot_app.experiments.recording_robot import RobotBodies, urdf_visuals
from robot_app.geometry import make_transform, rotation_about_z
from robot_app.sim import ClothBody, World, texture_image
from robot_app.sim.robot import FINGER_JOINTS

TABLE_RGBA = (204, 191, 166, 255)
TABLE_SLAB = 0.04  # the table drawn as its top, this thick [m]
BOX_RGBA = (217, 153, 77, 255)
TEXTURE_SCALE = 0.5  # cloth prints are stored at half the catalogue's 2 px/mm


def robot_bodies(world: World) -> RobotBodies:
    """The simulated PA10's bodies, standing where the world config puts its base."""
    robot = world.config.robot
    return RobotBodies(robot.urdf, world.robot.joint_names, FINGER_JOINTS, robot.base_xyz, robot.base_yaw)


def cell_layout(world: World, limits: JointLimits, bodies: RobotBodies) -> CellLayout:
    """The recording's static description of `world` (its cloths as they are now)."""
    c = world.config
    top = c.table.top_z
    tx, ty = c.table.centre_xy
    sx, sy = c.table.size_xy
    # the table's top as a slab, and the sheet just under the surface: a cloth lying on the
    # table (its nodes ~0.3 mm above it) is drawn above both
    table = Shape(
        "box",
        (sx, sy, TABLE_SLAB),
        make_transform(np.eye(3), [tx, ty, top - 0.001 - TABLE_SLAB / 2]),
        TABLE_RGBA,
    )
    m = 2 * c.range.sheet_margin
    red, green, blue = (round(255 * v) for v in c.range.sheet_rgb)
    sheet_rgba = (red, green, blue, 255)
    sheet_size = (c.range.size_xy[0] + m, c.range.size_xy[1] + m, 0.001)
    sheet = Shape(
        "box", sheet_size, make_transform(np.eye(3), [*c.range.centre_xy, top - 0.0007]), sheet_rgba
    )
    b = c.box
    outer = b.inner_size + 2 * b.wall_thickness
    offset = (b.inner_size + b.wall_thickness) / 2
    walls = []
    for dx, dy, size in (
        (offset, 0.0, (b.wall_thickness, outer, b.wall_height)),
        (-offset, 0.0, (b.wall_thickness, outer, b.wall_height)),
        (0.0, offset, (outer, b.wall_thickness, b.wall_height)),
        (0.0, -offset, (outer, b.wall_thickness, b.wall_height)),
    ):
        centre = [b.centre_xy[0] + dx, b.centre_xy[1] + dy, top + b.wall_height / 2]
        walls.append(Shape("box", size, make_transform(rotation_about_z(0.0), centre), BOX_RGBA))
    camera = world.stereo.rig
    return CellLayout(
        fixed={"table": (table,), "sheet": (sheet,), "box": tuple(walls)},
        links=bodies.visuals(urdf_visuals(c.robot.urdf)),
        cloths=tuple(_surface(cloth) for cloth in world.cloths),
        cameras=(camera.left, camera.right),
        joint_names=limits.names or tuple(world.robot.joint_names),
        joint_lower=limits.lower,
        joint_upper=limits.upper,
        joint_velocity=limits.velocity,
    )


def cloth_label(cloth: ClothBody) -> str:
    """The entity name of a cloth under `cell/cloths/` ("No.3")."""
    return f"No.{cloth.spec.number}"


class SceneSampler:
    """Feeds the recorder: joints every control step, the 3D scene at `rate_hz` of cell time.

    Args:
        world: the simulated cell.
        recorder: where the samples go.
        bodies: the robot's bodies (their poses by forward kinematics of the measured joints).
        rate_hz: scene samples per second of cell time.
    """

    def __init__(
        self, world: World, recorder: EpisodeRecorder, bodies: RobotBodies, rate_hz: float = 30.0
    ) -> None:
        if rate_hz <= 0:
            raise ValueError(f"rate_hz must be positive, got {rate_hz}")
        self.world, self.recorder, self.bodies = world, recorder, bodies
        self.period = 1.0 / rate_hz
        self.next_time = world.time

    def tick(self) -> None:
        """Samples the joints now, and the scene if a sample is due."""
        robot, time = self.world.robot, self.world.time
        q = robot.q()
        self.recorder.log_joints(time, q, robot.dq())
        if time + 1e-9 < self.next_time:
            return
        self.next_time += self.period
        poses, tcp = self.bodies.poses(q, robot.gripper_opening())
        nodes = {cloth_label(cloth): cloth.nodes() for cloth in self.world.cloths}
        self.recorder.log_scene(SceneSample(time, poses, tcp, nodes))


def _surface(cloth: ClothBody) -> ClothSurface:
    texture = texture_image(cloth.spec)
    small = np.asarray(
        cv2.resize(texture, None, fx=TEXTURE_SCALE, fy=TEXTURE_SCALE, interpolation=cv2.INTER_AREA), np.uint8
    )
    return ClothSurface(
        cloth_label(cloth), np.asarray(cloth.mesh.triangles), np.asarray(cloth.mesh.uvs), small
    )


__all__ = ["SceneSampler", "cell_layout", "cloth_label", "robot_bodies"]
