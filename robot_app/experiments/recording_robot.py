"""The robot as a recording draws it: URDF visual primitives on its rigid bodies, placed by FK.

Links joined by fixed joints move as one body (the PA10's last link carries the flange,
both cameras and the gripper's palm), so a recording needs one pose per body, not per
link: `RobotBodies` groups the URDF's visuals by body and computes the bodies' poses
with Pinocchio from the joint positions (one forward kinematics per sample).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from robot_app.arrays import FloatArray
from robot_app.errors import InputError
from robot_app.experiments.recording_layout import Shape
from robot_app.geometry import make_transform, rotation_about_z, rotation_from_rpy

TCP_FRAME = "tcp"


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


class RobotBodies:
    """The robot's rigid bodies and their poses in Σ_W.

    Args:
        urdf: the robot's URDF.
        arm_joints: names of the arm joints, in the order of the joint positions given to `poses`.
        gripper_joints: prismatic finger joints; each is set to half the gripper's opening.
        base_xyz, base_yaw: where the URDF's root link stands in Σ_W [m, rad].
    """

    def __init__(
        self,
        urdf: str | Path,
        arm_joints: Sequence[str],
        gripper_joints: Sequence[str] = (),
        base_xyz: Sequence[float] = (0.0, 0.0, 0.0),
        base_yaw: float = 0.0,
    ) -> None:
        self.urdf = Path(urdf)
        self._model = pin.buildModelFromUrdf(str(self.urdf))
        self._data = self._model.createData()
        self._arm_q = [self._q_index(name) for name in arm_joints]
        self._finger_q = [self._q_index(name) for name in gripper_joints]
        self._world_from_model = make_transform(rotation_about_z(base_yaw), base_xyz)
        model = self._model
        links = [f for f in model.frames if f.type == pin.FrameType.BODY]
        body_of_joint: dict[int, str] = {}
        for frame in links:  # the first link of each joint names its body (universe: the root link)
            body_of_joint.setdefault(int(frame.parentJoint), frame.name)
        self.body_of_link = {frame.name: body_of_joint[int(frame.parentJoint)] for frame in links}
        self.bodies = tuple(body_of_joint.values())
        self._body_frames = [model.getFrameId(name) for name in self.bodies]
        self._tcp_frame = model.getFrameId(TCP_FRAME) if model.existFrame(TCP_FRAME) else None
        pin.framesForwardKinematics(model, self._data, pin.neutral(model))
        self._link_in_body = {
            name: self._data.oMf[model.getFrameId(body)]
            .actInv(self._data.oMf[model.getFrameId(name)])
            .homogeneous
            for name, body in self.body_of_link.items()
        }

    def visuals(self, link_visuals: Mapping[str, tuple[Shape, ...]]) -> dict[str, tuple[Shape, ...]]:
        """The links' visuals (in their link frames) regrouped per body, in the body frames."""
        grouped: dict[str, list[Shape]] = {}
        for link, shapes in link_visuals.items():
            if link not in self.body_of_link:
                continue
            offset = self._link_in_body[link]
            body = grouped.setdefault(self.body_of_link[link], [])
            body.extend(Shape(s.kind, s.size, offset @ s.pose, s.rgba) for s in shapes)
        return {body: tuple(shapes) for body, shapes in grouped.items()}

    def poses(self, q: npt.ArrayLike, opening: float = 0.0) -> tuple[dict[str, FloatArray], FloatArray]:
        """Each body's (4, 4) pose in Σ_W [m], and the TCP position [m] (zeros without a `tcp` frame).

        Args:
            q: arm joint positions [rad], in `arm_joints` order.
            opening: gripper gap [m], shared equally by the finger joints.
        """
        configuration = pin.neutral(self._model)
        configuration[self._arm_q] = np.asarray(q, dtype=float)
        configuration[self._finger_q] = opening / 2
        pin.framesForwardKinematics(self._model, self._data, configuration)
        placed, world = self._data.oMf, self._world_from_model
        poses = {
            name: world @ placed[i].homogeneous
            for name, i in zip(self.bodies, self._body_frames, strict=True)
        }
        tcp = (
            np.zeros(3)
            if self._tcp_frame is None
            else world[:3, :3] @ placed[self._tcp_frame].translation + world[:3, 3]
        )
        return poses, tcp

    def _q_index(self, joint: str) -> int:
        if not self._model.existJointName(joint):
            raise ValueError(f"joint {joint!r} is not in {self.urdf}")
        return int(self._model.joints[self._model.getJointId(joint)].idx_q)


def _floats(text: str | None, count: int) -> tuple[float, ...]:
    values = tuple(float(v) for v in text.split()) if text else (0.0,) * count
    if len(values) != count:
        raise InputError(f"URDF attribute {text!r}: expected {count} numbers")
    return values


def _rgba(color: ET.Element | None) -> tuple[int, int, int, int]:
    r, g, b, a = _floats(color.get("rgba") if color is not None else "0.7 0.7 0.7 1", 4)
    return (round(255 * r), round(255 * g), round(255 * b), round(255 * a))


__all__ = ["RobotBodies", "urdf_visuals"]
