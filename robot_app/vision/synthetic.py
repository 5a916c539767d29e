"""A small ground-truth renderer for vision tests and benchmarks (numpy + OpenCV only).

Flat textured cloths (`SyntheticCloth`; the catalogue is `synthetic_catalogue.py`, the
photographic prints and deformations `synthetic_prints.py`) are drawn into a camera by
inverse mapping: each image pixel is back-projected (undistorted if the camera has
distortion) onto the cloth plane and samples the texture there, which is exact for a
plane at any pose. The table is a mildly textured green sheet; an optional sheet of
another colour occludes part of a cloth (paper Fig. 11 b). The pose handed to
`render_stereo_pair` is the ground truth ^CR T_M of the cloth's model frame Σ_M: origin
at the centroid of the cloth's outline (alpha mask), x and y along the texture's x and
y, z into the table.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray
from robot_app.geometry import (
    make_transform,
    rotation_about_z,
)
from robot_app.vision.camera import ModelCamera, PinholeCamera, StereoRig
from robot_app.vision.synthetic_camera import CameraRealism

Image = npt.NDArray[np.uint8]
Placement = tuple["SyntheticCloth", FloatArray]

TABLE_GREEN_BGR = (60, 150, 45)  # hue ≈ 86 of 255 (HSV_FULL), the paper's green sheet
OCCLUDER_BLUE_BGR = (205, 35, 30)  # the blue paper of Fig. 11 (b), hue ≈ 169 of 255
OCCLUDER_COLOURS: dict[str, tuple[int, int, int]] = {  # hued and unhued sheets over a cloth
    "blue": OCCLUDER_BLUE_BGR,
    "grey": (128, 128, 128),
    "white": (232, 232, 232),
    "brown": (45, 75, 125),
}


@dataclass(frozen=True)
class SyntheticCloth:
    """A flat cloth: its texture, outline and physical size.

    Attributes:
        name: catalogue name.
        texture_bgr: (H, W, 3) uint8 texture; texel (u, v) covers [u, u+1) x [v, v+1)
            times the texel size.
        alpha: (H, W) bool, True inside the cloth's outline.
        size: (width, height) of the texture [m].
        origin: the Σ_M origin in texture metres from the texture's corner [m], or None
            for the outline's centroid (a folded or wrinkled cloth keeps its flat frame).
    """

    name: str
    texture_bgr: Image
    alpha: npt.NDArray[np.bool_]
    size: tuple[float, float]
    origin: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        texture = np.asarray(self.texture_bgr)
        alpha = np.asarray(self.alpha, dtype=bool)
        if texture.ndim != 3 or texture.shape[2] != 3 or texture.dtype != np.uint8:
            raise ValueError(f"texture_bgr must be (H, W, 3) uint8, got {texture.shape} {texture.dtype}")
        if alpha.shape != texture.shape[:2] or not alpha.any():
            raise ValueError(f"alpha must be a non-empty (H, W) mask of shape {texture.shape[:2]}")
        if len(self.size) != 2 or min(self.size) <= 0:
            raise ValueError(f"size must be (width, height) > 0 [m], got {self.size}")
        texture.setflags(write=False)
        alpha.setflags(write=False)
        object.__setattr__(self, "texture_bgr", texture)
        object.__setattr__(self, "alpha", alpha)
        object.__setattr__(self, "size", (float(self.size[0]), float(self.size[1])))

    @property
    def texel_size(self) -> tuple[float, float]:
        """Size of one texel along x and y [m]."""
        height, width = self.alpha.shape
        return self.size[0] / width, self.size[1] / height

    @property
    def centroid(self) -> FloatArray:
        """The Σ_M origin in texture metres from the texture's corner [m], (2,): `origin`, or
        the centroid of the outline."""
        if self.origin is not None:
            return np.array(self.origin, dtype=float)
        v, u = np.nonzero(self.alpha)
        sx, sy = self.texel_size
        return np.array([(u.mean() + 0.5) * sx, (v.mean() + 0.5) * sy])

    @property
    def area(self) -> float:
        """Area inside the outline [m²]."""
        sx, sy = self.texel_size
        return float(self.alpha.sum() * sx * sy)

    def texel_to_model(self, uv: npt.ArrayLike) -> FloatArray:
        """Texel coordinates (..., 2) (centre of texel (0, 0) at (0, 0)) -> Σ_M points (..., 3) [m]."""
        uv = np.asarray(uv, dtype=float)
        sx, sy = self.texel_size
        c = self.centroid
        xy = (uv + 0.5) * [sx, sy] - c
        return np.concatenate([xy, np.zeros((*xy.shape[:-1], 1))], axis=-1)


def model_photo_transform(model_camera: ModelCamera) -> FloatArray:
    """Pose ^C T_M of a cloth in `render_model_photo`: centred on the optical axis, flat."""
    return make_transform(np.eye(3), [0.0, 0.0, model_camera.distance])


def render_model_photo(
    cloth: SyntheticCloth,
    model_camera: ModelCamera,
    rng: np.random.Generator | None = None,
    noise_sigma: float = 2.0,
) -> tuple[Image, Image]:
    """The Fig. 7 station: the cloth flat at `distance`, axes aligned, on a green sheet.

    Args:
        cloth: the cloth to photograph; its Σ_M sits at `model_photo_transform`.
        model_camera: intrinsics and distance to the plane [m].
        rng: noise source (default: a fixed seed, so renders are reproducible).
        noise_sigma: standard deviation of pixel noise [grey levels].

    Returns:
        (photo_bgr, background_bgr): the sheet with the cloth, and the empty sheet
        (same sheet, independent noise).
    """
    rng = np.random.default_rng(0) if rng is None else rng
    camera = model_camera.camera
    sheet = green_table(camera.image_size, rng)
    photo = _draw_cloth(sheet.astype(np.float32), camera, cloth, model_photo_transform(model_camera))
    return _add_noise(photo, rng, noise_sigma), _add_noise(sheet.astype(np.float32), rng, noise_sigma)


def render_stereo_pair(
    rig: StereoRig,
    placements: Sequence[Placement],
    *,
    occluder: Placement | None = None,
    rng: np.random.Generator | None = None,
    noise_sigma: float = 2.0,
    background_bgr: Image | None = None,
    camera: CameraRealism | None = None,
) -> tuple[Image, Image]:
    """Renders cloths lying at known poses into both hand cameras.

    Args:
        rig: the stereo rig.
        placements: (cloth, transform_model_to_right (4, 4)) pairs; later ones on top.
        occluder: an extra (sheet, pose) drawn last, e.g. from `occluder_covering`.
        rng: noise source (default: a fixed seed).
        noise_sigma: standard deviation of pixel noise [grey levels].
        background_bgr: the table as seen by both cameras; default a green sheet.
        camera: the cameras' imaging (exposure, white balance, shading, noise, blur, JPEG),
            instead of plain noise of `noise_sigma`.

    Returns:
        (left_bgr, right_bgr) uint8 images of the rig's size.
    """
    rng = np.random.default_rng(0) if rng is None else rng
    if background_bgr is None:
        table = green_table(rig.image_size, rng)
    else:
        table = np.asarray(background_bgr)
        width, height = rig.image_size
        if table.shape != (height, width, 3) or table.dtype != np.uint8:
            raise ValueError(f"background_bgr must be ({height}, {width}, 3) uint8, got {table.shape}")
    layers = [*placements, occluder] if occluder is not None else list(placements)
    T_right_to_left = rig.transform_right_to_left
    shade = camera.shade_field(rig.image_size, rng) if camera is not None else None
    images = []
    for lens, to_camera in ((rig.left, T_right_to_left), (rig.right, np.eye(4))):
        image = table.astype(np.float32)
        for cloth, transform in layers:
            pose = np.asarray(transform, dtype=float)
            if pose.shape != (4, 4):
                raise ValueError(f"a placement's transform must be 4x4, got {pose.shape}")
            image = _draw_cloth(image, lens, cloth, to_camera @ pose)
        if camera is not None and shade is not None:
            images.append(camera.image(image, rng, shade))
        else:
            images.append(_add_noise(image, rng, noise_sigma))
    return images[0], images[1]


def occluder_covering(
    cloth: SyntheticCloth,
    transform_model_to_right: npt.ArrayLike,
    fraction: float = 0.45,
    direction: float = 0.0,
    lift: float = 0.003,
    colour_bgr: tuple[int, int, int] = OCCLUDER_BLUE_BGR,
) -> Placement:
    """A sheet (blue by default) lying just above `cloth` that hides `fraction` of its area.

    The sheet covers every point of the cloth beyond a line perpendicular to
    `direction`, placed so that `fraction` of the outline's area is under it.

    Args:
        cloth: the cloth to hide partly.
        transform_model_to_right: the cloth's pose ^CR T_M.
        fraction: share of the cloth's area to cover, in (0, 1).
        direction: in Σ_M, the side the sheet comes from [rad] (0: from +x).
        lift: height of the sheet above the cloth, towards the camera [m].
        colour_bgr: the sheet's colour (`OCCLUDER_COLOURS` has blue, grey, white, brown).

    Returns:
        (sheet, transform_sheet_to_right) to pass as `occluder=`.
    """
    if not 0.0 < fraction < 1.0:
        raise ValueError(f"occluder fraction must be in (0, 1), got {fraction}")
    v, u = np.nonzero(cloth.alpha)
    points = cloth.texel_to_model(np.stack([u, v], axis=-1))[:, :2]
    d = np.array([np.cos(direction), np.sin(direction)])
    along, across = points @ d, points @ [-d[1], d[0]]
    start = float(np.quantile(along, 1.0 - fraction))
    margin = 0.02
    length = float(along.max()) - start + margin
    width = 2.0 * float(np.abs(across).max()) + 2 * margin
    texel = 0.001
    shape = (max(1, round(width / texel)), max(1, round(length / texel)))
    texture = np.empty((*shape, 3), np.uint8)
    texture[:] = colour_bgr
    sheet = SyntheticCloth("sheet", texture, np.ones(shape, bool), (shape[1] * texel, shape[0] * texel))
    centre = d * (start + sheet.size[0] / 2.0)
    in_model = make_transform(rotation_about_z(direction), [centre[0], centre[1], -lift])
    return sheet, np.asarray(transform_model_to_right, dtype=float) @ in_model


def green_table(image_size: tuple[int, int], rng: np.random.Generator) -> Image:
    """A green sheet filling an image: smooth brightness and hue variation, no noise."""
    width, height = image_size
    shade = cv2.resize(
        rng.uniform(0.88, 1.08, (4, 5)).astype(np.float32), (width, height), interpolation=cv2.INTER_CUBIC
    )
    tint = cv2.resize(
        rng.uniform(-6, 6, (3, 4)).astype(np.float32), (width, height), interpolation=cv2.INTER_CUBIC
    )
    b, g, r = TABLE_GREEN_BGR
    image = np.stack([(b + tint) * shade, g * shade, (r - tint) * shade], axis=-1)
    return np.clip(image, 0, 255).astype(np.uint8)


def _draw_cloth(
    image: npt.NDArray[np.float32], camera: PinholeCamera, cloth: SyntheticCloth, transform: FloatArray
) -> npt.NDArray[np.float32]:
    """Composites `cloth` at pose `transform` (Σ_M -> this camera) onto `image` (float)."""
    G = np.column_stack([transform[:3, 0], transform[:3, 1], transform[:3, 3]])  # plane z=0 -> rays
    if abs(np.linalg.det(G)) < 1e-12:
        return image  # the plane is seen edge-on: nothing to draw
    rays = _normalised_rays(camera)
    q = rays @ np.linalg.inv(G).T
    with np.errstate(divide="ignore", invalid="ignore"):
        in_front = q[..., 2] > 1e-9
        x = np.where(in_front, q[..., 0] / q[..., 2], np.nan)
        y = np.where(in_front, q[..., 1] / q[..., 2], np.nan)
    sx, sy = cloth.texel_size
    c = cloth.centroid
    map_u = np.nan_to_num((x + c[0]) / sx - 0.5, nan=-1e6).astype(np.float32)
    map_v = np.nan_to_num((y + c[1]) / sy - 0.5, nan=-1e6).astype(np.float32)
    texture = cloth.texture_bgr.astype(np.float32)
    alpha = cloth.alpha.astype(np.float32)
    # Texels per image pixel near the centre: blur the texture to avoid aliasing.
    depth = float(np.linalg.norm(transform[:3, 3]))
    footprint = depth / camera.camera_matrix[0, 0] / min(sx, sy)
    if footprint > 1.5:
        sigma = 0.5 * footprint
        texture = np.asarray(cv2.GaussianBlur(texture, (0, 0), sigma), dtype=np.float32)
        alpha = np.asarray(cv2.GaussianBlur(alpha, (0, 0), sigma), dtype=np.float32)
    border = cv2.BORDER_CONSTANT
    colour = cv2.remap(texture, map_u, map_v, cv2.INTER_LINEAR, borderMode=border, borderValue=0)
    cover = cv2.remap(alpha, map_u, map_v, cv2.INTER_LINEAR, borderMode=border, borderValue=0)[..., None]
    return image * (1.0 - cover) + colour * cover


def _normalised_rays(camera: PinholeCamera) -> FloatArray:
    """(H, W, 3) rays (x_n, y_n, 1) through every pixel centre, undistorted if needed."""
    width, height = camera.image_size
    u, v = np.meshgrid(np.arange(width, dtype=float), np.arange(height, dtype=float))
    K = camera.camera_matrix
    if camera.has_distortion:
        pixels = np.stack([u, v], axis=-1).reshape(-1, 1, 2)
        criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 40, 1e-10)
        normal = cv2.undistortPoints(pixels, K, camera.dist_coeffs, criteria=criteria)
        normal = normal.reshape(height, width, 2)
        x, y = normal[..., 0], normal[..., 1]
    else:
        x, y = (u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1]
    return np.stack([x, y, np.ones_like(x)], axis=-1)


def _add_noise(image: npt.NDArray[np.float32], rng: np.random.Generator, sigma: float) -> Image:
    if sigma < 0:
        raise ValueError(f"noise_sigma must be >= 0 [grey levels], got {sigma}")
    if sigma > 0:
        image = image + rng.normal(0.0, sigma, image.shape).astype(np.float32)
    return np.clip(np.rint(image), 0, 255).astype(np.uint8)


__all__ = [
    "OCCLUDER_BLUE_BGR",
    "OCCLUDER_COLOURS",
    "TABLE_GREEN_BGR",
    "SyntheticCloth",
    "green_table",
    "model_photo_transform",
    "occluder_covering",
    "render_model_photo",
    "render_stereo_pair",
]
