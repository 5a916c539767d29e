"""The S_in outline drawn on camera images: its shape in Σ_M and its projection."""

from __future__ import annotations

import dataclasses

import cv2
import numpy as np
import pytest

from robot_app.geometry import make_transform, rotation_about_z
from robot_app.vision.camera import ModelCamera, PinholeCamera, StereoRig
from robot_app.vision.outline import draw_outline, model_outline, project_outline
from robot_app.vision.photo_model import make_model
from robot_app.vision.synthetic import TABLE_GREEN_BGR, render_model_photo, render_stereo_pair
from robot_app.vision.synthetic_catalogue import synthetic_cloth

MODEL_CAMERA = ModelCamera(PinholeCamera.from_fov((640, 480), np.deg2rad(48)), 0.40)
CAMERA = PinholeCamera.from_fov((640, 480), np.deg2rad(48))
RIG = StereoRig(CAMERA, CAMERA, make_transform(np.eye(3), [-0.1, 0.0, 0.0]))


def _model(index: int):
    cloth = synthetic_cloth(index)
    photo, background = render_model_photo(cloth, MODEL_CAMERA, rng=np.random.default_rng(index))
    return cloth, make_model(photo, MODEL_CAMERA, background)


def _area(polygons) -> float:
    return sum(abs(cv2.contourArea(p[:, :2].astype(np.float32))) for p in polygons)


@pytest.mark.parametrize("index", [0, 8, 12])  # rectangle, T-shirt, L-shape (not convex)
def test_outline_encloses_the_cloths_area(index: int) -> None:
    cloth, model = _model(index)
    outline = model_outline(model)
    assert all(p.shape[1] == 3 and np.all(p[:, 2] == 0) for p in outline)
    assert _area(outline) == pytest.approx(cloth.area, rel=0.03)
    main = outline[0][:, :2].astype(np.float32)
    distance = [cv2.pointPolygonTest(main, (float(x), float(y)), True) for x, y in model.points_in[:, :2]]
    assert min(distance) > -0.001  # every S_in point inside (or within 1 mm of) the outline
    # a model without its photo's texture (file versions 1-2): the boundary of its S_in points
    bare = dataclasses.replace(model, texture_bgr=None, texture_mask=None, texture_from_model=None)
    assert _area(model_outline(bare)) == pytest.approx(cloth.area, rel=0.1)


@pytest.mark.parametrize("yaw_deg", [0.0, 35.0, -120.0])
def test_projected_outline_covers_the_rendered_cloth_in_both_images(yaw_deg: float) -> None:
    cloth, model = _model(8)
    pose = make_transform(rotation_about_z(np.deg2rad(yaw_deg)), [0.03, -0.02, 0.55])
    table = np.full((480, 640, 3), TABLE_GREEN_BGR, np.uint8)
    images = render_stereo_pair(RIG, [(cloth, pose)], noise_sigma=0.0, background_bgr=table)
    projected = project_outline(RIG, pose, model_outline(model))
    for image, polygons in zip(images, (projected.left, projected.right), strict=True):
        rendered = np.any(image != table, axis=2)
        drawn = np.zeros(rendered.shape, np.uint8)
        cv2.fillPoly(drawn, [np.round(p).astype(np.int32) for p in polygons], 1)
        overlap = np.logical_and(rendered, drawn).sum() / np.logical_or(rendered, drawn).sum()
        assert overlap > 0.95


def test_points_behind_a_camera_are_left_out_and_drawing_changes_pixels() -> None:
    _, model = _model(0)
    behind = make_transform(np.eye(3), [0.0, 0.0, -0.5])
    assert project_outline(RIG, behind, model_outline(model)).right == ()
    pose = make_transform(np.eye(3), [0.0, 0.0, 0.55])
    projected = project_outline(RIG, pose, model_outline(model))
    image = np.zeros((240, 320, 3), np.uint8)
    draw_outline(image, projected.right, (0, 255, 255), 2, scale=0.5)
    assert image[..., 2].max() == 255 and image[..., 0].max() == 0
    assert image.any(axis=2).mean() < 0.1  # an outline, not a filled shape
