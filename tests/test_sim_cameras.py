"""Rendering agrees with the rig file: projected points land on the rendered pixels."""

from __future__ import annotations

import numpy as np
import pybullet as pb
import pytest

from robot_app.geometry import invert_transform, make_transform, transform_points
from robot_app.sim.cameras import gl_projection_matrix, render_bgr
from robot_app.sim.config import CameraSettings, WorldConfig
from robot_app.sim.world import World
from robot_app.vision.camera import PinholeCamera, load_rig


@pytest.fixture(scope="module")
def world() -> World:
    # geometry, not looks: the clean cell draws the markers in their pure colours
    with World(WorldConfig(realism="clean", cameras=CameraSettings(image_size=(320, 240)))) as w:
        yield w


def _marker(world: World, xyz: np.ndarray, rgb: tuple[float, float, float]) -> int:
    client = world.client
    shape = pb.createVisualShape(pb.GEOM_SPHERE, radius=0.004, rgbaColor=[*rgb, 1], physicsClientId=client)
    return pb.createMultiBody(0, -1, shape, xyz.tolist(), physicsClientId=world.client)


def _centroid(image: np.ndarray, bgr: tuple[int, int, int]) -> np.ndarray:
    mask = np.all(np.abs(image.astype(int) - np.array(bgr)) < 60, axis=2)
    assert mask.sum() >= 4, "marker not visible"
    v, u = np.nonzero(mask)
    return np.array([u.mean(), v.mean()])


def test_rig_file_projection_lands_on_rendered_marker(world: World, tmp_path) -> None:
    rig = load_rig(world.save_rig(tmp_path / "rig.yaml"))
    rng = np.random.default_rng(7)
    camera_to_world = world.robot.frame_pose("camera_right_optical")
    errors = []
    for _ in range(4):
        point_camera = np.array([rng.uniform(-0.15, 0.15), rng.uniform(-0.1, 0.1), rng.uniform(0.45, 0.6)])
        point_world = transform_points(camera_to_world, point_camera)[0]
        marker = _marker(world, point_world, (1.0, 0.0, 0.0))
        frame = world.stereo.render()
        world.remove_body(marker)
        model = make_transform(np.eye(3), point_camera)
        left_px, right_px = rig.project_model(model, np.zeros((1, 3)))
        errors.append(np.linalg.norm(_centroid(frame.right_bgr, (0, 0, 255)) - right_px[0]))
        errors.append(np.linalg.norm(_centroid(frame.left_bgr, (0, 0, 255)) - left_px[0]))
    assert max(errors) < 1.0, errors


def test_rig_matches_urdf_camera_geometry(world: World) -> None:
    rig = world.stereo.rig
    np.testing.assert_allclose(rig.transform_left_to_right[:3, 3], [-0.1, 0, 0], atol=1e-6)
    np.testing.assert_allclose(rig.transform_left_to_right[:3, :3], np.eye(3), atol=1e-6)
    np.testing.assert_allclose(rig.transform_right_camera_to_hand[:3, 3], [0.05, -0.07, 0.06], atol=1e-6)


def test_observation_pose_puts_camera_above_range_centre(world: World) -> None:
    world.robot.reset_joints(world.observation_joints)
    pose = world.robot.frame_pose("camera_right_optical")
    centre = world.config.range.centre_xy
    np.testing.assert_allclose(pose[:3, 3], [*centre, world.config.table.top_z + 0.58], atol=1e-4)
    np.testing.assert_allclose(pose[:3, 2], [0, 0, -1], atol=1e-4)  # optical axis straight down


def test_off_centre_principal_point_is_rendered_where_projected() -> None:
    client = pb.connect(pb.DIRECT)
    try:
        K = np.array([[300.0, 0, 140.0], [0, 300.0, 130.0], [0, 0, 1]])
        camera = PinholeCamera(K, (320, 240))
        pose = make_transform(np.diag([1.0, -1.0, -1.0]), [0, 0, 0.5])
        point = np.array([0.03, -0.02, 0.0])
        blue = [0, 0, 1, 1]
        shape = pb.createVisualShape(pb.GEOM_SPHERE, radius=0.003, rgbaColor=blue, physicsClientId=client)
        pb.createMultiBody(0, -1, shape, point.tolist(), physicsClientId=client)
        image = render_bgr(client, camera, pose)
        expected = camera.project(transform_points(invert_transform(pose), point))[0]
        assert np.linalg.norm(_centroid(image, (255, 0, 0)) - expected) < 1.0
        assert len(gl_projection_matrix(camera, 0.1, 2.0)) == 16
    finally:
        pb.disconnect(client)
