"""The cell's light: a key lamp drawn per scene, and the shadows it casts.

pybullet's TinyRenderer shades a surface with ambient + key · max(0, n·l) + specular for
a directional light `l`. Its own shadows (`shadow=1`) take only 20% of the key's share
away and use a shadow map aimed at the world origin with the camera's field of view, so
a hand 0.5 m away casts almost nothing. The shadows here are a shadow map of our own:
the scene's depth rendered from the lamp once per capture (`ShadowMap`), against which
every camera pixel, put back into the world by its depth, is tested. A pixel in shadow
loses the key's share of its brightness, which is known from the surface normal.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import cv2
import numpy as np
import numpy.typing as npt
import pybullet as pb

from robot_app.arrays import FloatArray
from robot_app.geometry import invert_transform
from robot_app.sim.cameras import (
    Lighting,
    linear_depth,
    render_bgr_depth,
    tiny_render,
)
from robot_app.sim.realism import LightingSettings, StationLightingSettings
from robot_app.vision.camera import PinholeCamera

LAMP_DISTANCE = 2.0  # lamp to the middle of the lit region [m]: a ceiling lamp, not the sun
DEPTH_STEP = 0.01  # [m] a jump of depth between a pixel's neighbours: an edge, no surface normal
SHADOW_BIAS = 0.006  # depth a surface may lie behind the shadow map before it is shadowed [m]


def direction_from_angles(zenith_deg: float, azimuth_deg: float) -> tuple[float, float, float]:
    """Unit vector from the scene towards a lamp `zenith_deg` off vertical, turned by azimuth."""
    zenith, azimuth = np.radians(zenith_deg), np.radians(azimuth_deg)
    return (
        float(np.sin(zenith) * np.cos(azimuth)),
        float(np.sin(zenith) * np.sin(azimuth)),
        float(np.cos(zenith)),
    )


def draw_lighting(settings: LightingSettings, rng: np.random.Generator | None = None) -> Lighting:
    """The cell's light for one scene: the key's direction drawn uniformly in its ranges.

    Without `rng` the middle of each range is taken.
    """
    zenith_range, azimuth_range = settings.key_zenith_deg, settings.key_azimuth_deg
    if rng is None:
        zenith, azimuth = float(np.mean(zenith_range)), float(np.mean(azimuth_range))
    else:
        zenith = float(rng.uniform(*zenith_range))
        azimuth = float(rng.uniform(*azimuth_range))
    return Lighting(
        settings.ambient,
        settings.key,
        direction_from_angles(zenith, azimuth),
        settings.specular,
        settings.key_rgb,
    )


def station_lighting(settings: StationLightingSettings) -> Lighting:
    """The model station's fixed lamp."""
    return Lighting(
        settings.ambient,
        settings.key,
        direction_from_angles(settings.zenith_deg, settings.azimuth_deg),
        0.0,
        settings.key_rgb,
    )


@dataclass(frozen=True)
class ShadowMap:
    """Depth of the scene seen from the key lamp, covering a disc of the table.

    Attributes:
        camera: the lamp's pinhole (square image).
        transform_lamp_to_world: 4x4 pose of the lamp's OpenCV camera frame [m].
        depth: (S, S) distance along the lamp's axis to the first surface [m].
        texel: size of one shadow-map texel at the lit region's centre [m].
    """

    camera: PinholeCamera
    transform_lamp_to_world: FloatArray
    depth: FloatArray
    texel: float

    @classmethod
    def render(
        cls, client: int, light: Lighting, centre: npt.ArrayLike, radius: float, size: int
    ) -> ShadowMap:
        """Renders the depth from a lamp `LAMP_DISTANCE` from `centre` along the light direction.

        Args:
            client: pybullet client id.
            light: its direction is the lamp's.
            centre: (3,) middle of the region that must be covered [m].
            radius: radius of that region [m].
            size: side of the square shadow map [px].
        """
        direction = np.asarray(light.direction, dtype=float)
        direction /= np.linalg.norm(direction)
        target = np.asarray(centre, dtype=float)
        eye = target + LAMP_DISTANCE * direction
        pose = _look_at(eye, target)
        fov = 2.0 * np.arctan(radius / LAMP_DISTANCE)
        camera = PinholeCamera.from_fov((size, size), fov)
        near, far = 0.2, LAMP_DISTANCE + 1.0
        zbuffer = tiny_render(client, camera, pose, near, far, shadow=0, flags=pb.ER_NO_SEGMENTATION_MASK)[3]
        depth = linear_depth(np.asarray(zbuffer, dtype=np.float64).reshape(size, size), near, far)
        depth.setflags(write=False)
        return cls(camera, pose, depth, 2.0 * radius / size)

    def visibility(self, points_lamp: npt.NDArray[np.floating], penumbra: float) -> npt.NDArray[np.float32]:
        """Share of the lamp each point sees, 0 (shadow) to 1 (lit), soft over `penumbra` [m].

        Args:
            points_lamp: (..., 3) points in the lamp's camera frame [m].
            penumbra: width of soft shadow edges [m].

        Points outside the map count as lit.
        """
        z = points_lamp[..., 2]
        K = self.camera.camera_matrix
        with np.errstate(divide="ignore", invalid="ignore"):
            u = K[0, 0] * points_lamp[..., 0] / z + K[0, 2]
            v = K[1, 1] * points_lamp[..., 1] / z + K[1, 2]
        size = self.depth.shape[0]
        reach = max(0.0, penumbra / self.texel / 2.0)
        offsets = (-reach, 0.0, reach) if reach > 0.25 else (0.0,)
        padded = np.pad(self.depth, 1, constant_values=np.inf)  # outside the map: lit
        threshold = z - (SHADOW_BIAS + 2.0 * self.texel)
        lit = np.zeros(z.shape, dtype=np.float32)
        for du in offsets:
            iu = np.clip(np.rint(u + du), -1, size).astype(np.intp) + 1
            for dv in offsets:
                iv = np.clip(np.rint(v + dv), -1, size).astype(np.intp) + 1
                lit += padded[iv, iu] >= threshold
        lit[~(z > 0)] = len(offsets) ** 2
        return lit / np.float32(len(offsets) ** 2)


def shade_shadows(
    image_bgr: npt.NDArray[np.uint8],
    depth: FloatArray,
    camera: PinholeCamera,
    transform_camera_to_world: FloatArray,
    light: Lighting,
    shadow_map: ShadowMap,
    penumbra: float,
) -> npt.NDArray[np.uint8]:
    """Takes the key lamp's share away from the pixels it does not reach.

    A rendered pixel is albedo · (ambient + key · n·l · colour); in shadow it keeps
    albedo · ambient, so it is scaled by (ambient + seen · key n·l c) / (ambient + key n·l c).
    Shadows are soft, so visibility and normals are computed on every second pixel.

    Args:
        image_bgr: (H, W, 3) rendered image.
        depth: (H, W) its depth along the optical axis [m].
        camera: the camera's intrinsics.
        transform_camera_to_world: 4x4 OpenCV camera pose [m].
        light: the light the image was rendered with.
        shadow_map: depth from its lamp.
        penumbra: width of soft shadow edges [m].
    """
    height, width = image_bgr.shape[:2]
    points = camera_points(depth[::2, ::2], camera, step=2)
    camera_to_lamp = invert_transform(shadow_map.transform_lamp_to_world) @ transform_camera_to_world
    in_lamp = points @ camera_to_lamp[:3, :3].T.astype(np.float32) + camera_to_lamp[:3, 3].astype(np.float32)
    seen = shadow_map.visibility(in_lamp, penumbra)
    if np.all(seen >= 1.0):
        return image_bgr
    normals = surface_normals(points)
    direction = np.asarray(light.direction, dtype=float)
    direction = transform_camera_to_world[:3, :3].T @ (direction / np.linalg.norm(direction))
    facing = np.clip(normals @ direction.astype(np.float32), 0.0, 1.0)
    colour_bgr = np.asarray(light.colour[::-1], dtype=np.float32)
    direct = np.float32(light.diffuse) * facing[..., None] * colour_bgr
    scale = (light.ambient + seen[..., None] * direct) / np.maximum(light.ambient + direct, 1e-6)
    scale = cv2.resize(scale, (width, height), interpolation=cv2.INTER_LINEAR)
    shaded = image_bgr.astype(np.float32) * scale
    return np.clip(np.rint(shaded), 0, 255).astype(np.uint8)


def render_two_sided(
    client: int,
    camera: PinholeCamera,
    transform_camera_to_world: FloatArray,
    near: float,
    far: float,
    light: Lighting,
) -> tuple[npt.NDArray[np.uint8], FloatArray]:
    """`render_bgr_depth`, with every surface lit on the side the camera sees.

    TinyRenderer lights a cloth (a pybullet soft body) by its physics mesh's normals, which
    point out of the cloth's face side: a cloth lying face down, a flap folded over, a heap
    laid back upside down were lit by the ambient share alone (a white napkin's back drawn
    at grey 55 instead of 150 under the realistic lamp), darker than any real cloth there.
    So the scene is drawn twice, with the lamp and with it mirrored through the scene
    (-l): at each pixel one of the two has the key's share and the other not, and the
    surface's normal from the depth (turned towards the camera) says which is right: the
    lit one where it faces the lamp, the unlit one where it faces away. Pixels at depth
    steps (no normal there) and beyond `far` keep the first drawing.
    """
    image, depth = render_bgr_depth(client, camera, transform_camera_to_world, near, far, light)
    x, y, z = light.direction
    mirrored = replace(light, direction=(-x, -y, -z))
    other, _ = render_bgr_depth(client, camera, transform_camera_to_world, near, far, mirrored)
    points = camera_points(depth, camera)
    direction = np.asarray(light.direction, dtype=float)
    direction = np.asarray(transform_camera_to_world)[:3, :3].T @ (direction / np.linalg.norm(direction))
    facing = surface_normals(points) @ direction.astype(np.float32) > 0.0
    step = np.zeros(depth.shape, dtype=bool)
    step[:, 1:-1] = np.abs(depth[:, 2:] - depth[:, :-2]) > DEPTH_STEP
    step[1:-1] |= np.abs(depth[2:] - depth[:-2]) > DEPTH_STEP
    keep = step | (depth >= far * 0.999)
    chosen = np.where(facing[..., None], np.maximum(image, other), np.minimum(image, other))
    return np.where(keep[..., None], image, chosen).astype(np.uint8), depth


def render_lit(
    client: int,
    camera: PinholeCamera,
    transform_camera_to_world: FloatArray,
    light: Lighting,
    shadow_map: ShadowMap | None = None,
    penumbra: float = 0.0,
    near: float = 0.02,
    far: float = 3.0,
    two_sided: bool = False,
) -> npt.NDArray[np.uint8]:
    """Renders a camera with the light (`two_sided`: `render_two_sided`) and, given a
    shadow map, the key lamp's shadows."""
    render = render_two_sided if two_sided else render_bgr_depth
    image, depth = render(client, camera, transform_camera_to_world, near, far, light)
    if shadow_map is None:
        return image
    return shade_shadows(image, depth, camera, transform_camera_to_world, light, shadow_map, penumbra)


def camera_points(depth: FloatArray, camera: PinholeCamera, step: int = 1) -> npt.NDArray[np.float32]:
    """(h, w, 3) float32 points in the camera frame [m] behind pixels (step·j, step·i).

    Args:
        depth: (h, w) depth along the optical axis of every `step`-th pixel [m].
        camera: the camera's intrinsics.
        step: pixel stride the depth was taken with.
    """
    height, width = depth.shape
    K = camera.camera_matrix
    u = ((np.arange(width) * step - K[0, 2]) / K[0, 0]).astype(np.float32)
    v = ((np.arange(height) * step - K[1, 2]) / K[1, 1]).astype(np.float32)
    z = depth.astype(np.float32)
    return np.stack([u[None, :] * z, v[:, None] * z, z], axis=-1)


def surface_normals(points: npt.NDArray[np.float32]) -> npt.NDArray[np.float32]:
    """(h, w, 3) unit normals of a grid of camera-frame points, turned towards the camera."""
    along_u = np.zeros_like(points)
    along_v = np.zeros_like(points)
    along_u[:, 1:-1] = points[:, 2:] - points[:, :-2]
    along_v[1:-1] = points[2:] - points[:-2]
    normals = np.cross(along_v, along_u)
    length = np.linalg.norm(normals, axis=2, keepdims=True)
    normals = np.where(length > 1e-12, normals / np.maximum(length, 1e-12), np.float32(0.0))
    normals[length[..., 0] <= 1e-12] = (0.0, 0.0, -1.0)
    flip = np.sum(normals * points, axis=2, keepdims=True) > 0
    return np.where(flip, -normals, normals).astype(np.float32)


def _look_at(eye: FloatArray, target: FloatArray) -> FloatArray:
    """4x4 OpenCV camera pose at `eye` looking at `target` (any roll)."""
    z = target - eye
    z /= np.linalg.norm(z)
    helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(z, helper)
    x /= np.linalg.norm(x)
    pose = np.eye(4)
    pose[:3, :3] = np.column_stack([x, np.cross(z, x), z])
    pose[:3, 3] = eye
    return pose


__all__ = [
    "LAMP_DISTANCE",
    "ShadowMap",
    "camera_points",
    "direction_from_angles",
    "draw_lighting",
    "render_lit",
    "render_two_sided",
    "shade_shadows",
    "station_lighting",
    "surface_normals",
]
