"""The cloth catalogue and its meshes: sizes, colours away from the green, fabric looks,
hue families, Σ_M geometry."""

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
    fabric_atlas_image,
    fabric_texture_image,
    outline_polygon,
    polygon_area,
    polygon_centroid,
    texture_image,
)
from robot_app.sim.config import CATALOGUE_SIZE
from robot_app.vision.hue import DARK, LIGHT, colour_codes, hue_distance, to_hsv

BACKGROUND_HUE = 85  # HSV_FULL hue of the green sheet


def test_catalogue_has_twenty_distinct_cloths_within_paper_size() -> None:
    assert [s.number for s in CATALOGUE] == list(range(1, CATALOGUE_SIZE + 1)) == list(range(1, 21))
    for spec in CATALOGUE:
        assert spec.size[0] <= MAX_SIZE[0] + 1e-9 and spec.size[1] <= MAX_SIZE[1] + 1e-9
    assert len({(s.size, s.outline, s.pattern, s.colours) for s in CATALOGUE}) == 20
    assert len({s.outline for s in CATALOGUE}) >= 4
    assert len({s.mass for s in CATALOGUE}) >= 8
    assert {s.fabric.weave for s in CATALOGUE} == {"plain", "twill", "denim", "knit", "pile"}
    assert {s.fabric.print for s in CATALOGUE} == {"none", "floral", "photo"}


@pytest.mark.parametrize("spec", CATALOGUE, ids=lambda s: f"No{s.number}")
def test_textures_are_deterministic_and_not_green(spec: ClothSpec) -> None:
    for draw in (texture_image, fabric_texture_image):
        image = draw(spec)
        np.testing.assert_array_equal(image, draw(spec))
        hsv = to_hsv(image)
        saturated = hsv[:, :, 1] > 60
        near_green = hue_distance(hsv[:, :, 0], BACKGROUND_HUE) <= 30
        assert np.mean(near_green & saturated) < 0.02, draw.__name__


def _dominant_code(image: np.ndarray) -> int:
    """The most common colour code (hue in 16 bins, or DARK / LIGHT) of a texture."""
    codes = colour_codes(to_hsv(image), min_saturation=40, min_value=40).ravel()
    binned = np.where(codes < 256, codes // 16, codes)
    values, counts = np.unique(binned, return_counts=True)
    return int(values[np.argmax(counts)])


def test_extended_set_has_hue_families_and_hueless_cloths() -> None:
    # three blues, a second red (with No.1), two whites, and cloths with no hue at all:
    # identification cannot rest on the hue band alone
    dominant = {s.number: _dominant_code(fabric_texture_image(s)) for s in CATALOGUE}
    blue = [n for n in range(13, 21) if dominant[n] in (8, 9, 10)]  # hues 128-175 of 256
    assert len(blue) >= 3, dominant
    red = [n for n, code in dominant.items() if code in (14, 15, 0)]  # hues 224-255, 0-15
    assert {1, 16} <= set(red), dominant
    assert {17, 18} <= {n for n in range(13, 21) if dominant[n] == LIGHT}, dominant
    assert dominant[20] == DARK and dominant[19] in (DARK, LIGHT)


@pytest.mark.parametrize("number", [1, 4, 13, 17, 19])
def test_fabric_has_micro_texture_that_the_flat_cloth_lacks(number: int) -> None:
    spec = cloth_spec(number)
    flat, fabric = texture_image(spec), fabric_texture_image(spec)
    # a 6x6 mm patch inside one colour of the flat texture: flat is one value, fabric varies
    y, x = np.argwhere(np.all(flat == flat[flat.shape[0] // 2, flat.shape[1] // 2], axis=2))[len(flat) // 2]
    y, x = min(y, flat.shape[0] - 12), min(x, flat.shape[1] - 12)
    assert flat[y : y + 12, x : x + 12].reshape(-1, 3).std(axis=0).max() == 0
    assert fabric[y : y + 12, x : x + 12].reshape(-1, 3).astype(float).std(axis=0).max() > 2.0


@pytest.mark.parametrize("spec", CATALOGUE, ids=lambda s: f"No{s.number}")
def test_back_side_is_darker_and_duller(spec: ClothSpec) -> None:
    atlas = fabric_atlas_image(spec)
    front, back = np.split(atlas, 2, axis=1)
    front_v, back_v = to_hsv(front)[:, :, 2].astype(float), to_hsv(back)[:, :, 2].astype(float)
    assert back_v.mean() < 0.85 * front_v.mean()
    grey = lambda image: image.astype(float).mean(axis=2)  # noqa: E731
    assert grey(back).std() < grey(front).std() or front_v.std() < 6


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
    with pytest.raises(InputError) as number:
        cloth_spec(21)
    assert (number.value.value, number.value.expected) == (21, "1..20")


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
