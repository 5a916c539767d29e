"""Tests of the ground-truth renderer: where texture points land, what is covered."""

from __future__ import annotations

import numpy as np
import pytest

from robot_app.geometry import make_transform, rotation_about_z, rotation_from_rpy
from robot_app.vision.camera import ModelCamera, PinholeCamera, StereoRig
from robot_app.vision.hue import hue_distance, to_hsv, to_hue
from robot_app.vision.synthetic import (
    OCCLUDER_BLUE_BGR,
    TABLE_GREEN_BGR,
    SyntheticCloth,
    occluder_covering,
    render_model_photo,
    render_stereo_pair,
)
from robot_app.vision.synthetic_catalogue import CATALOGUE_SIZE, synthetic_cloth

GREEN_HUE = int(to_hue(np.array([[TABLE_GREEN_BGR]], np.uint8))[0, 0])
BLUE_HUE = int(to_hue(np.array([[OCCLUDER_BLUE_BGR]], np.uint8))[0, 0])


def _rig(distortion: tuple[float, ...] = (0.0,) * 5) -> StereoRig:
    base = PinholeCamera.from_fov((320, 240), np.deg2rad(48))
    camera = PinholeCamera(base.camera_matrix, base.image_size, np.array(distortion))
    return StereoRig(camera, camera, make_transform(np.eye(3), [-0.1, 0.0, 0.0]))


def _cloth_mask(image: np.ndarray) -> np.ndarray:
    """Pixels that are neither the green table (by hue) nor unsaturated."""
    hsv = to_hsv(image)
    return (hue_distance(hsv[..., 0], GREEN_HUE) > 30) & (hsv[..., 1] > 60)


def _marked_cloth() -> tuple[SyntheticCloth, np.ndarray]:
    """A red 0.16 x 0.12 m sheet with a 4 mm yellow square; returns it and the square's centre texel."""
    texture = np.empty((240, 320, 3), np.uint8)
    texture[:] = (30, 30, 210)
    texture[60:68, 200:208] = (20, 210, 230)
    return SyntheticCloth("marked", texture, np.ones((240, 320), bool), (0.16, 0.12)), np.array([203.5, 63.5])


def _marker_centre(image: np.ndarray) -> np.ndarray:
    hsv = to_hsv(image).astype(float)
    weight = np.clip(hsv[..., 2] - 150, 0, None) * (hue_distance(hsv[..., 0], 37) < 12) * (hsv[..., 1] > 100)
    v, u = np.indices(weight.shape)
    return np.array([(u * weight).sum(), (v * weight).sum()]) / weight.sum()


def test_catalogue_has_twelve_distinct_saturated_non_green_cloths_of_paper_size():
    assert CATALOGUE_SIZE >= 12
    cloths = [synthetic_cloth(i) for i in range(CATALOGUE_SIZE)]
    assert len({c.name for c in cloths}) == CATALOGUE_SIZE
    assert len({(c.size, c.texture_bgr[c.alpha].mean().round(1)) for c in cloths}) == CATALOGUE_SIZE
    for cloth in cloths:
        assert cloth.size[0] <= 0.25 + 1e-9 and cloth.size[1] <= 0.20 + 1e-9
        hsv = to_hsv(cloth.texture_bgr)[cloth.alpha]
        assert hue_distance(hsv[:, 0], GREEN_HUE).min() > 40, cloth.name
        assert np.percentile(hsv[:, 1], 1) > 100, cloth.name
    outlines = [c.alpha.mean() for c in cloths]
    assert sum(f < 0.99 for f in outlines) >= 4  # non-rectangular outlines


@pytest.mark.parametrize("distortion", [(0.0,) * 5, (-0.12, 0.05, 0.001, -0.002, 0.0)])
def test_a_texture_point_lands_where_the_rig_projects_it(distortion):
    rig = _rig(distortion)
    cloth, marker_texel = _marked_cloth()
    pose = make_transform(rotation_from_rpy(0.15, -0.1, 0.7), [0.02, -0.015, 0.5])
    left, right = render_stereo_pair(rig, [(cloth, pose)], rng=np.random.default_rng(1))
    expected_left, expected_right = rig.project_model(pose, cloth.texel_to_model(marker_texel)[None])
    assert np.linalg.norm(_marker_centre(left) - expected_left[0]) < 0.3
    assert np.linalg.norm(_marker_centre(right) - expected_right[0]) < 0.3


def test_model_origin_is_the_outline_centroid():
    rig = _rig()
    cloth = synthetic_cloth(12)  # L-shaped: its centroid is not the texture centre
    pose = make_transform(rotation_about_z(0.4), [-0.01, 0.02, 0.58])
    _, right = render_stereo_pair(rig, [(cloth, pose)], noise_sigma=0.0)
    v, u = np.nonzero(_cloth_mask(right))
    _, origin = rig.project_model(pose, np.zeros((1, 3)))
    assert np.linalg.norm([u.mean() - origin[0, 0], v.mean() - origin[0, 1]]) < 0.5
    pixel_area = (0.58 / rig.right.camera_matrix[0, 0]) ** 2
    assert u.size * pixel_area == pytest.approx(cloth.area, rel=0.03)


def test_occluder_covers_the_requested_fraction():
    rig = _rig()
    cloth = synthetic_cloth(3)
    pose = make_transform(rotation_about_z(-0.8), [0.03, 0.01, 0.58])
    for fraction, direction in ((0.45, 0.0), (0.3, 2.0)):
        occluder = occluder_covering(cloth, pose, fraction=fraction, direction=direction)
        _, clear = render_stereo_pair(rig, [(cloth, pose)])
        _, hidden = render_stereo_pair(rig, [(cloth, pose)], occluder=occluder)
        cloth_pixels = _cloth_mask(clear)
        blue = hue_distance(to_hue(hidden), BLUE_HUE) < 15
        assert (blue & cloth_pixels).sum() / cloth_pixels.sum() == pytest.approx(fraction, abs=0.03)


def test_later_placements_are_drawn_on_top_and_outside_points_are_cut():
    rig = _rig()
    red, yellow = synthetic_cloth(0), synthetic_cloth(1)
    pose = make_transform(np.eye(3), [0.0, 0.0, 0.58])
    _, right = render_stereo_pair(rig, [(red, pose), (yellow, pose)], noise_sigma=0.0)
    assert abs(int(to_hue(right)[120, 160]) - 37) <= 3  # yellow on top at the centre
    off_image = make_transform(np.eye(3), [0.2, 0.0, 0.58])  # half outside the right image
    _, right = render_stereo_pair(rig, [(red, off_image)], noise_sigma=0.0)
    assert _cloth_mask(right)[100:140, -5:].all() and not _cloth_mask(right)[:, :150].any()


def test_model_photo_shows_the_cloth_centred_and_the_background_empty():
    model_camera = ModelCamera(PinholeCamera.from_fov((640, 480), np.deg2rad(48)), 0.40)
    cloth = synthetic_cloth(8)
    photo, background = render_model_photo(cloth, model_camera, rng=np.random.default_rng(3))
    v, u = np.nonzero(_cloth_mask(photo))
    f = model_camera.camera.camera_matrix[0, 0]
    assert u.size * (0.40 / f) ** 2 == pytest.approx(cloth.area, rel=0.02)
    K = model_camera.camera.camera_matrix
    assert abs(u.mean() - K[0, 2]) < 0.5 and abs(v.mean() - K[1, 2]) < 0.5
    assert not _cloth_mask(background).any()
    assert photo.shape == background.shape == (480, 640, 3)


def test_bad_arguments_are_programming_errors():
    cloth = synthetic_cloth(0)
    with pytest.raises(ValueError, match="index"):
        synthetic_cloth(CATALOGUE_SIZE)
    with pytest.raises(ValueError, match="fraction"):
        occluder_covering(cloth, np.eye(4), fraction=1.2)
    with pytest.raises(ValueError, match="4x4"):
        render_stereo_pair(_rig(), [(cloth, np.eye(3))])
    with pytest.raises(ValueError, match="background_bgr"):
        render_stereo_pair(_rig(), [], background_bgr=np.zeros((10, 10, 3), np.uint8))
    with pytest.raises(ValueError, match="alpha"):
        SyntheticCloth("empty", np.zeros((4, 4, 3), np.uint8), np.zeros((4, 4), bool), (0.1, 0.1))
