"""The cloth model (paper Sec. II-B, Fig. 4): S_in, S_out and their colours in Σ_M, and its file.

A model is what `photo_model.make_model` makes of one photo of the cloth on a green
sheet: S_in, the cloth's points with their colour codes, S_out, a band enveloping S_in
that must look like background, the background hue H̄_B and, since version 3, the photo's
texture for the verify stage and the sheet's colour for the exposure reference. Points
are in Σ_M (docs/architecture.md): origin at the centroid of S_in, x along the photo's
image x, y along its image y, z = 0 on the cloth plane. One `.npz` holds it; `save` and
`load` round-trip.
"""

from __future__ import annotations

import json
import os
import zipfile
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray
from robot_app.errors import ModelError
from robot_app.input_files import require_input_file
from robot_app.vision.hue import COLOUR_CODES

MODEL_FORMAT = "robot_app.cloth_model"
# 2: hues_in may hold the tones DARK / LIGHT (uint16). 3: the model photo's texture (a crop
# of the photo around the cloth, its mask and the map from Σ_M to its pixels) and the sheet's
# colour in the photo, for the verify stage and the exposure reference. Versions 1-2 load
# too, without texture: the verification then has no appearance to compare.
MODEL_VERSION = 3
_READABLE_VERSIONS = (1, 2, 3)
_EXPECTED_FILE = f"a '{MODEL_FORMAT}' .npz written by 'model make'"


def _frozen_points(array: npt.ArrayLike, name: str) -> FloatArray:
    a = np.array(array, dtype=float)
    if a.ndim != 2 or a.shape[1] != 3 or not np.all(np.isfinite(a)):
        raise ModelError(
            f"{name} must be a finite (N, 3) array [m], got shape {a.shape}",
            key=name,
            value=a.shape,
            expected="a finite (N, 3) array [m]",
        )
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
            raise ModelError("a cloth model needs at least one S_in point", key="points_in", value=(0, 3))
        hues = np.array(self.hues_in)
        outside = hues[~((hues >= 0) & (hues < COLOUR_CODES))]  # NaN too
        if hues.shape != (len(points_in),) or outside.size:
            raise ModelError(
                f"hues_in must be {len(points_in)} colour codes in 0-{COLOUR_CODES - 1}, "
                f"got shape {hues.shape}",
                key="hues_in",
                value=hues.shape if hues.shape != (len(points_in),) else outside.tolist(),  # or the bad codes
                expected=f"{len(points_in)} colour codes in 0-{COLOUR_CODES - 1}",
            )
        hues = hues.astype(np.uint16)
        hues.setflags(write=False)
        grasp = np.array(self.grasp_point, dtype=float).reshape(-1)
        if grasp.shape != (3,) or not np.all(np.isfinite(grasp)):
            raise ModelError(
                f"grasp_point must be a finite 3-vector [m], got {grasp.tolist()}",
                key="grasp_point",
                value=grasp.tolist(),
            )
        grasp.setflags(write=False)
        background = float(self.background_hue)
        if not 0.0 <= background < 256.0:
            raise ModelError(
                f"background_hue must be in [0, 256), got {background}",
                key="background_hue",
                value=background,
            )
        extent = tuple(float(v) for v in self.extent)
        if len(extent) != 2 or min(extent) < 0:
            raise ModelError(
                f"extent must be two non-negative lengths [m], got {self.extent}",
                key="extent",
                value=self.extent,
            )
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
                raise ModelError(
                    f"{name} must be {n} positive weights, got shape {weights.shape}",
                    key=name,
                    value=weights.shape,
                )
            weights.setflags(write=False)
            object.__setattr__(self, name, weights)
        self._check_texture()

    def _check_texture(self) -> None:
        parts = {"texture_bgr": self.texture_bgr, "texture_mask": self.texture_mask,
                 "texture_from_model": self.texture_from_model}  # fmt: skip
        absent = [name for name, part in parts.items() if part is None]
        if len(absent) == len(parts):
            object.__setattr__(self, "texture_mask", None)
        elif absent:
            raise ModelError(
                "texture_bgr, texture_mask and texture_from_model come together (or none)", key=absent[0]
            )
        else:
            texture = np.array(self.texture_bgr)
            mask = np.array(self.texture_mask, dtype=bool)
            affine = np.array(self.texture_from_model, dtype=float)
            if texture.ndim != 3 or texture.shape[2] != 3 or texture.dtype != np.uint8:
                raise ModelError(
                    f"texture_bgr must be (h, w, 3) uint8, got {texture.shape} {texture.dtype}",
                    key="texture_bgr",
                    value=(texture.shape, str(texture.dtype)),
                )
            if mask.shape != texture.shape[:2] or not mask.any():
                raise ModelError(
                    f"texture_mask must be a non-empty (h, w) mask of shape {texture.shape[:2]}",
                    key="texture_mask",
                    value=mask.shape,
                )
            if affine.shape != (2, 3) or not np.all(np.isfinite(affine)):
                raise ModelError(
                    f"texture_from_model must be a finite 2x3 affine map, got {affine.shape}",
                    key="texture_from_model",
                    value=affine.shape,
                )
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
                raise ModelError(
                    f"sheet_bgr must be three channel values in (0, 255], got {sheet.tolist()}",
                    key="sheet_bgr",
                    value=sheet.tolist(),
                )
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

    @cached_property
    def radius(self) -> float:
        """The largest distance of a model point (S_in or S_out) from the origin of Σ_M [m]:
        computed once (the points are read-only), read by every tracking frame."""
        return float(np.max(np.linalg.norm(np.vstack([self.points_in, self.points_out]), axis=1)))

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
            raise ModelError(f"model metadata must be JSON-serialisable: {err}", key="metadata") from err
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
                f"{file} is not a cloth model (.npz written by 'model make')",
                path=file,
                expected=_EXPECTED_FILE,
            ) from err
        if not isinstance(arrays, dict) or "header" not in arrays:
            raise ModelError(
                f"{file} is not a cloth model: no '{MODEL_FORMAT}' header",
                path=file,
                key="header",
                expected=_EXPECTED_FILE,
            )
        try:
            header = json.loads(str(arrays["header"]))
        except json.JSONDecodeError as err:
            raise ModelError(
                f"{file} is not a cloth model: unreadable header",
                path=file,
                key="header",
                expected=_EXPECTED_FILE,
            ) from err
        if not isinstance(header, dict) or header.get("format") != MODEL_FORMAT:
            raise ModelError(
                f"{file} is not a cloth model: format tag is not '{MODEL_FORMAT}'",
                path=file,
                key="format",
                value=header.get("format") if isinstance(header, dict) else None,
                expected=_EXPECTED_FILE,
            )
        if header.get("version") not in _READABLE_VERSIONS:
            raise ModelError(
                f"{file}: cloth model version {header.get('version')} is not supported "
                f"(this robot_app reads versions {', '.join(map(str, _READABLE_VERSIONS))})",
                path=file,
                key="version",
                value=header.get("version"),
                expected=f"version {', '.join(map(str, _READABLE_VERSIONS))}",
            )
        missing = {"points_in", "hues_in", "points_out", "grasp_point"} - arrays.keys()
        if missing:
            raise ModelError(
                f"{file}: cloth model lacks arrays {sorted(missing)}",
                path=file,
                key=sorted(missing)[0],
                value=sorted(missing),
                expected="the arrays points_in, hues_in, points_out and grasp_point",
            )
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
        except ModelError as err:  # an array or header value the model does not accept
            given = {"value": err.value} if err.has_value else {}
            raise ModelError(
                f"{file}: {err}", path=file, key=err.key, expected=err.expected, **given
            ) from err


__all__ = ["MODEL_FORMAT", "MODEL_VERSION", "ClothModel"]
