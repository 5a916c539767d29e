"""Where a trial's images come from: the synthetic renderer or the pybullet world.

Both sources give the same things: the stereo rig, a photo model of each catalogue
cloth made by `make_model` from a rendered Fig. 7 photo, and a rendered stereo pair of
a `SceneSample` with the ground-truth pose ^CR T_M of each cloth in it. A source is
heavy (models, a pybullet client), so each process builds it once (`image_source`).

- `synthetic`: flat textured cloths drawn exactly at their poses (numpy + OpenCV);
  fast, exact ground truth, no wrinkles.
- `sim`: the pybullet cell at the observation pose; soft cloths dropped and settled,
  ground truth from the Kabsch fit of their nodes.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Protocol

import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray
from robot_app.errors import ConfigError
from robot_app.experiments.scenes import OBSERVATION_DEPTH, SceneSample
from robot_app.geometry import make_transform
from robot_app.vision.camera import ModelCamera, PinholeCamera, StereoRig
from robot_app.vision.photo_model import ClothModel, make_model

Image = npt.NDArray[np.uint8]

IMAGE_SIZE = (640, 480)
"""Hand and model cameras' resolution [px] (as the simulated cameras)."""

HFOV_DEG = 48.0
"""Horizontal field of view of the cameras [deg]."""

BASELINE = 0.10
"""Distance between the hand cameras [m] (urdf/pa10.urdf)."""

MODEL_DISTANCE = 0.40
"""Model camera to the model-creating plane [m] (paper Fig. 7)."""


@dataclass(frozen=True)
class RenderedScene:
    """A stereo pair and the truth behind it.

    Attributes:
        left_bgr: (H, W, 3) uint8 left image.
        right_bgr: (H, W, 3) uint8 right image.
        transform_target_to_right: ^CR T_M of the target, None if absent.
        transform_distractor_to_right: ^CR T_M of the distractor, None if none.
    """

    left_bgr: Image
    right_bgr: Image
    transform_target_to_right: FloatArray | None
    transform_distractor_to_right: FloatArray | None


class ImageSource(Protocol):
    """What a trial needs from an image source."""

    name: str
    rig: StereoRig

    def model(self, cloth_id: int) -> ClothModel:
        """The photo model of catalogue cloth No.`cloth_id` (cached)."""
        ...

    def radii(self) -> dict[int, float]:
        """Circumscribed radius [m] of each catalogue cloth."""
        ...

    def render(self, scene: SceneSample, rng: np.random.Generator) -> RenderedScene:
        """Puts the scene on the table and renders it from the observation pose."""
        ...


def hand_rig() -> StereoRig:
    """The hand stereo rig: two ideal cameras 0.1 m apart along x, same orientation."""
    camera = PinholeCamera.from_fov(IMAGE_SIZE, np.deg2rad(HFOV_DEG))
    return StereoRig(camera, camera, make_transform(np.eye(3), [-BASELINE, 0.0, 0.0]))


def model_camera() -> ModelCamera:
    """The Fig. 7 model camera, 400 mm above the sheet."""
    return ModelCamera(PinholeCamera.from_fov(IMAGE_SIZE, np.deg2rad(HFOV_DEG)), MODEL_DISTANCE)


class SyntheticSource:
    """Flat cloths rendered exactly (robot_app.vision.synthetic); No.k is catalogue entry k-1."""

    name = "synthetic"

    def __init__(self) -> None:
        from robot_app.vision import synthetic
        from robot_app.vision.synthetic_catalogue import synthetic_cloth

        self._synthetic = synthetic
        self.rig = hand_rig()
        self._model_camera = model_camera()
        self._cloths = {k: synthetic_cloth(k - 1) for k in range(1, 13)}
        self._models: dict[int, ClothModel] = {}

    def model(self, cloth_id: int) -> ClothModel:
        if cloth_id not in self._models:
            cloth = self._cloths[cloth_id]
            photo, background = self._synthetic.render_model_photo(cloth, self._model_camera)
            self._models[cloth_id] = make_model(photo, self._model_camera, background, name=f"No.{cloth_id}")
        return self._models[cloth_id]

    def radii(self) -> dict[int, float]:
        return {k: 0.5 * float(np.hypot(*cloth.size)) for k, cloth in self._cloths.items()}

    def render(self, scene: SceneSample, rng: np.random.Generator) -> RenderedScene:
        placements = []
        truth_target = truth_distractor = None
        if scene.distractor is not None:
            truth_distractor = scene.distractor.transform_model_to_right(OBSERVATION_DEPTH)
            placements.append((self._cloths[scene.distractor.cloth_id], truth_distractor))
        occluder = None
        if scene.target is not None:
            truth_target = scene.target.transform_model_to_right(OBSERVATION_DEPTH)
            cloth = self._cloths[scene.target.cloth_id]
            placements.append((cloth, truth_target))
            if scene.occluded_fraction > 0:
                occluder = self._synthetic.occluder_covering(
                    cloth, truth_target, scene.occluded_fraction, scene.occluder_direction
                )
        left, right = self._synthetic.render_stereo_pair(self.rig, placements, occluder=occluder, rng=rng)
        return RenderedScene(left, right, truth_target, truth_distractor)


@functools.lru_cache(maxsize=2)
def image_source(name: str) -> ImageSource:
    """This process's image source `name` ("synthetic" or "sim"), built on first use."""
    if name == "synthetic":
        return SyntheticSource()
    if name == "sim":
        from robot_app.experiments.sim_source import SimSource

        return SimSource()
    raise ConfigError(f"source must be 'synthetic' or 'sim', got {name!r}")


__all__ = [
    "ImageSource",
    "RenderedScene",
    "SyntheticSource",
    "hand_rig",
    "image_source",
    "model_camera",
]
