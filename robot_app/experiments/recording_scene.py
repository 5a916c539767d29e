"""The simulated cell as a recording sees it: its layout once, then samples at a fixed rate.

`cell_layout` describes the table, the green sheet, the collection box, the robot's URDF
visual primitives (per link, in the link frame) and the cloths' meshes and prints;
`SceneSampler` reads the link poses, the TCP, the cloths' nodes and the joint state from
the pybullet world while the loop runs. Both feed `EpisodeRecorder` (recording.py),
which knows nothing of pybullet.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import cv2
import numpy as np

from robot_app.control.limits import JointLimits
from robot_app.errors import InputError
from robot_app.experiments.recording import CellLayout, ClothSurface, EpisodeRecorder, SceneSample, Shape
from robot_app.geometry import make_transform, rotation_about_z, rotation_from_rpy
from robot_app.sim import ClothBody, World, texture_image

TABLE_RGBA = (204, 191, 166, 255)
TABLE_SLAB = 0.04  # the table drawn as its top, this thick [m]
BOX_RGBA = (217, 153, 77, 255)
TEXTURE_SCALE = 0.5  # cloth prints are stored at half the catalogue's 2 px/mm
TCP_LINK = "tcp"


def urdf_visuals(path: str | Path) -> dict[str, tuple[Shape, ...]]:
    """Visual primitives (box, cylinder, sphere) of every link of a URDF, in the link frame.

    Meshes are left out (our URDFs have none). Colours come from the visual's material,
    inline or named at the robot's top level.

    Raises:
        InputError: the file is missing or is not URDF XML.
    """
    try:
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError) as err:
        raise InputError(f"cannot read the robot URDF {path}: {err}", path=Path(path)) from err
    colours = {m.get("name", ""): _rgba(m.find("color")) for m in root.findall("material")}
    visuals: dict[str, tuple[Shape, ...]] = {}
    for link in root.findall("link"):
        shapes = []
        for visual in link.findall("visual"):
            origin = visual.find("origin")
            xyz = _floats(origin.get("xyz") if origin is not None else None, 3)
            rpy = _floats(origin.get("rpy") if origin is not None else None, 3)
            pose = make_transform(rotation_from_rpy(*rpy), xyz)
            material = visual.find("material")
            rgba = (180, 180, 180, 255)
            if material is not None:
                inline = material.find("color")
                rgba = _rgba(inline) if inline is not None else colours.get(material.get("name", ""), rgba)
            geometry = visual.find("geometry")
            for element in list(geometry) if geometry is not None else []:
                if element.tag == "box":
                    sx, sy, sz = _floats(element.get("size"), 3)
                    shapes.append(Shape("box", (sx, sy, sz), pose, rgba))
                elif element.tag == "cylinder":
                    r, length = float(element.get("radius", 0)), float(element.get("length", 0))
                    shapes.append(Shape("cylinder", (r, r, length), pose, rgba))
                elif element.tag == "sphere":
                    r = float(element.get("radius", 0))
                    shapes.append(Shape("sphere", (r, r, r), pose, rgba))
        if shapes:
            visuals[link.get("name", "")] = tuple(shapes)
    return visuals


def cell_layout(world: World, limits: JointLimits) -> CellLayout:
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
    links = urdf_visuals(c.robot.urdf)
    names = set(world.robot.link_names)
    camera = world.stereo.rig
    return CellLayout(
        fixed={"table": (table,), "sheet": (sheet,), "box": tuple(walls)},
        links={name: shapes for name, shapes in links.items() if name in names},
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
        links: robot links whose poses are sampled (those the layout draws).
        rate_hz: scene samples per second of cell time.
    """

    def __init__(
        self, world: World, recorder: EpisodeRecorder, links: tuple[str, ...], rate_hz: float = 30.0
    ) -> None:
        if rate_hz <= 0:
            raise ValueError(f"rate_hz must be positive, got {rate_hz}")
        self.world, self.recorder, self.links = world, recorder, links
        self.period = 1.0 / rate_hz
        self.next_time = world.time

    def tick(self) -> None:
        """Samples the joints now, and the scene if a sample is due."""
        robot, time = self.world.robot, self.world.time
        self.recorder.log_joints(time, robot.q(), robot.dq())
        if time + 1e-9 < self.next_time:
            return
        self.next_time += self.period
        poses = {link: robot.frame_pose(link) for link in self.links}
        tcp = robot.frame_pose(TCP_LINK)[:3, 3]
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


def _floats(text: str | None, count: int) -> tuple[float, ...]:
    values = tuple(float(v) for v in text.split()) if text else (0.0,) * count
    if len(values) != count:
        raise InputError(f"URDF attribute {text!r}: expected {count} numbers")
    return values


def _rgba(color: ET.Element | None) -> tuple[int, int, int, int]:
    r, g, b, a = _floats(color.get("rgba") if color is not None else "0.7 0.7 0.7 1", 4)
    return (round(255 * r), round(255 * g), round(255 * b), round(255 * a))


__all__ = ["SceneSampler", "cell_layout", "cloth_label", "urdf_visuals"]
