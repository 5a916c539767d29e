"""urdf/pa10.urdf: published PA10-7C figures, the shared tool geometry, consistent inertias."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pinocchio as pin
import pybullet as p
import pytest

from robot_app.robot_description import urdf_path
from robot_app.vision.camera import PinholeCamera

URDF = urdf_path("pa10.urdf")
ARM_JOINTS = ("S1", "S2", "S3", "E1", "E2", "W1", "W2")
AXES = ("z", "y", "z", "y", "z", "y", "z")
LIMITS_DEG = (177, 94, 174, 137, 255, 165, 255)
VELOCITY_DEG_S = (57, 57, 114, 114, 360, 360, 360)
MASSES = (9.78, 8.41, 3.52, 4.31, 3.45, 1.46, 0.24)
ARM_LINKS = ("link_s1", "link_s2", "link_s3", "link_e1", "link_e2", "link_w1", "link_w2")


@pytest.fixture(scope="module")
def tree() -> ET.Element:
    return ET.parse(URDF).getroot()


@pytest.fixture(scope="module")
def model() -> pin.Model:
    return pin.buildModelFromUrdf(str(URDF))


def _frame_in_flange(model: pin.Model, name: str, q: np.ndarray | None = None) -> np.ndarray:
    data = model.createData()
    pin.framesForwardKinematics(model, data, pin.neutral(model) if q is None else q)
    flange = data.oMf[model.getFrameId("flange")]
    return np.array((flange.inverse() * data.oMf[model.getFrameId(name)]).homogeneous)


def test_urdf_is_self_contained(tree: ET.Element) -> None:
    assert not tree.findall(".//mesh"), "primitives only: no meshes to fetch"
    text = Path(URDF).read_text()
    for source in ("Mitsubishi", "Kennedy", "Velocity limits"):
        assert source in text, f"the file must cite its sources ({source})"


def test_arm_joints_limits_and_velocities(tree: ET.Element) -> None:
    joints = {j.get("name"): j for j in tree.findall("joint")}
    for name, axis, limit, velocity in zip(ARM_JOINTS, AXES, LIMITS_DEG, VELOCITY_DEG_S, strict=True):
        joint = joints[name]
        assert joint.get("type") == "revolute"
        expected_axis = {"y": [0.0, 1.0, 0.0], "z": [0.0, 0.0, 1.0]}[axis]
        assert [float(v) for v in joint.find("axis").get("xyz").split()] == expected_axis
        lim = joint.find("limit")
        assert np.rad2deg(float(lim.get("lower"))) == pytest.approx(-limit, abs=1e-6)
        assert np.rad2deg(float(lim.get("upper"))) == pytest.approx(limit, abs=1e-6)
        assert np.rad2deg(float(lim.get("velocity"))) == pytest.approx(velocity, abs=1e-6)


def test_link_lengths_match_the_published_figures(model: pin.Model) -> None:
    data = model.createData()
    pin.framesForwardKinematics(model, data, pin.neutral(model))  # arm straight up
    z = {name: data.oMi[model.getJointId(name)].translation[2] for name in ARM_JOINTS}
    flange_z = data.oMf[model.getFrameId("flange")].translation[2]
    assert z["S2"] == pytest.approx(0.317, abs=1e-12)
    assert z["E1"] - z["S2"] == pytest.approx(0.45, abs=1e-12)
    assert z["W1"] - z["E1"] == pytest.approx(0.48, abs=1e-12)
    assert flange_z - z["W1"] == pytest.approx(0.07, abs=1e-12)


def test_masses_and_inertias_match_the_primitives(tree: ET.Element) -> None:
    links = {link.get("name"): link for link in tree.findall("link")}
    for name, mass in zip(ARM_LINKS, MASSES, strict=True):
        assert float(links[name].find("inertial/mass").get("value")) == pytest.approx(mass)
    checked = 0
    for link in tree.findall("link"):
        geometry = link.find("collision/geometry")
        if geometry is None:
            continue
        m = float(link.find("inertial/mass").get("value"))
        if (cyl := geometry.find("cylinder")) is not None:
            r, h = float(cyl.get("radius")), float(cyl.get("length"))
            expected = (m * (3 * r * r + h * h) / 12, m * (3 * r * r + h * h) / 12, m * r * r / 2)
        else:
            sx, sy, sz = (float(v) for v in geometry.find("box").get("size").split())
            expected = (m * (sy**2 + sz**2) / 12, m * (sx**2 + sz**2) / 12, m * (sx**2 + sy**2) / 12)
        inertia = link.find("inertial/inertia")
        actual = [float(inertia.get(k)) for k in ("ixx", "iyy", "izz")]
        np.testing.assert_allclose(actual, expected, rtol=1e-5, err_msg=link.get("name"))
        assert [float(inertia.get(k)) for k in ("ixy", "ixz", "iyz")] == [0.0, 0.0, 0.0]
        assert link.find("inertial/origin").get("xyz") == link.find("collision/origin").get("xyz")
        assert link.find("visual/origin").get("xyz") == link.find("collision/origin").get("xyz")
        checked += 1
    assert checked == 14


def test_tool_frames_are_the_shared_geometry(model: pin.Model) -> None:
    expected = {
        "camera_right_optical": (0.05, -0.07, 0.06),
        "camera_left_optical": (-0.05, -0.07, 0.06),
        "tcp": (0.0, 0.0, 0.16),
    }
    for name, translation in expected.items():
        T = _frame_in_flange(model, name)
        np.testing.assert_allclose(T[:3, 3], translation, atol=1e-12, err_msg=name)
        np.testing.assert_allclose(T[:3, :3], np.eye(3), atol=1e-12, err_msg=name)
    # Rig convention X_right = R X_left + T: the left centre in the right frame.
    T_left_to_right = np.linalg.inv(_frame_in_flange(model, "camera_right_optical")) @ _frame_in_flange(
        model, "camera_left_optical"
    )
    np.testing.assert_allclose(T_left_to_right[:3, 3], (-0.1, 0.0, 0.0), atol=1e-12)


def test_gripper_fingers_close_along_flange_x(model: pin.Model, tree: ET.Element) -> None:
    joints = {j.get("name"): j for j in tree.findall("joint")}
    q = pin.neutral(model)
    for side, sign in (("left", -1.0), ("right", 1.0)):
        joint = joints[f"finger_{side}_joint"]
        assert joint.get("type") == "prismatic"
        assert float(joint.find("limit").get("lower")) == 0.0
        assert float(joint.find("limit").get("upper")) == pytest.approx(0.04)
        closed = _frame_in_flange(model, f"finger_{side}", q)[:3, 3]
        q_open = q.copy()
        q_open[model.joints[model.getJointId(f"finger_{side}_joint")].idx_q] = 0.04
        opened = _frame_in_flange(model, f"finger_{side}", q_open)[:3, 3]
        np.testing.assert_allclose(opened - closed, (sign * 0.04, 0.0, 0.0), atol=1e-12)


def _box_corners(link: ET.Element) -> np.ndarray:
    size = np.array([float(v) for v in link.find("collision/geometry/box").get("size").split()])
    centre = np.array([float(v) for v in link.find("collision/origin").get("xyz").split()])
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    return centre + signs * size / 2


@pytest.mark.parametrize("opening", [0.0, 0.04])
@pytest.mark.parametrize("camera", ["camera_left_optical", "camera_right_optical"])
def test_gripper_stays_out_of_the_cameras_view(
    model: pin.Model, tree: ET.Element, camera: str, opening: float
) -> None:
    """Fig. 8: the cameras see past the fingers (640x480, 48 deg horizontal FOV)."""
    lens = PinholeCamera.from_fov((640, 480), np.deg2rad(48.0))
    links = {link.get("name"): link for link in tree.findall("link")}
    q = pin.neutral(model)
    for side in ("left", "right"):
        q[model.joints[model.getJointId(f"finger_{side}_joint")].idx_q] = opening
    fy, cy = lens.camera_matrix[1, 1], lens.camera_matrix[1, 2]
    T_flange_to_camera = np.linalg.inv(_frame_in_flange(model, camera, q))
    for name in ("finger_left", "finger_right", "gripper_palm"):
        T_link_to_flange = _frame_in_flange(model, name, q)
        corners = _box_corners(links[name]) @ T_link_to_flange[:3, :3].T + T_link_to_flange[:3, 3]
        in_camera = corners @ T_flange_to_camera[:3, :3].T + T_flange_to_camera[:3, 3]
        # Out of view if the whole (convex) box lies beyond the plane through the
        # camera centre and the bottom image edge (v = height), or beyond the top edge.
        beyond_bottom = in_camera[:, 1] - in_camera[:, 2] * (480 - cy) / fy
        beyond_top = in_camera[:, 1] + in_camera[:, 2] * cy / fy
        assert np.all(beyond_bottom > 0) or np.all(beyond_top < 0), f"{name} is in the view of {camera}"


def test_pybullet_loads_it_with_the_same_masses() -> None:
    client = p.connect(p.DIRECT)
    try:
        robot = p.loadURDF(str(URDF), useFixedBase=True, physicsClientId=client)
        names = {
            p.getJointInfo(robot, i, physicsClientId=client)[12].decode(): i
            for i in range(p.getNumJoints(robot, physicsClientId=client))
        }
        for link, mass in zip(ARM_LINKS, MASSES, strict=True):
            assert p.getDynamicsInfo(robot, names[link], physicsClientId=client)[0] == pytest.approx(mass)
        for frame in ("flange", "camera_left_optical", "camera_right_optical", "tcp"):
            assert frame in names
    finally:
        p.disconnect(client)
