"""Arm specifications: our PA10 and the example-robot-data arms used as IK anchors.

example-robot-data 6 ships URDFs only (no Python loader), so its data folder is found
from the installed distribution's file list (`importlib.metadata`), never from a
hard-coded path. The anchor arms are the ones of the TRAC-IK benchmark (Beeson and
Ames, Humanoids 2015): Baxter's right arm (base -> right_gripper) and PR2's right arm
(torso_lift_link -> r_wrist_roll_link).
"""

from __future__ import annotations

import functools
import importlib.metadata
from dataclasses import dataclass
from pathlib import Path

from robot_app.control.kinematics import Kinematics
from robot_app.errors import InputError
from robot_app.robot_description import PA10_BASE_LINK, PA10_FLANGE, PA10_URDF, urdf_path

EXAMPLE_ROBOT_DATA = "example-robot-data"
_ROBOTS_MARKER = ("share", "example-robot-data", "robots")


@dataclass(frozen=True)
class ArmSpec:
    """Where an arm's URDF is and which chain of it is the arm.

    Attributes:
        name: short name ('pa10', 'baxter', 'pr2').
        urdf_path: URDF file.
        base_link: reference frame of the chain.
        tip_frame: end frame of the chain.
        package_dirs: folders resolving the URDF's `package://` URIs.
        description: one line saying what the chain is and where it comes from.
    """

    name: str
    urdf_path: Path
    base_link: str
    tip_frame: str
    package_dirs: tuple[Path, ...]
    description: str

    def load(self) -> Kinematics:
        """Builds the chain's `Kinematics`."""
        return Kinematics.from_urdf(self.urdf_path, self.base_link, self.tip_frame, self.package_dirs)


@functools.cache
def example_robot_data_dir() -> Path:
    """The `robots/` folder of the installed example-robot-data distribution.

    Raises:
        InputError: the distribution is not installed or has no `robots/` folder.
    """
    try:
        dist = importlib.metadata.distribution(EXAMPLE_ROBOT_DATA)
    except importlib.metadata.PackageNotFoundError as err:
        raise InputError(
            f"{EXAMPLE_ROBOT_DATA} is not installed; `pip install '{EXAMPLE_ROBOT_DATA}>=6,<7'`"
        ) from err
    n = len(_ROBOTS_MARKER)
    for file in dist.files or ():
        parts = file.parts
        for i in range(len(parts) - n):
            if parts[i : i + n] == _ROBOTS_MARKER:
                robots = Path(str(dist.locate_file(Path(*parts[: i + n]))))
                if robots.is_dir():
                    return robots.resolve()
    raise InputError(
        f"{EXAMPLE_ROBOT_DATA} {dist.version} is installed but lists no share/example-robot-data/robots "
        "folder; reinstall it"
    )


def _example_arm(name: str, relative_urdf: str, base: str, tip: str, description: str) -> ArmSpec:
    robots = example_robot_data_dir()
    path = robots / relative_urdf
    if not path.is_file():
        raise InputError(f"{EXAMPLE_ROBOT_DATA} has no {relative_urdf} under {robots}")
    return ArmSpec(name, path, base, tip, (robots.parent.parent,), description)


def pa10_spec(tip_frame: str = PA10_FLANGE) -> ArmSpec:
    """The Mitsubishi PA10-7C of `urdf/pa10.urdf`, base_link -> tip_frame.

    Args:
        tip_frame: 'flange' (the bare arm) or a tool frame: 'tcp', 'camera_right_optical'.
    """
    path = urdf_path(PA10_URDF)
    return ArmSpec("pa10", path, PA10_BASE_LINK, tip_frame, (path.parent,), "Mitsubishi PA10-7C, 7 DoF")


def baxter_right_arm_spec() -> ArmSpec:
    """Baxter's right arm (7 DoF) from example-robot-data, base -> right_gripper."""
    return _example_arm(
        "baxter",
        "baxter_description/urdf/baxter.urdf",
        "base",
        "right_gripper",
        "Rethink Baxter right arm, 7 DoF (example-robot-data)",
    )


def pr2_right_arm_spec() -> ArmSpec:
    """PR2's right arm (7 DoF, two continuous) from example-robot-data, torso -> wrist roll."""
    return _example_arm(
        "pr2",
        "pr2_description/urdf/pr2.urdf",
        "torso_lift_link",
        "r_wrist_roll_link",
        "Willow Garage PR2 right arm, 7 DoF (example-robot-data)",
    )


_SPECS = {"pa10": pa10_spec, "baxter": baxter_right_arm_spec, "pr2": pr2_right_arm_spec}
ARM_NAMES: tuple[str, ...] = tuple(_SPECS)


def arm_spec(name: str) -> ArmSpec:
    """Spec of one of `ARM_NAMES`.

    Raises:
        InputError: unknown name.
    """
    if name not in _SPECS:
        raise InputError(
            f"unknown arm '{name}'; valid arms: {', '.join(ARM_NAMES)}",
            key="arm",
            value=name,
            expected=", ".join(ARM_NAMES),
        )
    return _SPECS[name]()


def load_arm(name: str) -> Kinematics:
    """`Kinematics` of one of `ARM_NAMES`."""
    return arm_spec(name).load()


__all__ = [
    "ARM_NAMES",
    "ArmSpec",
    "arm_spec",
    "baxter_right_arm_spec",
    "example_robot_data_dir",
    "load_arm",
    "pa10_spec",
    "pr2_right_arm_spec",
]
