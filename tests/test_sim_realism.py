"""Realism presets: config rules, the clean cell bit for bit, seeded images, noise, light,
wrinkles, folds and motion blur in the simulated cell. Each test fails if its feature
silently vanished."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pybullet as pb
import pytest

from robot_app.cli import main
from robot_app.console import InputWarning
from robot_app.errors import ConfigError
from robot_app.geometry import make_transform
from robot_app.sim import (
    Lighting,
    ModelStation,
    SceneSettings,
    World,
    cameras,
    cloth_spec,
    make_scene,
    render_bgr,
)
from robot_app.sim.cameras import gl_projection_matrix
from robot_app.sim.cloth_visual import ClothLook, Fold, Ridge
from robot_app.sim.config import StationSettings, WorldConfig, load_world_config
from robot_app.sim.lighting import direction_from_angles
from robot_app.sim.realism import PRESETS
from robot_app.vision.camera import PinholeCamera

DATA = Path(__file__).parent / "data"
SMALL = {"cameras": {"image_size": (160, 120)}}


def _config(realism: str, **extra: object) -> WorldConfig:
    return WorldConfig.model_validate({"realism": realism, **SMALL, **extra})


def _plane_deviation(points: np.ndarray) -> np.ndarray:
    centred = points - points.mean(axis=0)
    normal = np.linalg.svd(centred)[2][2]
    return centred @ normal


# --- config -----------------------------------------------------------------------------


def test_presets_fill_only_the_keys_not_given(tmp_path: Path) -> None:
    realistic = WorldConfig()
    assert realistic.realism == "realistic"
    assert realistic.lighting.shadows and realistic.imaging.exposure == "auto"
    assert realistic.imaging.noise_sigma == PRESETS["realistic"]["imaging"]["noise_sigma"]
    clean = WorldConfig(realism="clean")
    assert not clean.lighting.shadows and clean.imaging.jpeg_quality is None and not clean.appearance.fabric
    file = tmp_path / "world.yaml"
    file.write_text("realism: harsh\nimaging:\n  noise_sigma: 5.0\nlighting:\n  station:\n    key: 0.3\n")
    harsh = load_world_config(file, ("imaging.jpeg_quality=60",))
    assert harsh.imaging.noise_sigma == 5.0  # from the file
    assert harsh.imaging.jpeg_quality == 60  # from --set
    assert harsh.imaging.vignetting == PRESETS["harsh"]["imaging"]["vignetting"]  # from the preset
    assert harsh.lighting.station.key == 0.3
    assert harsh.lighting.station.zenith_deg == PRESETS["harsh"]["lighting"]["station"]["zenith_deg"]


def test_bad_realism_values_name_their_key() -> None:
    with pytest.raises(ConfigError) as err:
        load_world_config(overrides=("realism=foggy",))
    assert err.value.key == "realism" and err.value.value == "foggy" and err.value.exit_code == 2
    for key, value in (
        ("imaging.noise_sigma", -1),
        ("imaging.jpeg_quality", 500),
        ("lighting.key_zenith_deg", [50, 30]),
    ):
        with pytest.raises(ConfigError) as err:
            load_world_config(overrides=(f"{key}={value}",))
        assert err.value.key == key


def test_cli_rejects_an_unknown_preset_with_exit_2(tmp_path: Path) -> None:
    assert main(["sim", "show", "--realism", "foggy", "--out", str(tmp_path / "pictures")]) == 2
    assert not (tmp_path / "pictures").exists()


# --- clean: the old images, bit for bit -----------------------------------------------


def _pre_fix_projection(camera: PinholeCamera, near: float, far: float) -> list[float]:
    """The renderer's projection before the principal-point fix (cx + 0.5, cy + 0.5 where the
    fix has cx, cy + 1): the images in tests/data were rendered with it."""
    K = camera.camera_matrix.copy()
    K[0, 2] += 0.5
    K[1, 2] -= 0.5
    return gl_projection_matrix(PinholeCamera(K, camera.image_size, camera.dist_coeffs), near, far)


def test_clean_reproduces_the_old_images_bit_for_bit(monkeypatch: pytest.MonkeyPatch) -> None:
    """`clean` adds nothing to the renderer: with the projection the old simulator had (its
    principal point was later corrected by half a pixel, measured on rendered board
    corners), a clean capture and station photo are the pre-realism images bit for bit."""
    monkeypatch.setattr(cameras, "gl_projection_matrix", _pre_fix_projection)
    config = _config("clean", station=StationSettings(image_size=(160, 120)))
    with World(config) as world:
        make_scene(world, SceneSettings(target=3, distractor=4, occluder=True), seed=1)
        frame = world.stereo.render()
    np.testing.assert_array_equal(
        np.hstack([frame.left_bgr, frame.right_bgr]), cv2.imread(str(DATA / "clean_stereo_seed1.png"))
    )
    assert frame.available_time == frame.time and not frame.dropped
    with ModelStation.for_world(config) as station:
        photo = station.photograph(cloth_spec(3))
    np.testing.assert_array_equal(
        np.hstack([photo.photo_bgr, photo.background_bgr]), cv2.imread(str(DATA / "clean_station_no3.png"))
    )


# --- seeded realism --------------------------------------------------------------------


def _capture(realism: str, seed: int) -> tuple[np.ndarray, np.ndarray, float]:
    with World(_config(realism)) as world:
        make_scene(world, SceneSettings(target=13, distractor=16), seed)
        frames = [world.stereo.render() for _ in range(2)]
    return (
        np.hstack([frames[0].left_bgr, frames[0].right_bgr]),
        np.hstack([frames[1].left_bgr, frames[1].right_bgr]),
        frames[0].available_time - frames[0].time,
    )


def test_same_seed_same_images_and_another_seed_other_images() -> None:
    first, second, latency = _capture("harsh", 4)
    again, again_second, _ = _capture("harsh", 4)
    np.testing.assert_array_equal(first, again)
    np.testing.assert_array_equal(second, again_second)
    assert not np.array_equal(first, second)  # the next capture has its own noise
    other, _, _ = _capture("harsh", 5)
    assert not np.array_equal(first, other)
    assert (
        latency >= PRESETS["harsh"]["imaging"]["latency"] - 4 * PRESETS["harsh"]["imaging"]["latency_jitter"]
    )


def test_realistic_images_are_noisy_where_clean_ones_are_flat() -> None:
    patches = {}
    for realism in ("clean", "realistic"):
        with World(_config(realism)) as world:
            world.reseed(0)
            image = world.stereo.render().right_bgr  # the empty green sheet
        patches[realism] = image[50:70, 70:90].reshape(-1, 3).astype(float)
    assert patches["clean"].std(axis=0).max() == 0.0
    assert patches["realistic"].std(axis=0).min() > 0.7


# --- light -----------------------------------------------------------------------------


def _lower_hand(world: World, height: float) -> None:
    target = world.transform_observation_camera_to_world.copy()
    target[2, 3] = world.config.table.top_z + height
    world.robot.reset_joints(
        world.robot.solve_frame_ik("camera_right_optical", target, world.observation_joints)
    )


def _hand_over_sheet(shadows: bool) -> tuple[np.ndarray, tuple[int, int], float]:
    """The right image with the hand 0.22 m over the sheet and the lamp right behind the
    fingertips as seen from a sheet point in view; that point's pixel; the lamp's zenith."""
    ideal = {"exposure": "fixed", "noise_sigma": 0.0, "full_well": None, "vignetting": 0.0}
    ideal |= {"jpeg_quality": None, "white_balance_error": 0.0, "flicker": 0.0}
    config = _config("realistic", imaging=ideal, lighting={"shadows": shadows})
    with World(config) as world:
        _lower_hand(world, 0.22)
        camera = world.robot.frame_pose("camera_right_optical")
        fingertip = world.robot.frame_pose("tcp")[:3, 3]
        ground = camera[:3, 3] + camera[:3, :3] @ np.array([0.04, 0.03, 0.0])
        ground[2] = world.config.table.top_z - 0.0015
        direction = (fingertip - ground) / np.linalg.norm(fingertip - ground)
        zenith = float(np.degrees(np.arccos(direction[2])))
        azimuth = float(np.degrees(np.arctan2(direction[1], direction[0])))
        world.stereo.lighting = Lighting(0.3, 0.7, direction_from_angles(zenith, azimuth))
        image = world.stereo.render().right_bgr
        u, v = world.stereo.rig.right.project((np.linalg.inv(camera) @ [*ground, 1.0])[None, :3])[0]
    return image, (round(float(u)), round(float(v))), zenith


def test_the_hand_casts_its_shadow_on_the_sheet_under_it() -> None:
    image, (u, v), zenith = _hand_over_sheet(shadows=True)
    assert 20 < zenith < 70
    shadow = image[v - 2 : v + 3, u - 2 : u + 3, 1].mean()
    corner = (5, 5) if u > 80 else (5, 150)  # the same sheet, far from the hand's shadow
    open_sheet = image[corner[0] : corner[0] + 5, corner[1] : corner[1] + 5, 1].mean()
    # in shadow only the ambient share is left: 0.3 / (0.3 + 0.7 cos(zenith))
    assert shadow / open_sheet < 0.3 / (0.3 + 0.7 * np.cos(np.radians(zenith))) + 0.1
    unshadowed, _, _ = _hand_over_sheet(shadows=False)
    assert unshadowed[v - 2 : v + 3, u - 2 : u + 3, 1].mean() > 0.95 * open_sheet


def test_specular_term_and_lamp_colour_reach_the_renderer() -> None:
    with World(_config("clean")) as world:
        camera = world.stereo.rig.right
        pose = world.robot.frame_pose("camera_right_optical")
        direction = direction_from_angles(40.0, 30.0)
        matte = render_bgr(world.client, camera, pose, lighting=Lighting(0.3, 0.6, direction))
        shiny = render_bgr(world.client, camera, pose, lighting=Lighting(0.3, 0.6, direction, 0.3))
        warm = render_bgr(
            world.client, camera, pose, lighting=Lighting(0.3, 0.6, direction, 0.0, (1.0, 0.9, 0.6))
        )
    sheet = (slice(50, 70), slice(70, 90))
    assert shiny[sheet].astype(float).mean() > matte[sheet].astype(float).mean() + 1.0
    b, g, r = warm[sheet].astype(float).mean(axis=(0, 1)) / np.maximum(
        matte[sheet].astype(float).mean(axis=(0, 1)), 1
    )
    assert b < g <= r + 1e-9


def test_the_key_lamp_direction_is_drawn_per_scene_within_its_range() -> None:
    zeniths = []
    with World(_config("realistic")) as world:
        for seed in range(12):
            world.reseed(seed)
            zeniths.append(np.degrees(np.arccos(world.lighting.direction[2])))
    low, high = PRESETS["realistic"]["lighting"]["key_zenith_deg"]
    assert min(zeniths) >= low - 1e-9 and max(zeniths) <= high + 1e-9 and np.ptp(zeniths) > 5


# --- cloths that are not flat ----------------------------------------------------------


def test_wrinkled_cloth_is_not_flat_but_its_ground_truth_is_the_placement() -> None:
    with World(_config("realistic")) as world:
        scene = make_scene(world, SceneSettings(target=1), seed=3)
        cloth = scene.target
        _, render = pb.getMeshData(cloth.body_id, -1, physicsClientId=world.client)
        render = np.asarray(render)
        deviation = _plane_deviation(render)
        height = render[:, 2].max() - world.config.table.top_z
        amplitude = PRESETS["realistic"]["scene"]["wrinkle_amplitude"]
        assert np.sqrt(np.mean(deviation**2)) > 0.0008  # the rendered cloth has relief
        assert 0.003 < height < 1.6 * amplitude + 0.003  # a few mm to about a centimetre
        # the physics nodes lie on the table; the truth is the Kabsch fit of the rest nodes
        assert np.abs(_plane_deviation(cloth.nodes())).max() < 0.002
        pose = cloth.pose()
        assert abs(pose[2, 3] - world.config.table.top_z) < 0.004
    with World(_config("clean")) as world:
        flat = make_scene(world, SceneSettings(target=1), seed=3).target
        np.testing.assert_allclose(flat.pose()[:3, 3], pose[:3, 3], atol=0.002)  # same place, same truth


def test_a_wrinkled_cloth_is_grasped_where_it_is_drawn() -> None:
    # the drawn ridges stand above the flat physics nodes; fingers closing on a ridge hold it
    with World(_config("realistic")) as world:
        ridge = Ridge((0.0, 0.0), 0.3, 0.01, 0.012, 0.05)
        wrinkled = world.add_cloth(cloth_spec(1), 0.55, -0.1, 0.0, look=ClothLook((ridge,)))
        flat = world.add_cloth(cloth_spec(1), 0.55, 0.15, 0.0)
        lift = (wrinkled.drawn_nodes() - wrinkled.nodes())[:, 2]
        assert 0.004 < lift.max() < 0.012
        assert np.abs(flat.drawn_nodes() - flat.nodes()).max() < 0.0015


def test_a_folded_corner_shows_the_darker_back_side_on_top() -> None:
    config = _config("clean", appearance={"fabric": True}, cameras={"image_size": (320, 240)})
    with World(config) as world:
        world.reseed(0)
        spec = cloth_spec(17)  # white towel: front bright, back darker
        fold = Fold(angle=0.0, share=0.6)  # the +x 40% of the nodes fold over
        cloth = world.add_cloth(spec, 0.55, 0.0, 0.0, look=ClothLook((), fold))
        rest = cloth.mesh.vertices
        flap = fold.along(rest) > fold.line(rest)
        nodes = cloth.nodes()
        # the flap's nodes now lie over the rest of the cloth, mirrored about the fold line
        assert (
            nodes[flap, :2].mean(axis=0) @ cloth.pose()[:2, 0]
            < nodes[~flap, :2].max(axis=0) @ cloth.pose()[:2, 0]
        )
        image = world.stereo.render().right_bgr
        camera = world.robot.frame_pose("camera_right_optical")
        pixels = world.stereo.rig.right.project(
            (np.linalg.inv(camera) @ np.c_[nodes, np.ones(len(nodes))].T).T[:, :3]
        )
        values = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY).astype(float)
        flap_grey = np.mean([values[round(v), round(u)] for u, v in pixels[flap]])
        # front nodes beyond the part the flap covers stay visible
        along, line = fold.along(rest), fold.line(rest)
        far_front = along < 2 * line - along.max() - 0.01
        assert far_front.sum() >= 5
        front_grey = np.mean([values[round(v), round(u)] for u, v in pixels[far_front]])
        assert flap_grey < 0.85 * front_grey


# --- motion ----------------------------------------------------------------------------


def test_capture_blur_follows_the_camera_velocity() -> None:
    with World(_config("harsh")) as world:
        world.reseed(0)
        assert world.stereo._blur(  # at rest: no blur
            "camera_right_optical",
            world.robot.frame_pose("camera_right_optical"),
            np.full((4, 4), 0.58),
            world.stereo.rig.right,
        ) == (0.0, 0.0)
        q = world.robot.q()
        for index, speed in zip(world.robot.joint_indices, [0.4, 0, 0, 0, 0, 0, 0], strict=True):
            pb.resetJointState(world.robot.body_id, index, q[world.robot.joint_indices.index(index)], speed,
                               physicsClientId=world.client)  # fmt: skip
        pose = world.robot.frame_pose("camera_right_optical")
        du, dv = world.stereo._blur(
            "camera_right_optical", pose, np.full((4, 4), 0.58), world.stereo.rig.right
        )
        linear, _ = world.robot.frame_velocity("camera_right_optical")
        # S1 turning at 0.4 rad/s swings the hand about 0.2 m/s sideways: several pixels in 20 ms
        expected = np.linalg.norm(linear) / 0.58 * world.stereo.rig.right.camera_matrix[0, 0] * 0.02
        assert np.hypot(du, dv) == pytest.approx(expected, rel=0.35)
        assert np.hypot(du, dv) > 1.0


def test_same_scene_lays_identical_physics_in_every_realism() -> None:
    poses = []
    for realism in ("clean", "harsh"):
        with World(_config(realism)) as world:
            scene = make_scene(world, SceneSettings(target=5, distractor=9), seed=2)
            poses.append(make_transform(np.eye(3), scene.target.pose()[:3, 3]))
    np.testing.assert_allclose(poses[0], poses[1], atol=0.003)


def test_realistic_presets_give_the_recogniser_a_calibrated_rig() -> None:
    """realistic and harsh hand the recogniser the rig a simulated calibration measured;
    clean and an explicit null keep the URDF truth; a size never calibrated warns."""
    for realism in ("realistic", "harsh"):
        config = load_world_config(None, (f"realism={realism}", "cameras.image_size=[320,240]"))
        assert (
            config.cameras.rig_file is not None
            and config.cameras.rig_file.name == "rig_calibrated_320x240.yaml"
        )
    assert load_world_config(None, ("realism=clean",)).cameras.rig_file is None
    assert load_world_config(None, ("realism=realistic", "cameras.rig_file=null")).cameras.rig_file is None
    odd = load_world_config(None, ("realism=realistic", "cameras.image_size=[160,120]"))
    assert odd.cameras.rig_file is None
    with pytest.warns(InputWarning, match="no calibrated rig"), World(odd) as world:
        assert world.stereo.rig is world.stereo.true_rig
    config = load_world_config(None, ("realism=realistic", "cameras.image_size=[320,240]"))
    with World(config) as world:
        truth, used = world.stereo.true_rig, world.stereo.rig
        assert used is not truth
        # a calibration's errors, not the truth: focal lengths differ a little, not much
        focal_error = abs(used.right.camera_matrix[0, 0] / truth.right.camera_matrix[0, 0] - 1.0)
        assert 0.0 < focal_error < 0.005
        assert used.transform_right_camera_to_hand is not None
        offset = used.transform_right_camera_to_hand[:3, 3] - truth.transform_right_camera_to_hand[:3, 3]
        assert 0.0 < np.linalg.norm(offset) < 0.002
