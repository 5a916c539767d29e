"""The collection boxes are known furniture, not unknown cloths: laid into the survey image
with the camera's pose, they are taken out of the unknown regions, so that a cloth lying
beside a box is a region of its own (its colours can be tested) and a box alone is not
reported as an unknown cloth.

Synthetic image, ray-cast per pixel (independent of the projection under test): a tilted
camera over the table sees a box (walls and floor) and a white cloth lying against its
wall; the unknown region `identify` would give is both together. Ground truth: which
pixels show the cloth.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from robot_app.control.clear_table_records import BoxPlace
from robot_app.control.table_furniture import furniture_mask, without_furniture
from robot_app.geometry import make_transform
from robot_app.vision import PinholeCamera
from robot_app.vision.identify import UnknownRegion

CAMERA = PinholeCamera.from_fov((320, 240), np.deg2rad(60))
BOX = BoxPlace("whites", np.array([0.30, 0.56, 0.0]), 0.22, 0.10, 0.01)
CLOTH = (0.42, 0.53, 0.12, 0.10)  # (x, y) centre and size on the table [m], against the box's +x wall
SMALLEST = 0.01 * 320 * 240  # IdentifySettings.min_unknown_area of the image


def _camera_to_world(tilt: float) -> np.ndarray:
    """A camera 0.5 m over (0.45, 0.50), looking down, tilted by `tilt` [rad] towards -x
    (the box): its walls are seen from the side as well as from above."""
    down = np.diag([1.0, -1.0, -1.0])  # optical axis along -z_W
    c, s = np.cos(-tilt), np.sin(-tilt)
    about_y = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
    return make_transform(about_y.T @ down, [0.45, 0.50, 0.50])


def _ray_cast(transform: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(box, cloth) pixel masks: a pixel shows the box when its ray passes through the
    box's outer volume (walls, inside, floor) before the table, else the cloth when it
    meets the table inside the cloth's rectangle."""
    w, h = CAMERA.image_size
    u, v = np.meshgrid(np.arange(w) + 0.0, np.arange(h) + 0.0)
    K = CAMERA.camera_matrix
    rays_camera = np.stack([(u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1], np.ones_like(u)], axis=-1)
    rays = rays_camera @ transform[:3, :3].T
    origin = transform[:3, 3]
    half = BOX.inner_size / 2 + BOX.wall_thickness
    box = np.zeros((h, w), bool)
    for z in np.linspace(0.0, BOX.wall_height, 201):
        t = (z - origin[2]) / rays[..., 2]
        x, y = origin[0] + t * rays[..., 0], origin[1] + t * rays[..., 1]
        box |= (np.abs(x - BOX.centre[0]) <= half) & (np.abs(y - BOX.centre[1]) <= half)
    t = -origin[2] / rays[..., 2]
    x, y = origin[0] + t * rays[..., 0], origin[1] + t * rays[..., 1]
    cx, cy, sx, sy = CLOTH
    cloth = (np.abs(x - cx) <= sx / 2) & (np.abs(y - cy) <= sy / 2) & ~box
    return box, cloth


def _capture(transform: np.ndarray) -> SimpleNamespace:
    image = np.zeros((240, 320, 3), np.uint8)
    return SimpleNamespace(right_bgr=image, transform_right_camera_to_world=transform)


def _region(mask: np.ndarray) -> UnknownRegion:
    v, u = np.nonzero(mask)
    return UnknownRegion((float(u.mean()), float(v.mean())), int(mask.sum()), mask)


@pytest.mark.parametrize("tilt", [0.0, np.deg2rad(25)])
def test_the_cloth_beside_a_box_becomes_its_own_region(tilt: float) -> None:
    transform = _camera_to_world(tilt)
    box, cloth = _ray_cast(transform)
    assert box.sum() > cloth.sum() > SMALLEST  # the box takes most of the joint region
    joint = _region(box | cloth)
    share_before = cloth.sum() / joint.area
    capture = _capture(transform)
    furniture = furniture_mask(capture, CAMERA, [BOX], box.shape)
    regions = without_furniture([joint], furniture, SMALLEST)
    assert len(regions) == 1
    kept = regions[0].mask
    share_after = (kept & cloth).sum() / kept.sum()
    assert share_before < 0.5
    assert share_after > 0.95  # the box's pixels are gone ...
    assert (kept & cloth).sum() > 0.8 * cloth.sum()  # ... and most of the cloth is still there
    assert regions[0].area == kept.sum()
    assert abs(regions[0].centroid[0] - np.nonzero(kept)[1].mean()) < 1e-6


def test_a_box_alone_is_no_unknown_region() -> None:
    transform = _camera_to_world(np.deg2rad(25))
    box, _ = _ray_cast(transform)
    capture = _capture(transform)
    furniture = furniture_mask(capture, CAMERA, [BOX], box.shape)
    assert without_furniture([_region(box)], furniture, SMALLEST) == ()


def test_a_cloth_away_from_the_boxes_is_unchanged() -> None:
    transform = _camera_to_world(0.0)
    away = np.zeros((240, 320), bool)
    away[150:220, 220:300] = True  # a cloth in the image's far corner, nowhere near the box
    capture = _capture(transform)
    furniture = furniture_mask(capture, CAMERA, [BOX], away.shape)
    assert not (furniture & away).any()
    (region,) = without_furniture([_region(away)], furniture, SMALLEST)
    assert np.array_equal(region.mask, away)


def test_a_box_behind_the_camera_adds_nothing() -> None:
    transform = make_transform(np.diag([1.0, 1.0, 1.0]), [0.45, 0.50, 0.50])  # looking up
    capture = _capture(transform)
    assert not furniture_mask(capture, CAMERA, [BOX], (240, 320)).any()
