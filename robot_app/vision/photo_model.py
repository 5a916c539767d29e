"""The cloth model made from one photo (paper Sec. II-B, Fig. 4): S_in, S_out and hues.

A photo of the cloth lying flat on a green sheet, taken by the model camera at a known
distance (Fig. 7, paper: 400 mm), becomes a set of points in metres on the cloth plane:
S_in, the pixels whose hue differs from the average background hue H̄_B, each with its
hue, and S_out, a band enveloping S_in that must look like background. Points are in
Σ_M (docs/architecture.md): origin at the centroid of S_in, x along the photo's image x, y along
its image y, z = 0 on the cloth plane.
"""

from __future__ import annotations

import json
import os
import zipfile
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import cv2
import numpy as np
import numpy.typing as npt
from pydantic import Field, field_validator

from robot_app.arrays import FloatArray
from robot_app.config import StrictModel
from robot_app.errors import InputError, ModelError
from robot_app.geometry import rotation_about_z
from robot_app.input_files import read_image, require_input_file
from robot_app.vision.camera import ModelCamera, PinholeCamera
from robot_app.vision.hue import (
    COLOUR_CODES,
    HUE_RANGE,
    circular_mean_hue,
    colour_codes,
    colours_match,
    hue_distance,
    to_hsv,
)
from robot_app.vision.sampling import sample_model

Image = npt.NDArray[np.uint8]

MODEL_FORMAT = "robot_app.cloth_model"
# 2: hues_in may hold the tones DARK / LIGHT (uint16). 3: the model photo's texture (a crop
# of the photo around the cloth, its mask and the map from Σ_M to its pixels) and the sheet's
# colour in the photo, for the verify stage and the exposure reference. Versions 1-2 load
# too, without texture: the verification then has no appearance to compare.
MODEL_VERSION = 3
_READABLE_VERSIONS = (1, 2, 3)
_TEXTURE_MARGIN_PX = 4  # photo pixels kept around the cloth's bounding box


def _frozen_points(array: npt.ArrayLike, name: str) -> FloatArray:
    a = np.array(array, dtype=float)
    if a.ndim != 2 or a.shape[1] != 3 or not np.all(np.isfinite(a)):
        raise ModelError(f"{name} must be a finite (N, 3) array [m], got shape {a.shape}")
    a.setflags(write=False)
    return a


@dataclass(frozen=True)
class ClothModel:
    """A photo model of one cloth, in its model frame Σ_M.

    Attributes:
        name: the cloth's name (free text).
        points_in: (N_in, 3) sampled S_in [m] in Σ_M, z = 0.
        hues_in: (N_in,) model colour code of each S_in point: its hue (HSV_FULL, 0-255),
            or `hue.DARK` (256) / `hue.LIGHT` (257) for a point without hue (black, white).
        points_out: (N_out, 3) sampled S_out band [m] in Σ_M, z = 0.
        background_hue: H̄_B, the average background hue (HSV_FULL, 0-255).
        grasp_point: (3,) [m] in Σ_M, the maximum of the distance transform of S_in.
        extent: size of S_in's bounding box along x and y [m].
        symmetry_angles: yaw angles [rad] other than 0 under which S_in and its hues
            look the same (e.g. (pi,) for a plain rectangle).
        metadata: photo size, metres per pixel, settings used, source file names.
        weights_in: (N_in,) area each S_in point stands for, in units of one interior
            grid cell (ones for the paper's uniform grid; smaller for the dense rings of
            edge sampling, so the fitness stays an area integral and a partly hidden
            cloth does not pull the dense outline onto its visible part).
        weights_out: (N_out,) the same for S_out.
        texture_bgr: (h, w, 3) uint8 the model photo around the cloth (undistorted), or
            None (a version 1-2 file).
        texture_mask: (h, w) bool, the cloth's S_in in `texture_bgr`.
        texture_from_model: (2, 3) affine map of Σ_M (x, y) [m] to `texture_bgr` pixel
            (u, v) (pixel centres at integers).
        sheet_bgr: (3,) median colour (b, g, r) of the green sheet in the model photo, the
            exposure reference (`exposure.sheet_gains`), or None.
    """

    name: str
    points_in: FloatArray
    hues_in: npt.NDArray[np.uint16]
    points_out: FloatArray
    background_hue: float
    grasp_point: FloatArray
    extent: tuple[float, float]
    symmetry_angles: tuple[float, ...] = ()
    metadata: dict[str, Any] = field(default_factory=dict)
    weights_in: FloatArray | None = None
    weights_out: FloatArray | None = None
    texture_bgr: npt.NDArray[np.uint8] | None = None
    texture_mask: npt.NDArray[np.bool_] | None = None
    texture_from_model: FloatArray | None = None
    sheet_bgr: FloatArray | None = None

    def __post_init__(self) -> None:
        points_in = _frozen_points(self.points_in, "points_in")
        points_out = _frozen_points(self.points_out, "points_out")
        if len(points_in) == 0:
            raise ModelError("a cloth model needs at least one S_in point")
        hues = np.array(self.hues_in)
        in_range = hues.size == 0 or 0 <= hues.min() <= hues.max() < COLOUR_CODES
        if hues.shape != (len(points_in),) or not in_range:
            raise ModelError(
                f"hues_in must be {len(points_in)} colour codes in 0-{COLOUR_CODES - 1}, "
                f"got shape {hues.shape}"
            )
        hues = hues.astype(np.uint16)
        hues.setflags(write=False)
        grasp = np.array(self.grasp_point, dtype=float).reshape(-1)
        if grasp.shape != (3,) or not np.all(np.isfinite(grasp)):
            raise ModelError(f"grasp_point must be a finite 3-vector [m], got {grasp.tolist()}")
        grasp.setflags(write=False)
        background = float(self.background_hue)
        if not 0.0 <= background < 256.0:
            raise ModelError(f"background_hue must be in [0, 256), got {background}")
        extent = tuple(float(v) for v in self.extent)
        if len(extent) != 2 or min(extent) < 0:
            raise ModelError(f"extent must be two non-negative lengths [m], got {self.extent}")
        object.__setattr__(self, "points_in", points_in)
        object.__setattr__(self, "points_out", points_out)
        object.__setattr__(self, "hues_in", hues)
        object.__setattr__(self, "grasp_point", grasp)
        object.__setattr__(self, "background_hue", background)
        object.__setattr__(self, "extent", extent)
        object.__setattr__(self, "symmetry_angles", tuple(float(a) for a in self.symmetry_angles))
        object.__setattr__(self, "metadata", dict(self.metadata))
        for name, n in (("weights_in", len(points_in)), ("weights_out", len(points_out))):
            value = getattr(self, name)
            weights = np.ones(n) if value is None else np.array(value, dtype=float).reshape(-1)
            if weights.shape != (n,) or not np.all(np.isfinite(weights)) or np.any(weights <= 0):
                raise ModelError(f"{name} must be {n} positive weights, got shape {weights.shape}")
            weights.setflags(write=False)
            object.__setattr__(self, name, weights)
        self._check_texture()

    def _check_texture(self) -> None:
        parts = (self.texture_bgr, self.texture_mask, self.texture_from_model)
        if all(p is None for p in parts):
            object.__setattr__(self, "texture_mask", None)
        elif any(p is None for p in parts):
            raise ModelError("texture_bgr, texture_mask and texture_from_model come together (or none)")
        else:
            texture = np.array(self.texture_bgr)
            mask = np.array(self.texture_mask, dtype=bool)
            affine = np.array(self.texture_from_model, dtype=float)
            if texture.ndim != 3 or texture.shape[2] != 3 or texture.dtype != np.uint8:
                raise ModelError(f"texture_bgr must be (h, w, 3) uint8, got {texture.shape} {texture.dtype}")
            if mask.shape != texture.shape[:2] or not mask.any():
                raise ModelError(f"texture_mask must be a non-empty (h, w) mask of shape {texture.shape[:2]}")
            if affine.shape != (2, 3) or not np.all(np.isfinite(affine)):
                raise ModelError(f"texture_from_model must be a finite 2x3 affine map, got {affine.shape}")
            for name, array in (
                ("texture_bgr", texture),
                ("texture_mask", mask),
                ("texture_from_model", affine),
            ):
                array.setflags(write=False)
                object.__setattr__(self, name, array)
        if self.sheet_bgr is not None:
            sheet = np.array(self.sheet_bgr, dtype=float).reshape(-1)
            if sheet.shape != (3,) or not np.all((sheet > 0) & (sheet <= 255)):
                raise ModelError(f"sheet_bgr must be three channel values in (0, 255], got {sheet.tolist()}")
            sheet.setflags(write=False)
            object.__setattr__(self, "sheet_bgr", sheet)

    @property
    def has_texture(self) -> bool:
        """The model keeps its photo's texture (version 3), so it can be verified by appearance."""
        return self.texture_bgr is not None

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, ClothModel):
            return NotImplemented
        arrays = ("points_in", "hues_in", "points_out", "grasp_point", "weights_in", "weights_out",
                  "texture_bgr", "texture_mask", "texture_from_model", "sheet_bgr")  # fmt: skip
        same = all(
            (getattr(self, a) is None and getattr(other, a) is None)
            or (
                getattr(self, a) is not None
                and getattr(other, a) is not None
                and np.array_equal(getattr(self, a), getattr(other, a))
            )
            for a in arrays
        )
        return same and (
            self.name,
            self.background_hue,
            self.extent,
            self.symmetry_angles,
            self.metadata,
        ) == (other.name, other.background_hue, other.extent, other.symmetry_angles, other.metadata)

    __hash__ = None  # type: ignore[assignment]  # holds arrays: not hashable

    @property
    def n_in(self) -> int:
        """Number of S_in points."""
        return len(self.points_in)

    @property
    def n_out(self) -> int:
        """Number of S_out points."""
        return len(self.points_out)

    def save(self, path: str | Path) -> None:
        """Writes the model as one `.npz` (format tag + version) atomically (a temporary
        file in the same folder, then renamed); `load` reads it back equal."""
        header = {
            "format": MODEL_FORMAT,
            "version": MODEL_VERSION,
            "name": self.name,
            "background_hue": self.background_hue,
            "extent": list(self.extent),
            "symmetry_angles": list(self.symmetry_angles),
            "metadata": self.metadata,
            "sheet_bgr": None if self.sheet_bgr is None else [float(v) for v in self.sheet_bgr],
        }
        texture: dict[str, npt.NDArray[Any]] = {}
        if self.texture_bgr is not None:
            texture = {
                "texture_bgr": np.asarray(self.texture_bgr),
                "texture_mask": np.asarray(self.texture_mask),
                "texture_from_model": np.asarray(self.texture_from_model),
            }
        try:
            header_json = json.dumps(header)
        except (TypeError, ValueError) as err:
            raise ModelError(f"model metadata must be JSON-serialisable: {err}") from err
        target = Path(path)
        temporary = target.with_name(f".{target.name}.partial")
        try:
            self._write(temporary, header_json, texture)
            os.replace(temporary, target)
        except BaseException:
            temporary.unlink(missing_ok=True)
            raise

    def _write(self, file_path: Path, header_json: str, texture: dict[str, npt.NDArray[Any]]) -> None:
        with file_path.open("wb") as file:
            np.savez_compressed(
                file,
                header=np.array(header_json),
                points_in=self.points_in,
                hues_in=self.hues_in,
                points_out=self.points_out,
                grasp_point=self.grasp_point,
                weights_in=np.asarray(self.weights_in),
                weights_out=np.asarray(self.weights_out),
                **texture,  # type: ignore[arg-type]  # numpy's stub types the keywords as allow_pickle
            )

    @classmethod
    def load(cls, path: str | Path) -> ClothModel:
        """Reads a model written by `save`.

        Raises:
            InputError: the file does not exist.
            ModelError: the file is not a robot_app cloth model of a known version.
        """
        file = require_input_file(path, "cloth model")
        try:
            with np.load(file, allow_pickle=False) as data:
                arrays = {key: data[key] for key in data.files}
        except (OSError, ValueError, zipfile.BadZipFile, EOFError) as err:
            raise ModelError(
                f"{file} is not a cloth model (.npz written by 'model make')", path=file
            ) from err
        if not isinstance(arrays, dict) or "header" not in arrays:
            raise ModelError(f"{file} is not a cloth model: no '{MODEL_FORMAT}' header", path=file)
        try:
            header = json.loads(str(arrays["header"]))
        except json.JSONDecodeError as err:
            raise ModelError(f"{file} is not a cloth model: unreadable header", path=file) from err
        if not isinstance(header, dict) or header.get("format") != MODEL_FORMAT:
            raise ModelError(f"{file} is not a cloth model: format tag is not '{MODEL_FORMAT}'", path=file)
        if header.get("version") not in _READABLE_VERSIONS:
            raise ModelError(
                f"{file}: cloth model version {header.get('version')} is not supported "
                f"(this robot_app reads versions {', '.join(map(str, _READABLE_VERSIONS))})"
            )
        missing = {"points_in", "hues_in", "points_out", "grasp_point"} - arrays.keys()
        if missing:
            raise ModelError(f"{file}: cloth model lacks arrays {sorted(missing)}", path=file)
        try:
            return cls(
                name=str(header["name"]),
                points_in=arrays["points_in"],
                hues_in=arrays["hues_in"],
                points_out=arrays["points_out"],
                background_hue=float(header["background_hue"]),
                grasp_point=arrays["grasp_point"],
                extent=tuple(header["extent"]),
                symmetry_angles=tuple(header["symmetry_angles"]),
                metadata=header["metadata"],
                weights_in=arrays.get("weights_in"),  # absent in files of older builds: ones
                weights_out=arrays.get("weights_out"),
                texture_bgr=arrays.get("texture_bgr"),  # version 3
                texture_mask=arrays.get("texture_mask"),
                texture_from_model=arrays.get("texture_from_model"),
                sheet_bgr=header.get("sheet_bgr"),
            )
        except (KeyError, TypeError, ValueError) as err:
            raise ModelError(f"{file}: malformed cloth model: {err}", path=file) from err


class ModelSettings(StrictModel):
    """How a photo becomes a model (paper Sec. II-B).

    Pixels whose saturation is below `min_saturation`, or whose value is below
    `min_value`, have no meaningful hue (white, grey, black): they belong to the cloth's
    outline (the sheet is saturated green), so S_out stays outside the whole cloth. With
    `tones` (beyond the paper) they are sampled into S_in with a tone, DARK (value below
    `value_split`) or LIGHT, that the fitness matches against pixels of the same tone
    (its `FitnessSettings.min_saturation` etc. should be the same); without, they carry no
    sample, as in the paper's hue-only model, and a cloth's black or white parts add
    nothing to its fitness: a yellow-black check cloth then scored 0.83 at its true pose
    in the simulator, and a maroon cloth with white dots matched itself half-turned.

    Where the points go is `sampling` (see `robot_app.vision.sampling`): "edge" (rings
    along the outline at `edge_offsets` inside and `band_rings` rings from `band_gap` to
    `band_gap + band_width` outside, every `edge_spacing`, plus the interior on a
    `point_spacing` grid) or "grid" (the paper's uniform grid and band).
    """

    sampling: Literal["edge", "grid"] = "edge"
    point_spacing: float = Field(0.008, gt=0.0005, le=0.05, description="S_in (interior) grid step [m]")
    edge_spacing: float = Field(0.004, gt=0.0005, le=0.05, description="step along the edge rings [m]")
    edge_offsets: tuple[float, ...] = Field(
        (0.001, 0.004), min_length=1, description="S_in rings inside the outline [m]"
    )
    band_rings: int = Field(2, ge=1, le=10, description="S_out rings from band_gap to band_gap+band_width")
    band_width: float = Field(0.008, ge=0.0, le=0.1, description="width of the S_out band [m]")
    band_gap: float = Field(0.001, ge=0.0, le=0.05, description="outline to the first S_out ring [m]")
    min_hue_difference: int = Field(30, gt=0, lt=128, description="cloth vs background hue [0-255]")
    min_saturation: int = Field(40, ge=0, lt=255, description="below this, hue is undefined [0-255]")
    min_value: int = Field(40, ge=0, lt=255, description="below this too (dark pixels) [0-255]")
    value_split: int = Field(128, ge=1, le=255, description="DARK below, LIGHT from here [0-255]")
    tones: bool = True
    colour_edge_gap: float = Field(
        0.001, ge=0.0, le=0.01, description="S_in samples this near another colour are dropped [m]"
    )
    speckle_size: float = Field(0.003, ge=0.0, le=0.05, description="specks smaller are removed [m]")
    min_object_area: float = Field(1e-4, gt=0.0, description="smallest cloth area kept [m²]")
    largest_object_only: bool = True
    fill_holes: bool = True
    min_background_agreement: float = Field(
        0.9, gt=0.5, le=1.0, description="share of background pixels within the hue threshold"
    )
    symmetry_agreement: float = Field(0.9, gt=0.5, le=1.0, description="self-overlap to call a yaw symmetric")
    symmetry_texture: float = Field(
        0.7, gt=0.0, le=1.0, description="and the photo's lightness correlation with itself turned (textured)"
    )

    @field_validator("edge_offsets")
    @classmethod
    def _offsets_inside(cls, offsets: tuple[float, ...]) -> tuple[float, ...]:
        if any(not 0.0 < d <= 0.05 for d in offsets):
            raise ValueError("edge_offsets must be distances in (0, 0.05] m inside the outline")
        return offsets


def load_photo(path: str | Path) -> Image:
    """Reads a colour image file as (H, W, 3) uint8 BGR.

    Raises:
        InputError: missing, a folder, or not a readable image.
        ResourceError: too large for the default memory limit.
    """
    return read_image(path).bgr  # header and size checked first; libpng warnings kept quiet


def make_model(
    photo_bgr: Image,
    model_camera: ModelCamera,
    background_bgr: Image | None = None,
    settings: ModelSettings | None = None,
    name: str = "cloth",
    *,
    sources: Mapping[str, str] | None = None,
) -> ClothModel:
    """Makes a cloth model from a photo of the cloth lying on a uniform (green) sheet.

    Args:
        photo_bgr: (H, W, 3) uint8 photo from `model_camera` (Fig. 4 b).
        model_camera: its intrinsics and distance to the sheet [m].
        background_bgr: optional photo of the empty sheet (Fig. 4 a); without it the
            background hue is estimated from the photo's border.
        settings: sampling and segmentation settings (defaults if None).
        name: the model's name.
        sources: file names to record in the metadata (photo, background, camera).

    Raises:
        InputError: an image of the wrong type or size for the camera.
        ModelError: a background that is not uniform or not coloured, or no cloth.
    """
    settings = ModelSettings() if settings is None else settings
    camera = model_camera.camera
    hsv = _checked_hsv(photo_bgr, camera, "photo")
    if background_bgr is not None:
        background_hsv = _checked_hsv(background_bgr, camera, "background photo")
        H_B, agreement = _background_hue(background_hsv.reshape(-1, 3), settings, "background photo")
    else:
        H_B, agreement = _background_hue(_border(hsv), settings, "photo border")
    metric = _metric_grid(camera, model_camera.distance)  # (H, W, 2) photo plane [m]
    metres_per_pixel = model_camera.distance / float(camera.camera_matrix[0, 0])
    mask, n_objects = _cloth_mask(hsv, H_B, settings, metres_per_pixel)  # S_in of Fig. 4 (c)
    origin = metric[mask].mean(axis=0)  # Σ_M origin: centroid of S_in [m]
    xy = metric[mask] - origin
    extent = (float(np.ptp(xy[:, 0]) + metres_per_pixel), float(np.ptp(xy[:, 1]) + metres_per_pixel))

    smooth = to_hsv(
        np.asarray(cv2.GaussianBlur(np.ascontiguousarray(photo_bgr), (0, 0), 1.0), dtype=np.uint8)
    )
    samples = sample_model(mask, smooth, camera, model_camera.distance, origin, settings, H_B)
    if len(samples.points_in) < 3:
        raise ModelError(
            f"the cloth has only {len(samples.points_in)} sample points at point_spacing="
            f"{settings.point_spacing} m; use a smaller point_spacing or a larger cloth"
        )
    points_in = np.column_stack([samples.points_in, np.zeros(len(samples.points_in))])
    hues_in = samples.hues_in
    points_out = np.column_stack([samples.points_out, np.zeros(len(samples.points_out))])
    inside_px = cv2.distanceTransform(mask.astype(np.uint8), cv2.DIST_L2, 5)
    deepest = inside_px >= inside_px.max() - 1.0  # on a ridge, the point nearest the centroid
    grasp_xy = metric[deepest][np.argmin(np.linalg.norm(metric[deepest] - origin, axis=1))] - origin
    grasp = np.append(grasp_xy, 0.0)
    metadata = {
        "photo_size": [camera.width, camera.height],
        "metres_per_pixel": metres_per_pixel,
        "model_camera": model_camera.to_dict(),
        "origin_in_photo_plane": origin.tolist(),  # Σ_M origin in the photo camera's plane [m]
        "background": "background photo" if background_bgr is not None else "photo border",
        "background_agreement": agreement,
        "objects": n_objects,
        "area_m2": float(mask.sum() * metres_per_pixel**2),
        "settings": settings.model_dump(mode="json"),
        "sources": dict(sources or {}),
    }
    grid = np.column_stack([samples.grid_in, np.zeros(len(samples.grid_in))])
    lightness = cv2.GaussianBlur(
        cv2.cvtColor(np.ascontiguousarray(photo_bgr), cv2.COLOR_BGR2GRAY), (0, 0), 2.0
    )

    def lightness_at(points: FloatArray) -> FloatArray:
        u, v = _to_pixel_index(camera, model_camera.distance, points[:, :2] + origin)
        u, v = np.clip(u, 0, camera.width - 1), np.clip(v, 0, camera.height - 1)
        return np.asarray(lightness[v, u], dtype=float)

    symmetry = _symmetry_angles(grid, samples.grid_hues, settings.point_spacing, settings, lightness_at)
    texture, texture_mask, texture_from_model = _texture(
        photo_bgr, mask, camera, model_camera.distance, origin
    )
    sheet = _sheet_colour(photo_bgr, hsv, mask, H_B, settings)
    return ClothModel(
        name,
        points_in,
        hues_in,
        points_out,
        H_B,
        grasp,
        extent,
        symmetry,
        metadata,
        weights_in=samples.weights_in,
        weights_out=samples.weights_out,
        texture_bgr=texture,
        texture_mask=texture_mask,
        texture_from_model=texture_from_model,
        sheet_bgr=sheet,
    )


def _texture(
    photo_bgr: Image, mask: npt.NDArray[np.bool_], camera: PinholeCamera, distance: float, origin: FloatArray
) -> tuple[Image, npt.NDArray[np.bool_], FloatArray]:
    """The photo (undistorted) cropped around the cloth, its mask there and the affine map
    of Σ_M (x, y) [m] to the crop's pixels."""
    K = camera.camera_matrix
    photo = np.ascontiguousarray(photo_bgr)
    if camera.has_distortion:
        photo = np.asarray(cv2.undistort(photo, K, camera.dist_coeffs, None, K), dtype=np.uint8)
        mask = cv2.undistort(mask.astype(np.uint8), K, camera.dist_coeffs, None, K).astype(bool)
    rows, cols = np.nonzero(mask)
    m = _TEXTURE_MARGIN_PX
    v0, v1 = max(int(rows.min()) - m, 0), min(int(rows.max()) + m + 1, camera.height)
    u0, u1 = max(int(cols.min()) - m, 0), min(int(cols.max()) + m + 1, camera.width)
    fx, fy = K[0, 0] / distance, K[1, 1] / distance  # [px/m] on the cloth plane
    affine = np.array([[fx, 0.0, fx * origin[0] + K[0, 2] - u0], [0.0, fy, fy * origin[1] + K[1, 2] - v0]])
    return photo[v0:v1, u0:u1].copy(), mask[v0:v1, u0:u1].copy(), affine


def _sheet_colour(
    photo_bgr: Image, hsv: Image, mask: npt.NDArray[np.bool_], H_B: float, settings: ModelSettings
) -> FloatArray:
    """Median (b, g, r) of the sheet in the photo: saturated background-hued pixels away
    from the cloth."""
    near = cv2.dilate(mask.astype(np.uint8), np.ones((9, 9), np.uint8)).astype(bool)
    sheet = (
        ~near
        & (hsv[..., 1] >= settings.min_saturation)
        & (hue_distance(hsv[..., 0], H_B) <= settings.min_hue_difference // 2)
    )
    return np.maximum(np.median(np.asarray(photo_bgr)[sheet].reshape(-1, 3), axis=0), 1.0).astype(float)


def _checked_hsv(image: Image, camera: PinholeCamera, what: str) -> Image:
    array = np.asarray(image)
    if array.ndim != 3 or array.shape[2] != 3 or array.dtype != np.uint8:
        raise InputError(f"{what} must be an (H, W, 3) uint8 colour image, got {array.shape} {array.dtype}")
    if array.shape[:2] != (camera.height, camera.width):
        raise InputError(
            f"{what} is {array.shape[1]}x{array.shape[0]} px but the camera file says "
            f"{camera.width}x{camera.height}"
        )
    return to_hsv(np.ascontiguousarray(array))


def _border(hsv: Image) -> Image:
    """Pixels of a strip along the four edges (4 % of the short side), (N, 3)."""
    w = max(2, round(0.04 * min(hsv.shape[:2])))
    return np.concatenate([hsv[:w].reshape(-1, 3), hsv[-w:].reshape(-1, 3),
                           hsv[w:-w, :w].reshape(-1, 3), hsv[w:-w, -w:].reshape(-1, 3)])  # fmt: skip


def _background_hue(pixels_hsv: Image, settings: ModelSettings, what: str) -> tuple[float, float]:
    """Robust average background hue H̄_B: circular mean around the hue histogram's mode."""
    saturated = pixels_hsv[:, 1] >= settings.min_saturation
    if saturated.mean() < settings.min_background_agreement:
        raise ModelError(
            f"the {what} is not a coloured sheet: only {saturated.mean():.0%} of its pixels have "
            f"saturation >= {settings.min_saturation}; use a uniform green sheet as in Fig. 7"
        )
    hues = pixels_hsv[saturated, 0]
    histogram = np.bincount(hues, minlength=256).astype(float)
    histogram = np.convolve(np.concatenate([histogram[-8:], histogram, histogram[:8]]), np.ones(17), "valid")
    mode = int(np.argmax(histogram))
    near = hues[hue_distance(hues, mode) <= settings.min_hue_difference // 2]
    H_B = circular_mean_hue(near)
    agreement = float(
        np.mean(hue_distance(pixels_hsv[:, 0], H_B) <= settings.min_hue_difference / 2) * saturated.mean()
    )
    if agreement < settings.min_background_agreement:
        raise ModelError(
            f"the {what} is not uniform: only {agreement:.0%} of it is within "
            f"{settings.min_hue_difference // 2} of its average hue {H_B:.0f}; needs "
            f">= {settings.min_background_agreement:.0%} (a plain sheet, no other objects)"
        )
    return H_B, agreement


def _cloth_mask(
    hsv: Image, H_B: float, settings: ModelSettings, metres_per_pixel: float
) -> tuple[npt.NDArray[np.bool_], int]:
    """S_in in the photo: not the sheet, specks removed, objects selected, holes filled.

    A pixel is cloth if its hue is far from H̄_B, or if it has no hue at all (white,
    grey, black: the sheet is verified to be saturated): a white stripe is part of the
    cloth's outline (and with `tones`, carries a DARK or LIGHT sample).
    """
    codes = colour_codes(hsv, settings.min_saturation, settings.min_value, settings.value_split)
    differs = (codes >= HUE_RANGE) | (hue_distance(codes, H_B) > settings.min_hue_difference)
    mask = differs.astype(np.uint8)
    speck = round(settings.speckle_size / metres_per_pixel)
    if speck >= 2:
        kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (speck, speck))
        opened = cv2.morphologyEx(mask, cv2.MORPH_OPEN, kernel)
        mask = np.asarray(cv2.morphologyEx(opened, cv2.MORPH_CLOSE, kernel), dtype=np.uint8)
    _, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
    areas = stats[1:, cv2.CC_STAT_AREA] * metres_per_pixel**2
    keep = np.flatnonzero(areas >= settings.min_object_area) + 1
    if keep.size == 0:
        largest = float(areas.max()) if areas.size else 0.0
        raise ModelError(
            f"no cloth in the photo: no region with hue > {settings.min_hue_difference} away from the "
            f"background ({H_B:.0f}) is larger than {settings.min_object_area * 1e4:.2f} cm² "
            f"(largest: {largest * 1e4:.2f} cm²)"
        )
    if settings.largest_object_only:
        keep = keep[[int(np.argmax(stats[keep, cv2.CC_STAT_AREA]))]]
    mask = np.isin(labels, keep).astype(np.uint8)
    if settings.fill_holes:
        contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
        mask = np.asarray(
            cv2.drawContours(np.zeros_like(mask), contours, -1, 1, thickness=cv2.FILLED), dtype=np.uint8
        )
    edge = np.concatenate([mask[0], mask[-1], mask[:, 0], mask[:, -1]])
    if edge.any():
        raise ModelError("the cloth touches the photo's border, so its outline is cut: centre it in the view")
    return mask.astype(bool), int(keep.size)


def _metric_grid(camera: PinholeCamera, distance: float) -> FloatArray:
    """(H, W, 2) position of every pixel centre on the photo plane [m] (undistorted)."""
    u, v = np.meshgrid(np.arange(camera.width, dtype=float), np.arange(camera.height, dtype=float))
    K = camera.camera_matrix
    if camera.has_distortion:
        pixels = np.stack([u, v], axis=-1).reshape(-1, 1, 2)
        criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 40, 1e-10)
        normal = cv2.undistortPoints(pixels, K, camera.dist_coeffs, criteria=criteria)
        return np.asarray(normal.reshape(camera.height, camera.width, 2) * distance, dtype=float)
    return np.stack([(u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1]], axis=-1) * distance


def _to_pixel_index(
    camera: PinholeCamera, distance: float, xy: FloatArray
) -> tuple[npt.NDArray[np.intp], npt.NDArray[np.intp]]:
    """Nearest pixel of points on the photo plane (may be outside the image)."""
    pixels = camera.project(np.column_stack([xy, np.full(len(xy), distance)]))
    return np.rint(pixels[:, 0]).astype(np.intp), np.rint(pixels[:, 1]).astype(np.intp)


def _symmetry_angles(
    points: FloatArray,
    hues: npt.NDArray[np.uint16],
    step: float,
    settings: ModelSettings,
    lightness_at: Callable[[FloatArray], FloatArray] | None = None,
) -> tuple[float, ...]:
    """Yaws k·π/4 (k = 1..7) under which S_in and its colours map onto themselves and, where
    the photo is textured (lightness deviation of at least 6 grey levels), its lightness
    correlates with itself turned by at least `symmetry_texture`: a print of nearly one
    hue on an ellipse is not symmetric under a half turn, its picture tells the two apart."""
    cells = {(int(i), int(j)): h for (i, j), h in zip(np.rint(points[:, :2] / step), hues, strict=True)}
    own = lightness_at(points) if lightness_at is not None else None
    textured = own is not None and float(np.std(own)) >= 6.0
    angles = []
    for k in range(1, 8):
        angle = k * np.pi / 4
        rotated = points @ rotation_about_z(angle).T
        hits = 0
        for (i, j), hue in zip(np.rint(rotated[:, :2] / step).astype(int), hues, strict=True):
            other = cells.get((int(i), int(j)))
            hits += int(other is not None and bool(colours_match(hue, other, settings.min_hue_difference)))
        if hits < settings.symmetry_agreement * len(points):
            continue
        if textured and own is not None and lightness_at is not None:
            turned = lightness_at(rotated)  # the lightness that lands on each point when turned
            if float(np.corrcoef(own, turned)[0, 1]) < settings.symmetry_texture:
                continue
        angles.append(float(angle))
    return tuple(angles)


__all__ = ["MODEL_FORMAT", "MODEL_VERSION", "ClothModel", "ModelSettings", "load_photo", "make_model"]
