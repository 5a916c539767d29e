"""The cloth catalogue and its meshes: sizes, colours away from the green, Σ_M geometry."""

from __future__ import annotations

import numpy as np
import pytest

from robot_app.errors import InputError
from robot_app.sim.cloth_mesh import build_cloth_mesh
from robot_app.sim.cloths import (
    CATALOGUE,
    MAX_SIZE,
    ClothSpec,
    cloth_spec,
    outline_polygon,
    polygon_area,
    polygon_centroid,
    texture_image,
)
from robot_app.vision.hue import hue_distance, to_hsv

BACKGROUND_HUE = 85  # HSV_FULL hue of the green sheet


def test_catalogue_has_twelve_distinct_cloths_within_paper_size() -> None:
    assert [s.number for s in CATALOGUE] == list(range(1, 13))
    for spec in CATALOGUE:
        assert spec.size[0] <= MAX_SIZE[0] + 1e-9 and spec.size[1] <= MAX_SIZE[1] + 1e-9
    assert len({(s.size, s.outline, s.pattern, s.colours) for s in CATALOGUE}) == 12
    assert len({s.outline for s in CATALOGUE}) >= 4
    assert len({s.mass for s in CATALOGUE}) >= 8


@pytest.mark.parametrize("spec", CATALOGUE, ids=lambda s: f"No{s.number}")
def test_texture_is_deterministic_and_not_green(spec: ClothSpec) -> None:
    image = texture_image(spec)
    np.testing.assert_array_equal(image, texture_image(spec))
    hsv = to_hsv(image)
    saturated = hsv[:, :, 1] > 60
    near_green = hue_distance(hsv[:, :, 0], BACKGROUND_HUE) <= 30
    assert np.mean(near_green & saturated) < 0.01


def test_multicolour_cloth_no3_is_small_light_and_colourful() -> None:
    no3 = cloth_spec(3)
    hues = to_hsv(texture_image(no3))[:, :, 0]
    assert len(np.unique(hues // 16)) >= 4
    assert no3.mass == min(s.mass for s in CATALOGUE if s.size[0] > 0.15)
    assert no3.size[0] * no3.size[1] < 0.6 * MAX_SIZE[0] * MAX_SIZE[1]


def test_bad_catalogue_entries_are_rejected() -> None:
    with pytest.raises(ValueError, match="size"):
        ClothSpec(99, "huge", (0.4, 0.2), "rectangle", "plain", ((0, 0, 255),), 0.1)
    with pytest.raises(ValueError, match="outline"):
        ClothSpec(99, "odd", (0.2, 0.2), "star", "plain", ((0, 0, 255),), 0.1)
    with pytest.raises(InputError, match=r"1\.\.12"):
        cloth_spec(13)


def test_polygon_centroid_of_a_known_shape() -> None:
    square_with_tail = np.array([[0, 0], [2, 0], [2, 2], [0, 2]], float)
    assert polygon_area(square_with_tail) == pytest.approx(4.0)
    np.testing.assert_allclose(polygon_centroid(square_with_tail), [1.0, 1.0])


@pytest.mark.parametrize("number", [3, 7, 8, 10])
def test_mesh_is_centred_on_the_outline_centroid_and_covers_it(number: int) -> None:
    spec = cloth_spec(number)
    mesh = build_cloth_mesh(spec)
    triangles = mesh.vertices[mesh.triangles][:, :, :2]
    a, b, c = triangles[:, 0], triangles[:, 1], triangles[:, 2]
    cross = (b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0]
    area = 0.5 * np.abs(cross)
    outline_area = abs(polygon_area(outline_polygon(spec)))
    assert area.sum() == pytest.approx(outline_area, rel=0.01)
    centroid = (area[:, None] * triangles.mean(axis=1)).sum(axis=0) / area.sum()
    np.testing.assert_allclose(centroid, [0, 0], atol=1e-3)
    # texture coordinates follow Σ_M's x (right) and y (down) over the bounding box
    np.testing.assert_allclose(mesh.uvs * spec.size - mesh.offset, mesh.vertices[:, :2], atol=1e-9)
    assert 30 <= len(mesh.vertices) <= 200
