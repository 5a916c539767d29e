"""What a recording draws of a cell: its fixed parts, the robot's bodies, the cloths, and
the samples of the moving scene (types only; `recording.py` logs them, `recording_scene.py`
fills them from the simulator)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray
from robot_app.vision import PinholeCamera


@dataclass(frozen=True)
class Shape:
    """A primitive of the cell or of a robot link.

    Attributes:
        kind: "box", "cylinder" (axis along its z) or "sphere".
        size: box: full lengths (x, y, z); cylinder: (radius, radius, length); sphere: (r, r, r) [m].
        pose: (4, 4) pose of the shape's centre in its parent frame (Σ_W, or the link's) [m].
        rgba: colour, 0-255.
    """

    kind: Literal["box", "cylinder", "sphere"]
    size: tuple[float, float, float]
    pose: FloatArray
    rgba: tuple[int, int, int, int] = (180, 180, 180, 255)


@dataclass(frozen=True)
class ClothSurface:
    """A cloth's mesh as drawn: triangles of its nodes and its print.

    Attributes:
        label: entity name under `cell/cloths/` (e.g. "No.3").
        triangles: (T, 3) node indices.
        uvs: (N, 2) texture coordinates of the nodes (u right, v down, 0-1).
        texture_bgr: (H, W, 3) uint8 print.
    """

    label: str
    triangles: npt.NDArray[np.int64]
    uvs: FloatArray
    texture_bgr: npt.NDArray[np.uint8]


@dataclass(frozen=True)
class CellLayout:
    """What a recording draws once: the fixed cell, the robot's links, the cloths, the cameras.

    Attributes:
        fixed: entity name under `cell/` -> shapes in Σ_W.
        links: robot link name -> its visual shapes in the link frame.
        cloths: the cloths' meshes (their nodes move; see `SceneSample`).
        cameras: (left, right) hand cameras (intrinsics).
        joint_names: arm joints, in the order of the joint samples.
        joint_lower, joint_upper: position limits [rad]; joint_velocity: |velocity| limits [rad/s].
    """

    fixed: Mapping[str, tuple[Shape, ...]]
    links: Mapping[str, tuple[Shape, ...]]
    cloths: tuple[ClothSurface, ...]
    cameras: tuple[PinholeCamera, PinholeCamera]
    joint_names: tuple[str, ...]
    joint_lower: FloatArray
    joint_upper: FloatArray
    joint_velocity: FloatArray


@dataclass(frozen=True)
class SceneSample:
    """The moving cell at one time.

    Attributes:
        time: cell time [s].
        link_poses: link name -> (4, 4) pose in Σ_W [m].
        tcp: (3,) TCP position in Σ_W [m].
        cloth_nodes: cloth label -> (N, 3) node positions in Σ_W [m].
    """

    time: float
    link_poses: Mapping[str, FloatArray]
    tcp: FloatArray
    cloth_nodes: Mapping[str, FloatArray] = field(default_factory=dict)


__all__ = ["CellLayout", "ClothSurface", "SceneSample", "Shape"]
