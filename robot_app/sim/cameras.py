"""Rendering: the hand stereo pair and the Fig. 7 model-generation photo.

This is the one place where pybullet's GL camera meets the OpenCV convention of
`robot_app.vision.camera`: an OpenCV camera frame (x right, y down, z forward) is the GL
camera frame turned 180° about x, and the GL projection is built from the intrinsics so
that a point projected with `PinholeCamera.project` lands on the rendered pixel.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

import numpy as np
import numpy.typing as npt
import pybullet as pb

from robot_app.arrays import FloatArray
from robot_app.errors import CalibrationError, ConfigError, RobotAppError
from robot_app.geometry import invert_transform
from robot_app.sim.config import CameraSettings
from robot_app.vision.camera import PinholeCamera, StereoRig, load_rig, save_rig

if TYPE_CHECKING:
    from robot_app.sim.robot import SimRobot

GL_FROM_CV = np.diag([1.0, -1.0, -1.0, 1.0])  # OpenCV camera axes -> GL camera axes
LEFT_FRAME, RIGHT_FRAME, HAND_FRAME = "camera_left_optical", "camera_right_optical", "flange"


@dataclass(frozen=True)
class Lighting:
    """TinyRenderer lighting; no specular term and no shadows, so hues stay the texture's."""

    ambient: float = 0.6
    diffuse: float = 0.4
    direction: tuple[float, float, float] = (0.0, 0.0, 1.0)


def gl_view_matrix(transform_camera_to_world: npt.ArrayLike) -> list[float]:
    """pybullet view matrix (16 floats, column-major) of an OpenCV camera pose."""
    T = np.asarray(transform_camera_to_world, dtype=float)
    view = GL_FROM_CV @ invert_transform(T)  # world -> GL camera
    return view.T.reshape(-1).tolist()


def gl_projection_matrix(camera: PinholeCamera, near: float, far: float) -> list[float]:
    """pybullet projection matrix (16 floats, column-major) reproducing `camera`'s intrinsics.

    pybullet's TinyRenderer samples pixel i at the integer window coordinate i, as OpenCV
    does, but numbers rows from the bottom: image row r is window row H - 1 - r. So the
    principal point keeps its x and moves one pixel in y (measured on rendered
    checkerboard corners: the earlier +0.5, +0.5 put every pixel 0.5 px off in both axes).
    """
    if not 0 < near < far:
        raise CalibrationError(f"need 0 < near < far [m], got near={near}, far={far}")
    width, height = camera.image_size
    K = camera.camera_matrix
    fx, fy, cx, cy = K[0, 0], K[1, 1], K[0, 2], K[1, 2] + 1.0
    P = np.array(
        [
            [2 * fx / width, 0.0, 1.0 - 2 * cx / width, 0.0],
            [0.0, 2 * fy / height, 2 * cy / height - 1.0, 0.0],
            [0.0, 0.0, -(far + near) / (far - near), -2 * far * near / (far - near)],
            [0.0, 0.0, -1.0, 0.0],
        ]
    )
    return P.T.reshape(-1).tolist()


def render_bgr(
    client: int,
    camera: PinholeCamera,
    transform_camera_to_world: npt.ArrayLike,
    near: float = 0.02,
    far: float = 3.0,
    lighting: Lighting | None = None,
) -> npt.NDArray[np.uint8]:
    """Renders an (H, W, 3) uint8 BGR image with pybullet's CPU renderer.

    Args:
        client: pybullet client id.
        camera: intrinsics (distortion is not rendered; it must be zero).
        transform_camera_to_world: 4x4 pose of the OpenCV camera frame [m].
        near, far: clipping distances [m].
        lighting: light model; default `Lighting()`.
    """
    if camera.has_distortion:
        raise CalibrationError("the renderer draws ideal pinholes: dist_coeffs must be zero")
    light = lighting or Lighting()
    width, height = camera.image_size
    _, _, rgba, _, _ = pb.getCameraImage(
        width,
        height,
        viewMatrix=gl_view_matrix(transform_camera_to_world),
        projectionMatrix=gl_projection_matrix(camera, near, far),
        renderer=pb.ER_TINY_RENDERER,
        shadow=0,
        lightDirection=list(light.direction),
        lightAmbientCoeff=light.ambient,
        lightDiffuseCoeff=light.diffuse,
        lightSpecularCoeff=0.0,
        flags=pb.ER_NO_SEGMENTATION_MASK,
        physicsClientId=client,
    )
    image = np.asarray(rgba, dtype=np.uint8).reshape(height, width, 4)
    return np.ascontiguousarray(image[:, :, 2::-1])


@dataclass(frozen=True)
class StereoFrame:
    """One capture of the hand stereo pair.

    Attributes:
        left_bgr, right_bgr: (H, W, 3) uint8 images.
        time: simulated time of the capture [s].
        transform_right_camera_to_world: 4x4 pose of Σ_CR at capture [m].
    """

    left_bgr: npt.NDArray[np.uint8]
    right_bgr: npt.NDArray[np.uint8]
    time: float
    transform_right_camera_to_world: FloatArray


class _Clock(Protocol):
    """Anything with a simulated `time` [s] (the World)."""

    @property
    def time(self) -> float: ...


class StereoCamera:
    """The two hand cameras, rendered at the robot's `camera_*_optical` frames.

    `true_rig` (intrinsics from the config, extrinsics from the URDF) is what the
    renderer draws and `save_rig` writes. `rig` is what the recogniser and the loop are
    given: the truth, or the rig of `config.rig_file` (a calibration); with a rig file,
    a capture's camera pose is the measured flange pose times its camera-to-hand
    transform, as a real controller would compute it.
    """

    def __init__(self, client: int, robot: SimRobot, config: CameraSettings, clock: _Clock) -> None:
        self._client = client
        self._robot = robot
        self._config = config
        self._clock = clock
        width, height = config.image_size
        camera = PinholeCamera.from_fov((width, height), np.deg2rad(config.hfov_deg))
        left = robot.frame_pose(LEFT_FRAME)
        right = robot.frame_pose(RIGHT_FRAME)
        hand = robot.frame_pose(HAND_FRAME)
        self.true_rig = StereoRig(
            camera,
            camera,
            invert_transform(right) @ left,
            invert_transform(hand) @ right,
        )
        self.rig = (
            self.true_rig if config.rig_file is None else _calibrated_rig(config.rig_file, config.image_size)
        )
        self.lighting = Lighting(config.ambient, config.diffuse)

    def render(self) -> StereoFrame:
        """Renders both (true) cameras at the robot's current pose."""
        left_pose = self._robot.frame_pose(LEFT_FRAME)
        right_pose = self._robot.frame_pose(RIGHT_FRAME)
        near, far = self._config.near, self._config.far
        left = render_bgr(self._client, self.true_rig.left, left_pose, near, far, self.lighting)
        right = render_bgr(self._client, self.true_rig.right, right_pose, near, far, self.lighting)
        if self.rig is not self.true_rig and self.rig.transform_right_camera_to_hand is not None:
            right_pose = self._robot.frame_pose(HAND_FRAME) @ self.rig.transform_right_camera_to_hand
        return StereoFrame(left, right, self._clock.time, right_pose)

    def save_rig(self, path: str | Path) -> Path:
        """Writes the true rig YAML (docs/architecture.md format) and returns its path."""
        save_rig(self.true_rig, path)
        return Path(path)


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


__all__ = [
    "GL_FROM_CV",
    "Lighting",
    "StereoCamera",
    "StereoFrame",
    "gl_projection_matrix",
    "gl_view_matrix",
    "render_bgr",
]
