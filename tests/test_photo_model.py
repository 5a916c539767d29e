"""Tests of the photo model (paper Sec. II-B): ClothModel file round trip, make_model."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from robot_app.errors import InputError, ModelError
from robot_app.vision.camera import ModelCamera, PinholeCamera
from robot_app.vision.cloth_model import ClothModel
from robot_app.vision.hue import DARK, LIGHT, colour_codes, hue_distance, to_hsv, to_hue
from robot_app.vision.photo_model import ModelSettings, load_photo, make_model
from robot_app.vision.synthetic import TABLE_GREEN_BGR, SyntheticCloth, render_model_photo
from robot_app.vision.synthetic_catalogue import synthetic_cloth


def _handmade_model() -> ClothModel:
    rng = np.random.default_rng(0)
    return ClothModel(
        name="handmade",
        points_in=rng.uniform(-0.1, 0.1, (40, 3)) * [1, 1, 0],
        hues_in=rng.integers(0, 256, 40),
        points_out=rng.uniform(-0.12, 0.12, (30, 3)) * [1, 1, 0],
        background_hue=85.5,
        grasp_point=[0.01, -0.02, 0.0],
        extent=(0.2, 0.15),
        symmetry_angles=(np.pi,),
        metadata={"metres_per_pixel": 0.0007, "source": "none"},
    )


def test_model_file_round_trips_exactly(tmp_path):
    model = _handmade_model()
    path = tmp_path / "m.npz"
    model.save(path)
    loaded = ClothModel.load(path)
    assert loaded == model
    assert loaded.hues_in.dtype == np.uint16
    assert not loaded.points_in.flags.writeable


def test_loading_a_missing_file_is_an_input_error(tmp_path):
    with pytest.raises(InputError) as missing:
        ClothModel.load(tmp_path / "nothing.npz")
    assert missing.value.path == tmp_path / "nothing.npz" and not isinstance(missing.value, ModelError)


def test_loading_another_npz_is_a_model_error(tmp_path):
    path = tmp_path / "other.npz"
    np.savez(path, points=np.zeros((3, 3)))
    with pytest.raises(ModelError) as other:
        ClothModel.load(path)
    assert (other.value.path, other.value.key) == (path, "header")


def test_loading_a_text_file_is_a_model_error(tmp_path):
    path = tmp_path / "text.npz"
    path.write_text("not a zip")
    with pytest.raises(ModelError) as text:
        ClothModel.load(path)
    assert (text.value.path, text.value.key) == (path, None)


def test_model_rejects_mismatched_hues():
    with pytest.raises(ModelError) as count:
        ClothModel("x", np.zeros((3, 3)), np.zeros(2), np.zeros((0, 3)), 80.0, np.zeros(3), (0, 0))
    assert (count.value.key, count.value.value) == ("hues_in", (2,))
    with pytest.raises(ModelError) as code:
        ClothModel("x", np.zeros((1, 3)), np.array([LIGHT + 1]), np.zeros((0, 3)), 80.0, np.zeros(3), (0, 0))
    assert (code.value.key, code.value.value) == ("hues_in", [LIGHT + 1])


def test_a_file_with_arrays_the_model_rejects_names_the_file_and_the_array(tmp_path):
    _handmade_model().save(tmp_path / "m.npz")
    with np.load(tmp_path / "m.npz") as data:
        arrays = dict(data)
    arrays["hues_in"] = arrays["hues_in"][:-1]
    np.savez(tmp_path / "short.npz", **arrays)
    with pytest.raises(ModelError) as short:
        ClothModel.load(tmp_path / "short.npz")
    assert (short.value.path, short.value.key, short.value.value) == (
        tmp_path / "short.npz",
        "hues_in",
        (39,),
    )


def test_a_version_1_file_still_loads(tmp_path):
    model = _handmade_model()
    model.save(tmp_path / "new.npz")
    with np.load(tmp_path / "new.npz") as data:
        arrays = dict(data)
    header = json.loads(str(arrays["header"]))
    header["version"] = 1
    arrays["header"] = np.array(json.dumps(header))
    arrays["hues_in"] = arrays["hues_in"].astype(np.uint8)  # version 1: hues only, uint8
    np.savez(tmp_path / "old.npz", **arrays)
    assert ClothModel.load(tmp_path / "old.npz") == model
    header["version"] = 4
    arrays["header"] = np.array(json.dumps(header))
    np.savez(tmp_path / "future.npz", **arrays)
    with pytest.raises(ModelError) as future:
        ClothModel.load(tmp_path / "future.npz")
    assert (future.value.path, future.value.key, future.value.value) == (
        tmp_path / "future.npz",
        "version",
        4,
    )


def test_a_version_3_model_keeps_its_photo_texture_and_sheet_colour(tmp_path):
    cloth = synthetic_cloth(3)
    photo, background = render_model_photo(cloth, MODEL_CAMERA)
    model = make_model(photo, MODEL_CAMERA, background)
    assert model.has_texture and model.sheet_bgr is not None
    # the sheet's colour is the photo's green
    assert np.all(np.abs(model.sheet_bgr - np.median(background.reshape(-1, 3), axis=0)) <= 3)
    # the texture map sends each S_in point to a pixel of the cloth of the point's hue
    A = model.texture_from_model
    uv = model.points_in[:, :2] @ A[:, :2].T + A[:, 2]
    iu, iv = np.rint(uv).astype(int).T
    assert model.texture_mask[iv, iu].all()
    hues = to_hue(np.ascontiguousarray(model.texture_bgr))[iv, iu]
    hued = model.hues_in < 256
    assert np.median(hue_distance(hues[hued], model.hues_in[hued])) <= 3
    model.save(tmp_path / "m.npz")
    assert ClothModel.load(tmp_path / "m.npz") == model
    assert not any(p.name.startswith(".") for p in tmp_path.iterdir())  # no partial file left


def test_a_version_2_file_loads_without_texture(tmp_path):
    cloth = synthetic_cloth(3)
    photo, background = render_model_photo(cloth, MODEL_CAMERA)
    make_model(photo, MODEL_CAMERA, background).save(tmp_path / "new.npz")
    with np.load(tmp_path / "new.npz") as data:
        arrays = {k: v for k, v in data.items() if not k.startswith("texture")}
    header = json.loads(str(arrays["header"]))
    header["version"] = 2
    del header["sheet_bgr"]
    arrays["header"] = np.array(json.dumps(header))
    np.savez(tmp_path / "v2.npz", **arrays)
    old = ClothModel.load(tmp_path / "v2.npz")
    assert not old.has_texture and old.sheet_bgr is None and old.n_in > 0


def _checks_with_white_stripe() -> SyntheticCloth:
    """20 x 16 cm: yellow and black 2 cm checks, a white stripe 2 cm wide across the middle."""
    v, u = np.indices((320, 400))
    texture = np.where((((u // 40) + (v // 40)) % 2 == 0)[..., None], (30, 200, 225), (35, 35, 35))
    texture[(v >= 140) & (v < 180)] = (225, 225, 225)
    return SyntheticCloth("checks", texture.astype(np.uint8), np.ones((320, 400), bool), (0.2, 0.16))


def test_black_and_white_parts_become_toned_points():
    cloth = _checks_with_white_stripe()
    photo, background = render_model_photo(cloth, MODEL_CAMERA, rng=np.random.default_rng(2))
    model = make_model(photo, MODEL_CAMERA, background)
    texel = _model_to_texel(cloth, model.points_in)
    codes = colour_codes(to_hsv(np.ascontiguousarray(cloth.texture_bgr)), 40, 40, 128)
    truth = codes[texel[:, 1], texel[:, 0]]
    dark, light = model.hues_in == DARK, model.hues_in == LIGHT
    assert dark.sum() > 50 and light.sum() > 20
    assert np.mean(truth[dark] == DARK) > 0.95 and np.mean(truth[light] == LIGHT) > 0.95
    # Away from colour edges (±2 photo pixels, where the blur mixes black with yellow) every
    # black sample is DARK.
    kernel = np.ones((9, 9), np.uint8)
    dark_texels = (codes == DARK).astype(np.uint8)
    deep_dark = cv2.erode(dark_texels, kernel).astype(bool)[texel[:, 1], texel[:, 0]]
    assert deep_dark.sum() > 50 and np.all(model.hues_in[deep_dark] == DARK)
    hue_only = make_model(photo, MODEL_CAMERA, background, ModelSettings(tones=False))
    assert (hue_only.hues_in < 256).all() and hue_only.n_in < model.n_in - dark.sum()
    assert hue_only.extent == model.extent  # the outline is the same either way


# --- make_model on rendered photos with exact ground truth -------------------------------

MODEL_CAMERA = ModelCamera(PinholeCamera.from_fov((640, 480), np.deg2rad(48)), 0.40)
PIXEL = 0.40 / MODEL_CAMERA.camera.camera_matrix[0, 0]  # metres per pixel on the sheet
GREEN_HUE = int(to_hue(np.array([[TABLE_GREEN_BGR]], np.uint8))[0, 0])


def _photo(index: int, camera: ModelCamera = MODEL_CAMERA) -> tuple[SyntheticCloth, np.ndarray, np.ndarray]:
    cloth = synthetic_cloth(index)
    photo, background = render_model_photo(cloth, camera, rng=np.random.default_rng(index))
    return cloth, photo, background


def _outline_extent(cloth: SyntheticCloth) -> tuple[float, float]:
    sx, sy = cloth.texel_size
    return cloth.alpha.any(axis=0).sum() * sx, cloth.alpha.any(axis=1).sum() * sy


def _model_to_texel(cloth: SyntheticCloth, points: np.ndarray) -> np.ndarray:
    return np.rint((points[:, :2] + cloth.centroid) / cloth.texel_size - 0.5).astype(int)


@pytest.mark.parametrize("index", [0, 3, 8, 12])  # rectangle, multi-colour, T-shirt, L-shape
def test_make_model_recovers_the_cloth_geometry_in_metres(index):
    cloth, photo, background = _photo(index)
    model = make_model(photo, MODEL_CAMERA, background)
    assert model.extent == pytest.approx(_outline_extent(cloth), abs=2 * PIXEL)
    assert model.metadata["area_m2"] == pytest.approx(cloth.area, rel=0.02)
    # The cloth lies with its centroid on the optical axis: Σ_M's origin is there.
    assert np.linalg.norm(model.metadata["origin_in_photo_plane"]) < PIXEL
    # Every S_in point is on the cloth and carries the texture's hue there.
    texel = _model_to_texel(cloth, model.points_in)
    height, width = cloth.alpha.shape
    inside = (texel >= 0).all(axis=1) & (texel[:, 0] < width) & (texel[:, 1] < height)
    assert inside.all() and cloth.alpha[texel[:, 1], texel[:, 0]].mean() > 0.99
    texture_hue = to_hue(cloth.texture_bgr)
    kernel = np.ones((9, 9), np.uint8)  # ±2 photo pixels: where the blurred photo mixes colours
    colour_edge = hue_distance(cv2.dilate(texture_hue, kernel), cv2.erode(texture_hue, kernel)) > 8
    colour_edge |= cv2.erode(cloth.alpha.astype(np.uint8), kernel, borderValue=0) == 0  # the outline
    clear = ~colour_edge[texel[:, 1], texel[:, 0]]
    assert clear.mean() > 0.6  # the outermost S_in ring lies 1 mm (< 2 photo pixels) inside the outline
    hue_error = hue_distance(texture_hue[texel[:, 1], texel[:, 0]], model.hues_in)
    assert np.mean(hue_error[clear] <= 4) > 0.99
    assert np.all(model.points_in[:, 2] == 0) and np.all(model.points_out[:, 2] == 0)
    literal = ModelSettings(sampling="grid", point_spacing=0.006, colour_edge_gap=0.0)
    grid = make_model(photo, MODEL_CAMERA, background, literal)
    assert grid.n_in == pytest.approx(cloth.area / 0.006**2, rel=0.1)
    # By default the samples within 1 mm of another colour are dropped: a few on a multi-colour cloth.
    spaced = make_model(photo, MODEL_CAMERA, background, ModelSettings(sampling="grid", point_spacing=0.006))
    assert (index == 3) == (spaced.n_in < 0.95 * grid.n_in) and spaced.n_in <= grid.n_in


def _distance_to_outline(cloth: SyntheticCloth, points: np.ndarray, inside: bool) -> np.ndarray:
    """Distance [m] of model points from the true outline, inside or outside it."""
    pad = 200
    outline = np.pad(cloth.alpha, pad).astype(np.uint8)
    distance = cv2.distanceTransform(outline if inside else 1 - outline, cv2.DIST_L2, 5) * cloth.texel_size[0]
    texel = _model_to_texel(cloth, points) + pad
    return distance[texel[:, 1], texel[:, 0]]


@pytest.mark.parametrize("index", [0, 8])
def test_edge_sampling_puts_rings_along_the_outline_on_both_sides(index):
    cloth, photo, background = _photo(index)
    settings = ModelSettings(edge_offsets=(0.001, 0.004), band_gap=0.001, band_width=0.008, band_rings=2)
    model = make_model(photo, MODEL_CAMERA, background, settings)
    depth = _distance_to_outline(cloth, model.points_in, inside=True)
    gap = _distance_to_outline(cloth, model.points_out, inside=False)
    assert gap.min() > 0  # no S_out point on the cloth
    for offset in (0.001, 0.004):  # each S_in ring: about one edge_spacing apart all along the outline
        ring = np.abs(depth - offset) < 1.5 * PIXEL
        perimeter = (
            cv2.arcLength(
                cv2.findContours(cloth.alpha.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)[0][
                    0
                ],
                True,
            )
            * cloth.texel_size[0]
        )
        assert ring.sum() == pytest.approx(perimeter / settings.edge_spacing, rel=0.25)  # fmt: skip
    for offset in (0.001, 0.009):  # S_out rings at band_gap and band_gap + band_width
        assert np.sum(np.abs(gap - offset) < 1.5 * PIXEL) > 0.4 * len(gap)
    # the interior is on the coarser grid, away from the rings
    interior = depth > 0.004 + 2 * PIXEL
    assert np.min(depth[interior]) > 0.004 + settings.point_spacing / 2 - 2 * PIXEL


def test_s_out_is_a_band_enveloping_s_in():
    cloth, photo, background = _photo(12)
    settings = ModelSettings(sampling="grid", point_spacing=0.006, band_width=0.012, band_gap=0.003)
    model = make_model(photo, MODEL_CAMERA, background, settings)
    # Distance of each S_out point from the true outline, via the texture's distance transform.
    pad = 200
    outline = np.pad(cloth.alpha, pad).astype(np.uint8)
    distance = cv2.distanceTransform(1 - outline, cv2.DIST_L2, 5) * cloth.texel_size[0]
    texel = _model_to_texel(cloth, model.points_out) + pad
    gap = distance[texel[:, 1], texel[:, 0]]
    assert gap.min() > 0.003 - 2 * PIXEL and gap.max() < 0.015 + 2 * PIXEL
    angles = np.arctan2(model.points_out[:, 1], model.points_out[:, 0])
    assert len(np.unique(np.floor((angles + np.pi) / (2 * np.pi) * 36) % 36)) == 36  # all around


def test_background_hue_from_the_border_agrees_with_the_background_photo():
    _, photo, background = _photo(2)
    with_background = make_model(photo, MODEL_CAMERA, background)
    from_border = make_model(photo, MODEL_CAMERA)
    assert abs(with_background.background_hue - GREEN_HUE) < 8
    assert hue_distance(round(with_background.background_hue), round(from_border.background_hue)) <= 2
    assert from_border.metadata["background"] == "photo border"


@pytest.mark.parametrize(
    ("index", "expected"),
    [(0, (np.pi,)), (1, (np.pi / 2, np.pi, 3 * np.pi / 2)), (12, ()), (10, ()), (9, (np.pi,))],
)
def test_symmetry_angles_from_self_overlap(index, expected):
    _, photo, _ = _photo(index)
    assert make_model(photo, MODEL_CAMERA).symmetry_angles == pytest.approx(expected)


def test_grasp_point_is_deepest_inside_the_cloth():
    _, photo, _ = _photo(0)  # a plain rectangle: the ridge of the distance transform is centred
    assert np.linalg.norm(make_model(photo, MODEL_CAMERA).grasp_point) < 2 * PIXEL
    cloth, photo, _ = _photo(12)  # L-shape: deepest point of the wide arm, on the cloth
    grasp = make_model(photo, MODEL_CAMERA).grasp_point
    texel = _model_to_texel(cloth, grasp[None])[0]
    assert cloth.alpha[texel[1], texel[0]]
    alpha = np.pad(cloth.alpha, 1).astype(np.uint8)
    depth = cv2.distanceTransform(alpha, cv2.DIST_L2, 5)[1:-1, 1:-1]
    assert depth[texel[1], texel[0]] > 0.95 * depth.max()


def test_make_model_undistorts_a_distorted_camera():
    base = MODEL_CAMERA.camera
    camera = ModelCamera(PinholeCamera(base.camera_matrix, base.image_size, [-0.2, 0.08, 0, 0, 0]), 0.40)
    cloth, photo, _ = _photo(0, camera)
    model = make_model(photo, camera)
    assert model.extent == pytest.approx(_outline_extent(cloth), abs=2 * PIXEL)


def test_specks_are_removed_and_objects_selected_by_option():
    cloth, photo, background = _photo(0)
    photo = photo.copy()
    cv2.circle(photo, (20 + 20, 30 + 20), 2, (30, 30, 210), -1)  # a speck: 2 px radius
    cv2.rectangle(photo, (560, 380), (613, 433), (30, 30, 210), -1)  # a 3 x 3 cm second object
    single = make_model(photo, MODEL_CAMERA, background)
    assert single.metadata["area_m2"] == pytest.approx(cloth.area, rel=0.02)
    both = make_model(photo, MODEL_CAMERA, background, ModelSettings(largest_object_only=False))
    assert both.metadata["objects"] == 2
    assert both.metadata["area_m2"] == pytest.approx(cloth.area + (54 * PIXEL) ** 2, rel=0.02)


def test_made_model_round_trips_through_its_file(tmp_path):
    _, photo, background = _photo(5)
    model = make_model(photo, MODEL_CAMERA, background, name="dots", sources={"photo": "p.png"})
    model.save(tmp_path / "dots.npz")
    assert ClothModel.load(tmp_path / "dots.npz") == model


def test_a_photo_without_cloth_is_a_model_error():
    _, _, background = _photo(0)
    with pytest.raises(ModelError) as empty:
        make_model(background, MODEL_CAMERA)
    assert empty.value.key == "photo" and empty.value.value < ModelSettings().min_object_area


def test_a_non_uniform_background_is_a_model_error():
    _, photo, _ = _photo(0)
    photo = photo.copy()
    photo[:, 320:] = (200, 60, 40)  # half the sheet is blue
    with pytest.raises(ModelError) as two_hues:
        make_model(photo, MODEL_CAMERA)
    assert two_hues.value.key == "photo"  # its border is the sheet
    assert two_hues.value.value == pytest.approx(0.5, abs=0.1)  # the share near the sheet's hue
    grey = np.full_like(photo, 128)
    with pytest.raises(ModelError) as colourless:
        make_model(photo, MODEL_CAMERA, grey)
    assert (colourless.value.key, colourless.value.value) == ("background", 0.0)  # nothing saturated


def test_bad_images_are_input_errors(tmp_path):
    _, photo, _ = _photo(0)
    with pytest.raises(InputError) as size:
        make_model(photo[:200], MODEL_CAMERA)
    assert (size.value.key, size.value.value) == ("photo", (640, 200))
    with pytest.raises(InputError) as dtype:
        make_model(photo, MODEL_CAMERA, photo.astype(float))
    assert (dtype.value.key, dtype.value.value) == ("background", ((480, 640, 3), "float64"))
    (tmp_path / "bad.png").write_bytes(b"not a png")
    with pytest.raises(InputError) as unreadable:
        load_photo(tmp_path / "bad.png")
    assert unreadable.value.path == tmp_path / "bad.png"
    with pytest.raises(InputError) as missing:
        load_photo(tmp_path / "missing.png")
    assert missing.value.path == tmp_path / "missing.png"


def test_settings_are_validated():
    with pytest.raises(ValueError, match="point_spacing"):
        ModelSettings(point_spacing=-1.0)
