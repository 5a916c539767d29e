"""The files of a calibration: the folder of image pairs, the robot poses CSV, atomic writes.

Image folder: one file per camera and view, `left_<n>.png` and `right_<n>.png` with the
same number n (any digits: `left_7.png` pairs with `right_7.png`, `left_007.png` with
`right_007.png`); .png, .jpg, .jpeg, .bmp and .tif(f) are read. Other files are ignored.

Robot poses CSV: the flange frame Σ_H in the robot base frame at each view, metres and
a unit quaternion (x, y, z, w), one row per image pair, `index` being the pair's n:
```
index,x,y,z,qx,qy,qz,qw
0,0.5512,0.0214,0.6518,0.0021,0.9999,-0.0103,0.0003
```
"""

from __future__ import annotations

import csv
import io
import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray
from robot_app.errors import InputError
from robot_app.geometry import make_transform, matrix_from_quaternion_xyzw, quaternion_xyzw_from_matrix

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff")
POSE_COLUMNS = ("index", "x", "y", "z", "qx", "qy", "qz", "qw")
_NAME = re.compile(r"^(left|right)_(\d+)$")


@dataclass(frozen=True)
class ImagePair:
    """One view of the stereo pair: its number and its two files (None when missing)."""

    index: int
    left: Path | None
    right: Path | None

    @property
    def name(self) -> str:
        """A short name for reports, e.g. 'view 7'."""
        return f"view {self.index}"


def find_image_pairs(folder: str | Path) -> list[ImagePair]:
    """The views of an image folder, sorted by number (see the module docstring).

    Raises:
        InputError: the folder does not exist or holds no left_/right_ images.
    """
    root = Path(folder)
    if not root.is_dir():
        raise InputError(f"image folder not found: {root}", path=root, key="--images")
    sides: dict[int, dict[str, Path]] = {}
    for file in sorted(root.iterdir()):
        match = _NAME.match(file.stem)
        if not match or file.suffix.lower() not in IMAGE_SUFFIXES or not file.is_file():
            continue
        side, number = match.group(1), int(match.group(2))
        if side in sides.setdefault(number, {}):
            raise InputError(
                f"{root}: two {side} images numbered {number} ({sides[number][side].name}, {file.name})",
                path=file,
                key="--images",
            )
        sides[number][side] = file
    if not sides:
        raise InputError(
            f"{root} holds no calibration images (expected left_<n>.png and right_<n>.png)",
            path=root,
            key="--images",
            value=0,
            expected="left_<n>.png / right_<n>.png pairs",
        )
    return [ImagePair(n, files.get("left"), files.get("right")) for n, files in sorted(sides.items())]


def read_robot_poses(path: str | Path) -> dict[int, FloatArray]:
    """Flange-in-base 4x4 poses by view number from a robot poses CSV.

    Raises:
        InputError: missing file, wrong header, a bad number or quaternion, a repeated index.
    """
    file = Path(path)
    if not file.is_file():
        raise InputError(f"robot poses file not found: {file}", path=file, key="--robot-poses")
    rows = list(csv.reader(io.StringIO(file.read_text())))
    header = tuple(h.strip() for h in rows[0]) if rows else ()
    if header != POSE_COLUMNS:
        raise InputError(
            f"{file}: the header must be {','.join(POSE_COLUMNS)}, got {','.join(header) or 'nothing'}",
            path=file,
            key="--robot-poses",
            value=",".join(header),
            expected=",".join(POSE_COLUMNS),
        )
    poses: dict[int, FloatArray] = {}
    for line, row in enumerate(rows[1:], start=2):
        if not any(cell.strip() for cell in row):
            continue
        try:
            if len(row) != len(POSE_COLUMNS):
                raise ValueError(f"{len(row)} columns instead of {len(POSE_COLUMNS)}")
            index = int(row[0])
            values = np.array([float(v) for v in row[1:]])
            if not np.all(np.isfinite(values)):
                raise ValueError("a value is not finite")
            norm = float(np.linalg.norm(values[3:]))
            if abs(norm - 1.0) > 1e-3:
                raise ValueError(f"the quaternion's norm is {norm:.4f}, not 1")
        except ValueError as err:
            raise InputError(f"{file} line {line}: {err}", path=file, key="--robot-poses") from err
        if index in poses:
            raise InputError(f"{file} line {line}: index {index} appears twice", path=file, value=index)
        poses[index] = make_transform(matrix_from_quaternion_xyzw(values[3:]), values[:3])
    return poses


def robot_poses_csv(poses: Mapping[int, npt.ArrayLike]) -> str:
    """The CSV text of flange-in-base poses by view number."""
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(POSE_COLUMNS)
    for index, pose in sorted(poses.items()):
        T = np.asarray(pose, dtype=float)
        q = quaternion_xyzw_from_matrix(T[:3, :3])
        writer.writerow([index, *(f"{v:.9f}" for v in (*T[:3, 3], *q))])
    return out.getvalue()


__all__ = [
    "IMAGE_SUFFIXES",
    "POSE_COLUMNS",
    "ImagePair",
    "find_image_pairs",
    "read_robot_poses",
    "robot_poses_csv",
]
