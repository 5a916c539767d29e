"""`world.cameras.rig_file`: the recogniser and the loop get the file's rig, rendering keeps the truth."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from robot_app.errors import ConfigError
from robot_app.geometry import make_transform, rotation_about_z
from robot_app.sim.config import CameraSettings, WorldConfig
from robot_app.sim.world import World
from robot_app.vision.camera import PinholeCamera, StereoRig, load_rig, save_rig

SIZE = (160, 120)


@pytest.fixture(scope="module")
def truth(tmp_path_factory: pytest.TempPathFactory) -> tuple[StereoRig, Path]:
    folder = tmp_path_factory.mktemp("rig_file")
    with World(WorldConfig(cameras=CameraSettings(image_size=SIZE))) as world:
        path = world.save_rig(folder / "truth.yaml")
    return load_rig(path), folder


def _perturbed(rig: StereoRig) -> StereoRig:
    assert rig.transform_right_camera_to_hand is not None
    K = rig.right.camera_matrix.copy()
    K[0, 0] *= 1.004
    camera = PinholeCamera(K, rig.image_size, [0.01, 0.0, 0.0, 0.0, 0.0])
    nudge = make_transform(rotation_about_z(np.deg2rad(0.3)), [0.002, -0.001, 0.003])
    return replace(
        rig, right=camera, transform_right_camera_to_hand=rig.transform_right_camera_to_hand @ nudge
    )


def test_recogniser_gets_the_file_rig_and_rendering_stays_true(truth) -> None:
    true_rig, folder = truth
    calibrated = _perturbed(true_rig)
    save_rig(calibrated, folder / "calibrated.yaml")
    with World(WorldConfig(cameras=CameraSettings(image_size=SIZE))) as world:
        plain = world.stereo.render()
    config = WorldConfig(cameras=CameraSettings(image_size=SIZE, rig_file=folder / "calibrated.yaml"))
    with World(config) as world:
        np.testing.assert_allclose(world.stereo.rig.right.camera_matrix, calibrated.right.camera_matrix)
        np.testing.assert_allclose(world.stereo.true_rig.right.camera_matrix, true_rig.right.camera_matrix)
        frame = world.stereo.render()
        hand = world.robot.frame_pose("flange")
        true_camera = world.robot.frame_pose("camera_right_optical")
    np.testing.assert_array_equal(frame.right_bgr, plain.right_bgr)  # the true cameras draw
    assert calibrated.transform_right_camera_to_hand is not None
    believed = hand @ calibrated.transform_right_camera_to_hand
    np.testing.assert_allclose(frame.transform_right_camera_to_world, believed, atol=1e-12)
    assert np.linalg.norm(frame.transform_right_camera_to_world[:3, 3] - true_camera[:3, 3]) > 0.003


def test_without_a_rig_file_the_capture_pose_is_the_true_camera(truth) -> None:
    with World(WorldConfig(cameras=CameraSettings(image_size=SIZE))) as world:
        frame = world.stereo.render()
        assert world.stereo.rig is world.stereo.true_rig
        np.testing.assert_array_equal(
            frame.transform_right_camera_to_world, world.robot.frame_pose("camera_right_optical")
        )


def test_a_rig_file_of_another_resolution_is_a_config_error(truth) -> None:
    true_rig, folder = truth
    camera = PinholeCamera.from_fov((320, 240), np.deg2rad(48))
    save_rig(replace(true_rig, left=camera, right=camera), folder / "other_size.yaml")
    config = WorldConfig(cameras=CameraSettings(image_size=SIZE, rig_file=folder / "other_size.yaml"))
    with pytest.raises(ConfigError) as caught:
        World(config)
    assert caught.value.key == "world.cameras.rig_file"
    assert caught.value.exit_code == 2


def test_a_rig_file_without_hand_eye_or_missing_is_a_config_error(truth) -> None:
    true_rig, folder = truth
    save_rig(replace(true_rig, transform_right_camera_to_hand=None), folder / "no_hand.yaml")
    for name in ("no_hand.yaml", "missing.yaml"):
        config = WorldConfig(cameras=CameraSettings(image_size=SIZE, rig_file=folder / name))
        with pytest.raises(ConfigError) as caught:
            World(config)
        assert caught.value.key == "world.cameras.rig_file"
        assert caught.value.path == folder / name
