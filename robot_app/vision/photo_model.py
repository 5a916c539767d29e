"""The cloth model made from one photo (paper Sec. II-B, Fig. 4): S_in, S_out and hues.

A photo of the cloth lying flat on a green sheet, taken by the model camera at a known
distance (Fig. 7, paper: 400 mm), becomes a set of points in metres on the cloth plane:
S_in, the pixels whose hue differs from the average background hue H̄_B, each with its
hue, and S_out, a band enveloping S_in that must look like background. Points are in
Σ_M (DESIGN.md): origin at the centroid of S_in, x along the photo's image x, y along
its image y, z = 0 on the cloth plane.
"""

from __future__ import annotations

import json
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from robot_app.errors import InputError, ModelError
from robot_app.geometry import FloatArray

MODEL_FORMAT = "robot_app.cloth_model"
MODEL_VERSION = 1


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
        hues_in: (N_in,) model hue at each S_in point (HSV_FULL, 0-255).
        points_out: (N_out, 3) sampled S_out band [m] in Σ_M, z = 0.
        background_hue: H̄_B, the average background hue (HSV_FULL, 0-255).
        grasp_point: (3,) [m] in Σ_M, the maximum of the distance transform of S_in.
        extent: size of S_in's bounding box along x and y [m].
        symmetry_angles: yaw angles [rad] other than 0 under which S_in and its hues
            look the same (e.g. (pi,) for a plain rectangle).
        metadata: photo size, metres per pixel, settings used, source file names.
    """

    name: str
    points_in: FloatArray
    hues_in: npt.NDArray[np.uint8]
    points_out: FloatArray
    background_hue: float
    grasp_point: FloatArray
    extent: tuple[float, float]
    symmetry_angles: tuple[float, ...] = ()
    metadata: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        points_in = _frozen_points(self.points_in, "points_in")
        points_out = _frozen_points(self.points_out, "points_out")
        if len(points_in) == 0:
            raise ModelError("a cloth model needs at least one S_in point")
        hues = np.array(self.hues_in)
        if hues.shape != (len(points_in),) or (hues.size and (hues.min() < 0 or hues.max() > 255)):
            raise ModelError(f"hues_in must be {len(points_in)} values in 0-255, got shape {hues.shape}")
        hues = hues.astype(np.uint8)
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

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, ClothModel):
            return NotImplemented
        arrays = ("points_in", "hues_in", "points_out", "grasp_point")
        return all(np.array_equal(getattr(self, a), getattr(other, a)) for a in arrays) and (
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
        """Writes the model as one `.npz` (format tag + version); `load` reads it back equal."""
        header = {
            "format": MODEL_FORMAT,
            "version": MODEL_VERSION,
            "name": self.name,
            "background_hue": self.background_hue,
            "extent": list(self.extent),
            "symmetry_angles": list(self.symmetry_angles),
            "metadata": self.metadata,
        }
        try:
            header_json = json.dumps(header)
        except (TypeError, ValueError) as err:
            raise ModelError(f"model metadata must be JSON-serialisable: {err}") from err
        with Path(path).open("wb") as file:
            np.savez_compressed(
                file,
                header=np.array(header_json),
                points_in=self.points_in,
                hues_in=self.hues_in,
                points_out=self.points_out,
                grasp_point=self.grasp_point,
            )

    @classmethod
    def load(cls, path: str | Path) -> ClothModel:
        """Reads a model written by `save`.

        Raises:
            InputError: the file does not exist.
            ModelError: the file is not a robot_app cloth model of a known version.
        """
        file = Path(path)
        if not file.is_file():
            raise InputError(f"cloth model file not found: {file}")
        try:
            with np.load(file, allow_pickle=False) as data:
                arrays = {key: data[key] for key in data.files}
        except (OSError, ValueError, zipfile.BadZipFile, EOFError) as err:
            raise ModelError(f"{file} is not a cloth model (.npz written by 'model make')") from err
        if not isinstance(arrays, dict) or "header" not in arrays:
            raise ModelError(f"{file} is not a cloth model: no '{MODEL_FORMAT}' header")
        try:
            header = json.loads(str(arrays["header"]))
        except json.JSONDecodeError as err:
            raise ModelError(f"{file} is not a cloth model: unreadable header") from err
        if not isinstance(header, dict) or header.get("format") != MODEL_FORMAT:
            raise ModelError(f"{file} is not a cloth model: format tag is not '{MODEL_FORMAT}'")
        if header.get("version") != MODEL_VERSION:
            raise ModelError(
                f"{file}: cloth model version {header.get('version')} is not supported "
                f"(this robot_app reads version {MODEL_VERSION})"
            )
        missing = {"points_in", "hues_in", "points_out", "grasp_point"} - arrays.keys()
        if missing:
            raise ModelError(f"{file}: cloth model lacks arrays {sorted(missing)}")
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
            )
        except (KeyError, TypeError, ValueError) as err:
            raise ModelError(f"{file}: malformed cloth model: {err}") from err


__all__ = ["MODEL_FORMAT", "MODEL_VERSION", "ClothModel"]
