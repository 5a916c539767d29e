"""Arm specs: example-robot-data found from the installed distribution; PA10 URDF located."""

from __future__ import annotations

import importlib.metadata
import shutil
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from robot_app import robot_description as _paths
from robot_app.control.robot_models import (
    ARM_NAMES,
    arm_spec,
    example_robot_data_dir,
    load_arm,
    pa10_spec,
)
from robot_app.errors import InputError

EXPECTED_JOINTS = {
    "pa10": ("S1", "S2", "S3", "E1", "E2", "W1", "W2"),
    "baxter": ("right_s0", "right_s1", "right_e0", "right_e1", "right_w0", "right_w1", "right_w2"),
    "pr2": (
        "r_shoulder_pan_joint",
        "r_shoulder_lift_joint",
        "r_upper_arm_roll_joint",
        "r_elbow_flex_joint",
        "r_forearm_roll_joint",
        "r_wrist_flex_joint",
        "r_wrist_roll_joint",
    ),
}


def test_example_robot_data_is_found_inside_the_installed_distribution() -> None:
    robots = example_robot_data_dir()
    assert robots.parts[-3:] == ("share", "example-robot-data", "robots")
    assert (robots / "baxter_description" / "urdf" / "baxter.urdf").is_file()
    dist_root = Path(str(importlib.metadata.distribution("example-robot-data").locate_file(""))).resolve()
    assert dist_root in robots.parents


@pytest.mark.parametrize("name", ARM_NAMES)
def test_each_arm_loads_its_seven_joint_chain(name: str) -> None:
    spec = arm_spec(name)
    assert spec.urdf_path.is_file()
    kin = spec.load()
    assert kin.joint_names == EXPECTED_JOINTS[name]
    assert np.all(kin.lower < kin.upper)
    assert np.all(kin.velocity_limits > 0)


@pytest.mark.parametrize("name", ["baxter", "pr2"])
def test_reduced_chain_fk_equals_the_full_model(name: str) -> None:
    """Locking the other joints keeps the chain's kinematics: compare with the full tree."""
    spec = arm_spec(name)
    kin = spec.load()
    full = pin.buildModelFromUrdf(str(spec.urdf_path))
    data = full.createData()
    rng = np.random.default_rng(2)
    for _ in range(10):
        q = kin.random_configuration(rng)
        q_full = pin.neutral(full)
        for joint_name, value in zip(kin.joint_names, q, strict=True):
            joint = full.joints[full.getJointId(joint_name)]
            if joint.nq == 2:
                q_full[joint.idx_q : joint.idx_q + 2] = (np.cos(value), np.sin(value))
            else:
                q_full[joint.idx_q] = value
        pin.framesForwardKinematics(full, data, q_full)
        base = data.oMf[full.getFrameId(spec.base_link)]
        tip = data.oMf[full.getFrameId(spec.tip_frame)]
        np.testing.assert_allclose(kin.tip_pose(q), (base.inverse() * tip).homogeneous, atol=1e-12)


def test_pa10_spec_points_at_the_repository_urdf() -> None:
    spec = pa10_spec()
    repo_urdf = Path(__file__).resolve().parents[1] / "urdf" / "pa10.urdf"
    assert spec.urdf_path.resolve() == repo_urdf
    assert (spec.base_link, spec.tip_frame) == ("base_link", "flange")
    assert pa10_spec("tcp").load().tip_frame == "tcp"


def test_urdf_dir_can_be_overridden(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    shutil.copy(pa10_spec().urdf_path, tmp_path / "pa10.urdf")
    monkeypatch.setenv(_paths.URDF_DIR_ENV, str(tmp_path))
    assert pa10_spec().urdf_path == tmp_path / "pa10.urdf"
    with pytest.raises(InputError) as missing:
        _paths.urdf_path("no_such_robot.urdf")
    assert (missing.value.path, missing.value.key) == (Path("no_such_robot.urdf"), "ROBOT_APP_URDF_DIR")
    assert str(tmp_path) in missing.value.expected  # the variable's folder was searched


def test_unknown_arm_raises_input_error() -> None:
    with pytest.raises(InputError) as unknown:
        arm_spec("ur5")
    assert (unknown.value.key, unknown.value.value, unknown.value.expected) == (
        "arm",
        "ur5",
        "pa10, baxter, pr2",
    )
    with pytest.raises(InputError) as also_unknown:
        load_arm("kuka")
    assert also_unknown.value.value == "kuka"


def test_package_carries_a_link_to_the_urdf_folder_for_wheels() -> None:
    """A regular (non-editable) install finds the URDF at robot_app/urdf/ (wheel package data)."""
    import robot_app

    packaged = Path(robot_app.__file__).parent / "urdf" / "pa10.urdf"
    assert packaged.resolve() == (Path(__file__).resolve().parents[1] / "urdf" / "pa10.urdf")
    assert packaged.parent in _paths.urdf_search_dirs()
