"""The two hand cameras: render, shadow, and image each capture as a real stereo camera would.

A capture renders both cameras at the robot's current pose with the cell's light,
darkens what the key lamp does not reach (one shadow map per capture, shared by both
cameras), and passes each image through its camera's model (`imaging.CameraModel`):
exposure, white balance, vignetting, noise, motion blur, JPEG. The frame carries its
exposure time, the time it becomes available, and whether a frame was lost.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Protocol

import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray
from robot_app.console import warn_input
from robot_app.errors import ConfigError, RobotAppError
from robot_app.geometry import invert_transform
from robot_app.sim.cameras import (
    HAND_FRAME,
    LEFT_FRAME,
    RIGHT_FRAME,
    Lighting,
    StereoFrame,
    render_bgr_depth,
)
from robot_app.sim.config import WorldConfig
from robot_app.sim.imaging import CameraModel, FrameClock, image_motion
from robot_app.sim.lighting import ShadowMap, draw_lighting, render_two_sided, shade_shadows
from robot_app.sim.realism import CALIBRATED_RIG_PRESETS, calibrated_rig_file
from robot_app.vision.camera import PinholeCamera, StereoRig, load_rig, save_rig

if TYPE_CHECKING:
    from robot_app.sim.robot import SimRobot

MAX_FOOTPRINT_RANGE = 2.0  # a corner ray that misses the table counts this far out [m]


class _Clock(Protocol):
    """Anything with a simulated `time` [s] (the World)."""

    @property
    def time(self) -> float: ...


class StereoCamera:
    """The two hand cameras, rendered at the robot's `camera_*_optical` frames.

    `true_rig` (intrinsics from the config, extrinsics from the URDF) is what the
    renderer draws and `save_rig` writes. `rig` is what the recogniser and the loop are
    given: the truth, or the rig of `world.cameras.rig_file` (a calibration); with a rig
    file, a capture's camera pose is the measured flange pose times its camera-to-hand
    transform, as a real controller would compute it.

    Args:
        client: pybullet client id.
        robot: the arm carrying the cameras.
        config: the world's settings (cameras, lighting, imaging, table height).
        clock: the simulated clock.
        seed: seed of the cameras' noise, exposure and timing (see `reseed`).
    """

    def __init__(
        self, client: int, robot: SimRobot, config: WorldConfig, clock: _Clock, seed: int = 0
    ) -> None:
        self._client = client
        self._robot = robot
        self._config = config
        self._clock = clock
        width, height = config.cameras.image_size
        camera = PinholeCamera.from_fov((width, height), np.deg2rad(config.cameras.hfov_deg))
        left = robot.frame_pose(LEFT_FRAME)
        right = robot.frame_pose(RIGHT_FRAME)
        hand = robot.frame_pose(HAND_FRAME)
        self.true_rig = StereoRig(
            camera,
            camera,
            invert_transform(right) @ left,
            invert_transform(hand) @ right,
        )
        rig_file = config.cameras.rig_file
        self.rig = self.true_rig if rig_file is None else _calibrated_rig(rig_file, config.cameras.image_size)
        size = config.cameras.image_size
        uncalibrated = config.realism in CALIBRATED_RIG_PRESETS and calibrated_rig_file(size) is None
        if rig_file is None and uncalibrated:
            warn_input(
                f"world.realism={config.realism}: no calibrated rig for {list(size)} px cameras "
                "(configs/rig_calibrated_<w>x<h>.yaml); the recogniser gets the URDF's true cameras",
                key="world.cameras.rig_file",
            )
        self.lighting: Lighting = draw_lighting(config.lighting)
        white_point = config.lighting.key_rgb
        self._models = (
            CameraModel(config.imaging, (seed, 1), white_point),
            CameraModel(config.imaging, (seed, 2), white_point),
        )
        self._frame_clock = FrameClock(config.imaging, (seed, 3))

    def reseed(self, seed: int) -> None:
        """Restarts both cameras' generators (noise, white balance, exposure, timing) from `seed`."""
        self._models[0].reset((seed, 1))
        self._models[1].reset((seed, 2))
        self._frame_clock.reset((seed, 3))

    def render(self) -> StereoFrame:
        """Captures both cameras at the robot's current pose."""
        time = self._clock.time
        poses = (self._robot.frame_pose(LEFT_FRAME), self._robot.frame_pose(RIGHT_FRAME))
        cameras = (self.true_rig.left, self.true_rig.right)
        shadow_map = self.shadow_map(cameras, poses) if self._config.lighting.shadows else None
        images = []
        frames = (LEFT_FRAME, RIGHT_FRAME)
        for model, camera, pose, frame in zip(self._models, cameras, poses, frames, strict=True):
            near, far = self._config.cameras.near, self._config.cameras.far
            render = render_two_sided if self._config.lighting.two_sided else render_bgr_depth
            image, depth = render(self._client, camera, pose, near, far, self.lighting)
            if shadow_map is not None:
                penumbra = self._config.lighting.penumbra
                image = shade_shadows(image, depth, camera, pose, self.lighting, shadow_map, penumbra)
            blur = self._blur(frame, pose, depth, camera)
            image, _ = model.expose(image, time, blur)
            images.append(image)
        timing = self._frame_clock.timing(time)
        right_pose = poses[1]
        if self.rig is not self.true_rig and self.rig.transform_right_camera_to_hand is not None:
            right_pose = self._robot.frame_pose(HAND_FRAME) @ self.rig.transform_right_camera_to_hand
        return StereoFrame(images[0], images[1], time, right_pose, timing.available_time, timing.dropped)

    def expose_uniform_card(self, level: float = 0.8) -> tuple[npt.NDArray[np.uint8], npt.NDArray[np.uint8]]:
        """Both cameras looking into a uniformly lit white card that fills their view.

        A flat-field frame, as a real rig takes one (a diffuser over the lenses, or a
        matte card under even light): every pixel receives the same light, `level` of
        full scale at unit gain in the lamp's colour; each camera's own model then adds
        what it adds to every capture (vignetting, exposure, noise, white balance, JPEG).
        The card is ideally even here, which a real one never quite is.
        """
        width, height = self._config.cameras.image_size
        lamp = np.asarray(self._config.lighting.key_rgb, dtype=float)
        bgr = 255.0 * level * lamp[::-1] / float(lamp.max())
        card = np.broadcast_to(np.rint(bgr).astype(np.uint8), (height, width, 3)).copy()
        time = self._clock.time
        left, _ = self._models[0].expose(card, time)
        right, _ = self._models[1].expose(card, time)
        return left, right

    def save_rig(self, path: str | Path) -> Path:
        """Writes the true rig YAML (docs/architecture.md format) and returns its path."""
        save_rig(self.true_rig, path)
        return Path(path)

    def shadow_map(
        self, cameras: tuple[PinholeCamera, ...], poses: tuple[FloatArray, ...], size: int | None = None
    ) -> ShadowMap:
        """The key lamp's depth over the part of the table the cameras see.

        Args:
            cameras: intrinsics of each camera.
            poses: their 4x4 OpenCV poses [m].
            size: shadow map side [px] (default: `lighting.shadow_map_size`).
        """
        top = self._config.table.top_z
        corners = np.concatenate([table_footprint(c, p, top) for c, p in zip(cameras, poses, strict=True)])
        centre = corners.mean(axis=0)
        radius = float(np.max(np.linalg.norm(corners - centre, axis=1))) + 0.03
        size = size or self._config.lighting.shadow_map_size
        return ShadowMap.render(self._client, self.lighting, centre, radius, size)

    def _blur(
        self, frame: str, pose: FloatArray, depth: FloatArray, camera: PinholeCamera
    ) -> tuple[float, float]:
        """Image motion over the exposure [px] from the camera's velocity and the scene depth."""
        exposure_time = self._config.imaging.exposure_time
        if exposure_time <= 0:
            return (0.0, 0.0)
        linear, angular = self._robot.frame_velocity(frame)
        R = pose[:3, :3]
        valid = depth[depth < 0.99 * self._config.cameras.far]
        scene_depth = float(np.median(valid)) if valid.size else 1.0
        du, dv = image_motion(R.T @ linear, R.T @ angular, scene_depth, camera.camera_matrix[0, 0])
        return (du * exposure_time, dv * exposure_time)


def table_footprint(camera: PinholeCamera, pose: npt.ArrayLike, table_z: float) -> FloatArray:
    """(5, 3) where the image corners' and centre's rays meet the table plane [m]."""
    T = np.asarray(pose, dtype=float)
    width, height = camera.image_size
    K_inv = np.linalg.inv(camera.camera_matrix)
    pixels = np.array(
        [[0, 0, 1], [width, 0, 1], [0, height, 1], [width, height, 1], [width / 2, height / 2, 1]]
    )
    rays = (T[:3, :3] @ (K_inv @ pixels.T)).T
    rays /= np.linalg.norm(rays, axis=1, keepdims=True)
    origin = T[:3, 3]
    with np.errstate(divide="ignore"):
        reach = (table_z - origin[2]) / rays[:, 2]
    hits = (reach > 0) & np.isfinite(reach)
    reach = np.where(hits, np.minimum(reach, MAX_FOOTPRINT_RANGE), MAX_FOOTPRINT_RANGE)
    return origin + rays * reach[:, None]


def _calibrated_rig(path: Path, image_size: tuple[int, int]) -> StereoRig:
    """The rig of a `rig_file` setting, checked against the cameras it stands for."""
    key, value = "world.cameras.rig_file", str(path)
    try:
        rig = load_rig(path)
    except RobotAppError as err:
        raise ConfigError(f"{key}: {err}", key=key, value=value, path=path) from err
    if rig.image_size != tuple(image_size):
        raise ConfigError(
            f"{key}: {path} is a rig for {list(rig.image_size)} px images but the cameras are "
            f"{list(image_size)} px (calibrate at the resolution the cameras run at)",
            key=key,
            value=value,
            path=path,
            expected=f"a rig with image_size {list(image_size)}",
        )
    if rig.transform_right_camera_to_hand is None:
        raise ConfigError(
            f"{key}: {path} has no transform_right_camera_to_hand (run robot-app calibrate hand-eye)",
            key=key,
            value=value,
            path=path,
        )
    return rig


__all__ = ["StereoCamera", "table_footprint"]
