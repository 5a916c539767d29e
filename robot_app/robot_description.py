"""robot_app's own URDF files and the joint chain of an arm, read once through Pinocchio.

The URDFs live in the repository's top-level `urdf/` folder. An editable install or a
source checkout finds them next to the package; `robot_app/urdf` is a symlink to that
folder, so a wheel that lists `urdf/*.urdf` in its package data carries a copy.
`ROBOT_APP_URDF_DIR` overrides both.

`read_joint_chain` is the one source of an arm's joint names and hardware limits: the
controller's `JointLimits`, the simulator's `SimRobot` and the kinematics all read them
from the URDF through Pinocchio, never from a list typed in twice.
"""

from __future__ import annotations

import functools
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from robot_app.arrays import FloatArray
from robot_app.errors import InputError

URDF_DIR_ENV = "ROBOT_APP_URDF_DIR"
PA10_URDF = "pa10.urdf"
PA10_BASE_LINK = "base_link"
PA10_FLANGE = "flange"


def urdf_search_dirs() -> tuple[Path, ...]:
    """Folders searched for robot_app's URDFs, in order."""
    package_dir = Path(__file__).resolve().parent  # robot_app/
    dirs = []
    if os.environ.get(URDF_DIR_ENV):
        dirs.append(Path(os.environ[URDF_DIR_ENV]))
    dirs += [package_dir.parent / "urdf", package_dir / "urdf"]
    return tuple(dirs)


def urdf_path(file_name: str) -> Path:
    """Absolute path of one of robot_app's URDF files, e.g. 'pa10.urdf'.

    Raises:
        InputError: the file is in none of `urdf_search_dirs()` (`path` names it, `key`
            the environment variable that adds a folder).
    """
    for folder in urdf_search_dirs():
        candidate = folder / file_name
        if candidate.is_file():
            return candidate
    searched = ", ".join(str(d) for d in urdf_search_dirs())
    raise InputError(
        f"{file_name} not found in {searched}; set {URDF_DIR_ENV} to the folder holding it",
        path=file_name,
        key=URDF_DIR_ENV,
        expected=f"a file in {searched}",
    )


@dataclass(frozen=True)
class JointChain:
    """The actuated joints between two links of a URDF, base to tip, with their limits.

    Attributes:
        names: joint names in chain order.
        lower, upper: position limits [rad or m], read-only (n,).
        velocity: velocity limits [rad/s or m/s], read-only (n,).
        effort: effort limits [N m or N], read-only (n,).
    """

    names: tuple[str, ...]
    lower: FloatArray
    upper: FloatArray
    velocity: FloatArray
    effort: FloatArray

    @property
    def dof(self) -> int:
        """Number of joints."""
        return len(self.names)


def read_joint_chain(
    urdf: str | Path, base_link: str = PA10_BASE_LINK, tip_link: str = PA10_FLANGE
) -> JointChain:
    """The 1-DoF joints on the path from `base_link` to `tip_link` of a URDF, via Pinocchio.

    Raises:
        InputError: the file is missing or not a URDF, a link is unknown, or no joint
            lies between the two links.
    """
    return _read_joint_chain(Path(urdf).resolve(), base_link, tip_link)


@functools.lru_cache(maxsize=16)
def _read_joint_chain(path: Path, base_link: str, tip_link: str) -> JointChain:
    if not path.is_file():
        raise InputError(f"URDF not found: {path}", path=path, expected="an existing URDF file")
    try:
        model = pin.buildModelFromUrdf(str(path))
    except (RuntimeError, ValueError) as err:
        raise InputError(f"cannot parse URDF {path}: {err}", path=path, expected="a valid URDF") from err
    for link in (base_link, tip_link):
        if not model.existFrame(link):
            raise InputError(f"{path}: no link named {link!r}", path=path, key=link)

    def ancestors(frame: str) -> list[int]:
        joint, out = model.frames[model.getFrameId(frame)].parentJoint, []
        while joint > 0:
            out.append(joint)
            joint = model.parents[joint]
        return out

    base = set(ancestors(base_link))
    chain = [j for j in reversed(ancestors(tip_link)) if j not in base and model.joints[j].nv == 1]
    if not chain:
        raise InputError(f"{path}: no joint between {base_link!r} and {tip_link!r}", path=path)
    rows = [model.joints[j].idx_q for j in chain]
    speed_rows = [model.joints[j].idx_v for j in chain]

    def readonly(values: FloatArray) -> FloatArray:
        out = np.array(values, dtype=float)
        out.setflags(write=False)
        return out

    return JointChain(
        names=tuple(model.names[j] for j in chain),
        lower=readonly(model.lowerPositionLimit[rows]),
        upper=readonly(model.upperPositionLimit[rows]),
        velocity=readonly(model.velocityLimit[speed_rows]),
        effort=readonly(model.effortLimit[speed_rows]),
    )


__all__ = [
    "PA10_BASE_LINK",
    "PA10_FLANGE",
    "PA10_URDF",
    "URDF_DIR_ENV",
    "JointChain",
    "read_joint_chain",
    "urdf_path",
    "urdf_search_dirs",
]
