"""Pinhole cameras and the stereo rig (paper eqs. 1-8), and their YAML files.

Conventions (docs/architecture.md): OpenCV camera frames (x right, y down, z along the optical
axis); a stereo rig follows `cv2.stereoCalibrate`: X_right = R @ X_left + T. A pose
recognised by the rig is ^CR T_M, the model in the right camera.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import yaml

from robot_app.arrays import FloatArray
from robot_app.console import warn_input
from robot_app.errors import CalibrationError
from robot_app.geometry import (
    invert_transform,
    is_rotation,
    make_transform,
)
from robot_app.input_files import require_input_file

DIST_COEFF_COUNTS = (0, 4, 5)
"""Distortion vector lengths OpenCV's calibration writes that this camera model reads."""
MIN_BASELINE = 1e-3
"""A stereo baseline below this [m] gives no depth from the pair: warned about."""


def _warn_short_distortion(entry: dict[str, Any], file: str | Path, key: str) -> None:
    """Warns about a distortion vector of an unusual length (the rest are taken as 0)."""
    coefficients = entry.get("dist_coeffs")
    if coefficients is None:
        return
    count = np.asarray(coefficients, dtype=float).size
    if count not in DIST_COEFF_COUNTS:
        warn_input(
            f"{file}: {key} has {count} coefficients; OpenCV writes 4 or 5 (k1, k2, p1, p2[, k3]), "
            f"so the missing ones are taken as 0",
            path=file,
            key=key,
        )


def _readonly(array: npt.ArrayLike, shape: tuple[int, ...], name: str) -> FloatArray:
    a = np.array(array, dtype=float)
    if a.shape != shape:
        raise CalibrationError(
            f"{name} must be an array of shape {shape}, got shape {a.shape}",
            key=name,
            value=a.tolist(),
            expected=f"an array of shape {shape}",
        )
    if not np.all(np.isfinite(a)):
        raise CalibrationError(
            f"{name} must hold finite numbers, got {a.tolist()}",
            key=name,
            value=a.tolist(),
            expected="finite numbers",
        )
    a.setflags(write=False)
    return a


@dataclass(frozen=True)
class PinholeCamera:
    """A pinhole camera with OpenCV intrinsics and optional distortion.

    Attributes:
        camera_matrix: [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] [px].
        image_size: (width, height) [px].
        dist_coeffs: OpenCV (k1, k2, p1, p2, k3); zeros for an ideal lens.
    """

    camera_matrix: FloatArray
    image_size: tuple[int, int]
    dist_coeffs: FloatArray = field(default_factory=lambda: np.zeros(5))

    def __post_init__(self) -> None:
        K = _readonly(self.camera_matrix, (3, 3), "camera_matrix")
        if K[0, 0] <= 0 or K[1, 1] <= 0 or K[0, 1] != 0 or K[1, 0] != 0 or K[2, 0] != 0:
            raise CalibrationError(
                f"camera_matrix must be [[fx,0,cx],[0,fy,cy],[0,0,1]], got {K.tolist()}",
                key="camera_matrix",
                value=K.tolist(),
                expected="[[fx, 0, cx], [0, fy, cy], [0, 0, 1]] with fx, fy > 0",
            )
        if not np.allclose(K[2], [0.0, 0.0, 1.0]):
            raise CalibrationError(
                f"camera_matrix last row must be [0, 0, 1], got {K[2].tolist()}",
                key="camera_matrix",
                value=K.tolist(),
                expected="[[fx, 0, cx], [0, fy, cy], [0, 0, 1]] with fx, fy > 0",
            )
        width, height = (int(v) for v in self.image_size)
        if width <= 0 or height <= 0:
            raise CalibrationError(
                f"image_size must be two positive integers, got {self.image_size}",
                key="image_size",
                value=self.image_size,
                expected="[width, height] in whole pixels > 0",
            )
        dist = np.zeros(5)
        given = np.asarray(self.dist_coeffs, dtype=float).reshape(-1)
        if given.size > 5 or not np.all(np.isfinite(given)):
            raise CalibrationError(
                f"dist_coeffs must be up to 5 finite numbers, got {given.tolist()}",
                key="dist_coeffs",
                value=given.tolist(),
                expected="up to 5 finite numbers (k1, k2, p1, p2, k3)",
            )
        dist[: given.size] = given
        dist.setflags(write=False)
        object.__setattr__(self, "camera_matrix", K)
        object.__setattr__(self, "image_size", (width, height))
        object.__setattr__(self, "dist_coeffs", dist)

    @classmethod
    def from_fov(cls, image_size: tuple[int, int], horizontal_fov: float) -> PinholeCamera:
        """An ideal camera with square pixels, centred principal point.

        Args:
            image_size: (width, height) [px].
            horizontal_fov: full horizontal field of view [rad].
        """
        width, height = image_size
        if not 0 < horizontal_fov < np.pi:
            raise CalibrationError(
                f"horizontal_fov must be in (0, pi) rad, got {horizontal_fov}",
                key="horizontal_fov",
                value=horizontal_fov,
                expected="an angle in (0, pi) rad",
            )
        f = (width / 2.0) / np.tan(horizontal_fov / 2.0)
        K = np.array([[f, 0.0, width / 2.0], [0.0, f, height / 2.0], [0.0, 0.0, 1.0]])
        return cls(K, (width, height))

    @property
    def width(self) -> int:
        return self.image_size[0]

    @property
    def height(self) -> int:
        return self.image_size[1]

    @property
    def has_distortion(self) -> bool:
        return bool(np.any(self.dist_coeffs != 0.0))

    def project(self, points_camera: npt.ArrayLike) -> FloatArray:
        """Projects points in this camera's frame to pixels (eqs. 4-6).

        Args:
            points_camera: (..., 3) points [m] in the camera frame.

        Returns:
            (..., 2) pixel coordinates (u, v) [px]; NaN for points with z <= 0.
        """
        P = np.asarray(points_camera, dtype=float)
        if P.shape[-1] != 3:
            raise ValueError(f"points must have shape (..., 3), got {P.shape}")
        z = P[..., 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            x = np.where(z > 0, P[..., 0] / z, np.nan)
            y = np.where(z > 0, P[..., 1] / z, np.nan)
        if self.has_distortion:
            k1, k2, p1, p2, k3 = self.dist_coeffs
            r2 = x * x + y * y
            radial = 1 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2
            x, y = (
                x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x),
                y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y,
            )
        K = self.camera_matrix
        return np.stack([K[0, 0] * x + K[0, 2], K[1, 1] * y + K[1, 2]], axis=-1)

    def to_dict(self) -> dict[str, Any]:
        return {
            "camera_matrix": self.camera_matrix.tolist(),
            "dist_coeffs": self.dist_coeffs.tolist(),
        }


@dataclass(frozen=True)
class StereoRig:
    """Two hand cameras; `transform_left_to_right` maps Σ_CL points to Σ_CR (X_r = R X_l + T).

    Attributes:
        left, right: the two cameras (same image size).
        transform_left_to_right: 4x4 [R T; 0 1] of cv2.stereoCalibrate.
        transform_right_camera_to_hand: 4x4 pose of Σ_CR in Σ_H, or None without a robot.
    """

    left: PinholeCamera
    right: PinholeCamera
    transform_left_to_right: FloatArray
    transform_right_camera_to_hand: FloatArray | None = None

    def __post_init__(self) -> None:
        if self.left.image_size != self.right.image_size:
            raise CalibrationError(
                f"left and right image sizes differ: {self.left.image_size} vs {self.right.image_size}",
                key="image_size",
                value=(self.left.image_size, self.right.image_size),
                expected="one image size for both cameras",
            )
        for name in ("transform_left_to_right", "transform_right_camera_to_hand"):
            value = getattr(self, name)
            if value is None:
                continue
            T = _readonly(value, (4, 4), name)
            if not is_rotation(T[:3, :3], tol=1e-5):
                raise CalibrationError(
                    f"{name}: R is not a rotation (R^T R != I or det != 1)",
                    key=name,
                    value=T.tolist(),
                    expected="a 4x4 transform [R T; 0 1] with R a rotation",
                )
            if not np.allclose(T[3], [0, 0, 0, 1]):
                raise CalibrationError(
                    f"{name}: last row must be [0, 0, 0, 1]",
                    key=name,
                    value=T.tolist(),
                    expected="a 4x4 transform [R T; 0 1] with R a rotation",
                )
            object.__setattr__(self, name, T)

    @property
    def image_size(self) -> tuple[int, int]:
        return self.right.image_size

    @property
    def transform_right_to_left(self) -> FloatArray:
        """4x4 mapping Σ_CR points to Σ_CL (eq. 7 from eq. 1)."""
        return invert_transform(self.transform_left_to_right)

    @property
    def baseline(self) -> float:
        """Distance between the optical centres [m]."""
        return float(np.linalg.norm(self.transform_left_to_right[:3, 3]))

    def project_model(
        self, transforms_model_to_right: npt.ArrayLike, points_model: npt.ArrayLike
    ) -> tuple[FloatArray, FloatArray]:
        """Projects model points for many poses at once (eq. 8).

        Args:
            transforms_model_to_right: (P, 4, 4) or (4, 4) poses ^CR T_M.
            points_model: (N, 3) points [m] in Σ_M.

        Returns:
            (pixels_left, pixels_right), each (P, N, 2) [px] (NaN behind a camera).
        """
        T = np.asarray(transforms_model_to_right, dtype=float)
        single = T.ndim == 2
        T = T.reshape(-1, 4, 4)
        M = np.asarray(points_model, dtype=float).reshape(-1, 3)
        right = np.einsum("pij,nj->pni", T[:, :3, :3], M) + T[:, None, :3, 3]
        L = self.transform_right_to_left
        left = right @ L[:3, :3].T + L[:3, 3]
        pixels_left, pixels_right = self.left.project(left), self.right.project(right)
        if single:
            return pixels_left[0], pixels_right[0]
        return pixels_left, pixels_right

    def to_dict(self) -> dict[str, Any]:
        data: dict[str, Any] = {
            "image_size": list(self.image_size),
            "left": self.left.to_dict(),
            "right": self.right.to_dict(),
            "R": self.transform_left_to_right[:3, :3].tolist(),
            "T": self.transform_left_to_right[:3, 3].tolist(),
        }
        if self.transform_right_camera_to_hand is not None:
            data["transform_right_camera_to_hand"] = self.transform_right_camera_to_hand.tolist()
        return data


@dataclass(frozen=True)
class ModelCamera:
    """The model-generation camera of Fig. 7: intrinsics and the distance to the plane.

    Attributes:
        camera: intrinsics and image size.
        distance: lens to the model-creating plane [m] (paper: 0.40).
    """

    camera: PinholeCamera
    distance: float

    def __post_init__(self) -> None:
        if not np.isfinite(self.distance) or self.distance <= 0:
            raise CalibrationError(
                f"distance must be a positive number of metres, got {self.distance}",
                key="distance",
                value=self.distance,
                expected="a distance > 0 [m]",
            )

    def to_dict(self) -> dict[str, Any]:
        return {
            "image_size": list(self.camera.image_size),
            "camera_matrix": self.camera.camera_matrix.tolist(),
            "dist_coeffs": self.camera.dist_coeffs.tolist(),
            "distance": float(self.distance),
        }


def _with_path(err: CalibrationError, path: str | Path) -> CalibrationError:
    """`err` with the file named (the camera classes do not know which file they came from)."""
    if err.path is not None:
        return err
    given = {"value": err.value} if err.has_value else {}
    return CalibrationError(f"{path}: {err}", path=path, key=err.key, expected=err.expected, **given)


def _read_mapping(path: str | Path, what: str) -> dict[str, Any]:
    file = require_input_file(path, what)
    try:
        data = yaml.safe_load(file.read_text())
    except (yaml.YAMLError, UnicodeDecodeError) as err:
        raise CalibrationError(
            f"{file} is not a YAML {what} file: {err}", path=file, expected=f"a YAML {what} file"
        ) from err
    if not isinstance(data, dict):
        raise CalibrationError(
            f"{file} is not a YAML {what} file (no mapping at top level)",
            path=file,
            value=data,
            expected=f"a YAML {what} file",
        )
    return data


def _require(data: dict[str, Any], key: str, file: str | Path) -> Any:
    if key not in data:
        raise CalibrationError(f"{file}: missing key '{key}'", path=file, key=key, expected=f"a key '{key}'")
    return data[key]


def _image_size(data: dict[str, Any], file: str | Path) -> tuple[int, int]:
    size = _require(data, "image_size", file)
    whole = isinstance(size, list | tuple) and len(size) == 2
    numbers = whole and all(isinstance(v, int | float) and not isinstance(v, bool) for v in size)
    if not numbers or not all(np.isfinite(v) and v == int(v) and v > 0 for v in size):
        raise CalibrationError(
            f"{file}: image_size must be [width, height] in whole pixels > 0, got {size!r}",
            path=file,
            key="image_size",
            value=size,
            expected="[width, height]",
        )
    return int(size[0]), int(size[1])


def load_rig(path: str | Path) -> StereoRig:
    """Reads a stereo rig YAML file (docs/architecture.md format)."""
    data = _read_mapping(path, "stereo rig")
    size = _image_size(data, path)
    try:
        cameras = {}
        for side in ("left", "right"):
            entry = _require(data, side, path)
            try:
                cameras[side] = PinholeCamera(
                    _require(entry, "camera_matrix", path), size, entry.get("dist_coeffs", np.zeros(5))
                )
            except CalibrationError as err:  # the key as the file spells it: left.camera_matrix
                err.key = f"{side}.{err.key}" if err.key else side
                raise
        R = np.asarray(_require(data, "R", path), dtype=float)
        T = np.asarray(_require(data, "T", path), dtype=float).reshape(-1)
        if R.shape != (3, 3) or T.shape != (3,):
            bad = "R" if R.shape != (3, 3) else "T"
            raise CalibrationError(
                f"{path}: R must be 3x3 and T a 3-vector",
                path=path,
                key=bad,
                value=(R if bad == "R" else T).tolist(),
                expected="R a 3x3 rotation matrix, T a 3-vector [m]",
            )
        if not is_rotation(R, tol=1e-5):
            raise CalibrationError(
                f"{path}: R is not a rotation matrix (R^T R != I or det != 1)",
                path=path,
                key="R",
                value=R.tolist(),
                expected="a rotation matrix (R^T R = I, det = +1)",
            )
        hand = data.get("transform_right_camera_to_hand")
        rig = StereoRig(cameras["left"], cameras["right"], make_transform(R, T), hand)
    except (TypeError, ValueError, AttributeError) as err:
        raise CalibrationError(f"{path}: malformed stereo rig: {err}", path=path) from err
    except CalibrationError as err:
        raise _with_path(err, path) from err
    for side in ("left", "right"):
        _warn_short_distortion(data[side], path, f"{side}.dist_coeffs")
    if rig.baseline < MIN_BASELINE:
        warn_input(
            f"{path}: the baseline |T| is {rig.baseline * 1e3:.3g} mm: the two cameras sit at one "
            "point, so the pair gives no depth; T is in metres (OpenCV stereoCalibrate)",
            path=path,
            key="T",
        )
    return rig


def save_rig(rig: StereoRig, path: str | Path) -> None:
    """Writes `rig` as YAML; `load_rig` reads it back equal."""
    Path(path).write_text(yaml.safe_dump(rig.to_dict(), sort_keys=False))


def load_model_camera(path: str | Path) -> ModelCamera:
    """Reads a model-generation camera YAML file (docs/architecture.md format)."""
    data = _read_mapping(path, "camera")
    size = _image_size(data, path)
    try:
        camera = PinholeCamera(
            _require(data, "camera_matrix", path), size, data.get("dist_coeffs", np.zeros(5))
        )
        model_camera = ModelCamera(camera, float(_require(data, "distance", path)))
    except (TypeError, ValueError) as err:
        raise CalibrationError(f"{path}: malformed camera file: {err}", path=path) from err
    except CalibrationError as err:
        raise _with_path(err, path) from err
    _warn_short_distortion(data, path, "dist_coeffs")
    return model_camera


def save_model_camera(model_camera: ModelCamera, path: str | Path) -> None:
    """Writes a model-generation camera as YAML."""
    Path(path).write_text(yaml.safe_dump(model_camera.to_dict(), sort_keys=False))


__all__ = [
    "ModelCamera",
    "PinholeCamera",
    "StereoRig",
    "load_model_camera",
    "load_rig",
    "save_model_camera",
    "save_rig",
]
