"""Trial scenes: where the target, a distractor and the occluder go, drawn from a seed.

Positions are in the right camera frame at the observation pose (docs/architecture.md: Σ_CR,
x right, y down, z down to the table), so a scene means the same thing to the synthetic
renderer and to the simulator. The camera looks straight down from `depth` above the
table, and a cloth lying flat in the model photo's orientation has identity rotation
in Σ_CR; its yaw turns it about the optical axis.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from robot_app.arrays import FloatArray
from robot_app.errors import ConfigError
from robot_app.experiments.experiment_config import CLOTH_COUNT, TrialSceneSettings
from robot_app.geometry import (
    make_transform,
    rotation_about_z,
)

OBSERVATION_DEPTH = 0.58
"""Right camera to table at the observation pose [m] (paper Sec. III: z = 580 mm)."""

VIEW_HALF_EXTENT = (0.2, 0.15)
"""Half extent [m] of the table area where a distractor may go (inside the 510 x 390 mm view)."""


@dataclass(frozen=True)
class Placement:
    """One cloth on the table.

    Attributes:
        cloth_id: catalogue number No.1 - No.12.
        x: centre along the right camera's x [m].
        y: centre along the right camera's y [m].
        yaw: rotation about the optical axis [rad].
    """

    cloth_id: int
    x: float
    y: float
    yaw: float

    def transform_model_to_right(self, depth: float = OBSERVATION_DEPTH) -> FloatArray:
        """^CR T_M of the cloth lying flat `depth` [m] below the right camera."""
        return make_transform(rotation_about_z(self.yaw), [self.x, self.y, depth])


@dataclass(frozen=True)
class SceneSample:
    """One trial's scene.

    Attributes:
        target_id: the cloth to recognise (its model is searched for).
        target: where the target lies, None if it is absent from the table.
        distractor: a second cloth, or None.
        occluded_fraction: share of the target hidden by the blue sheet (0 = none).
        occluder_direction: side the sheet comes from, in Σ_M [rad].
        drop_height: height the cloths are dropped from (simulator only) [m].
    """

    target_id: int
    target: Placement | None
    distractor: Placement | None
    occluded_fraction: float
    occluder_direction: float
    drop_height: float


def _cloth_radius(cloth_id: int, radii: dict[int, float] | None) -> float:
    return 0.16 if radii is None else radii.get(cloth_id, 0.16)


def sample_scene(
    settings: TrialSceneSettings,
    scene_index: int,
    rng: np.random.Generator,
    radii: dict[int, float] | None = None,
) -> SceneSample:
    """Draws one scene from the settings.

    Args:
        settings: the config's scene section.
        scene_index: selects the target, cloth_ids[scene_index % len(cloth_ids)].
        rng: the trial's random generator.
        radii: circumscribed radius of each cloth [m], to keep a distractor clear of
            the target (default 0.16 m).

    Returns:
        The scene; the distractor never overlaps the target's circumscribed circle
        when there is room for it.
    """
    target_id = settings.cloth_ids[scene_index % len(settings.cloth_ids)]
    x = float(rng.uniform(*settings.x_range_m))
    y = float(rng.uniform(*settings.y_range_m))
    yaw = float(np.deg2rad(rng.uniform(*settings.yaw_range_deg)))
    target = Placement(target_id, x, y, yaw)
    direction = float(rng.uniform(-np.pi, np.pi))
    distractor = None
    if settings.distractor is not None:
        if settings.distractor == "random":
            others = [i for i in range(1, CLOTH_COUNT + 1) if i != target_id]
            other_id = int(others[int(rng.integers(len(others)))])
        else:
            other_id = int(settings.distractor)
        if other_id == target_id:
            raise ConfigError(f"scene.distractor must differ from the target cloth No.{target_id}")
        clearance = _cloth_radius(target_id, radii) + _cloth_radius(other_id, radii)
        best, best_gap = (0.0, 0.0), -np.inf
        for _ in range(200):
            cx = float(rng.uniform(-VIEW_HALF_EXTENT[0], VIEW_HALF_EXTENT[0]))
            cy = float(rng.uniform(-VIEW_HALF_EXTENT[1], VIEW_HALF_EXTENT[1]))
            gap = float(np.hypot(cx - x, cy - y)) - clearance
            if gap > best_gap:
                best, best_gap = (cx, cy), gap
            if gap >= 0.0:
                break
        distractor = Placement(other_id, best[0], best[1], float(rng.uniform(-np.pi, np.pi)))
    return SceneSample(
        target_id=target_id,
        target=None if settings.absent_target else target,
        distractor=distractor,
        occluded_fraction=settings.occlusion_fraction,
        occluder_direction=direction,
        drop_height=settings.drop_height_m,
    )


__all__ = ["OBSERVATION_DEPTH", "Placement", "SceneSample", "sample_scene"]
