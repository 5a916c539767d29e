"""The `sim` image source: the pybullet cell at the observation pose (one client per process).

A `SceneSample` (positions in the right camera frame at the observation pose) is laid
out in the world: each cloth is dropped from the scene's drop height at the world pose
under its camera-frame position and settles as a soft body; the blue paper covers the
requested share of the target's nodes from the sampled side. The truth is the Kabsch
fit of each cloth's nodes, seen from the right camera. Models come from the Fig. 7
station photographed in its own client and go through `make_model`.
"""

from __future__ import annotations

import numpy as np

from robot_app.experiments.image_sources import RenderedScene
from robot_app.experiments.scenes import Placement, SceneSample
from robot_app.geometry import invert_transform, rotation_about_z, yaw_of
from robot_app.sim.cloth_body import ClothBody
from robot_app.vision.photo_model import ClothModel, make_model

FACE_UP = np.diag([1.0, -1.0, -1.0])
"""Σ_M of a face-up cloth in the world: z into the table (docs/architecture.md)."""

OCCLUDER_SIZE = (0.30, 0.30)
"""The blue paper [m]."""


class SimSource:
    """The pybullet world and model station of this process."""

    name = "sim"

    def __init__(self) -> None:
        from robot_app.sim import ModelStation, World, cloth_spec
        from robot_app.sim.cloth_visual import ClothLook
        from robot_app.sim.realism import scene_defaults

        self._cloth_spec = cloth_spec
        self._look = ClothLook.draw
        self.world = World()
        self._defaults = scene_defaults(self.world.config.realism)
        config = self.world.config
        self.rig = self.world.stereo.rig
        self._station = ModelStation.for_world(config)
        self._models: dict[int, ClothModel] = {}
        self._occluder: int | None = None
        self._camera_to_world = self.world.transform_observation_camera_to_world
        self._table_depth = float(
            np.linalg.solve(self._camera_to_world, [0.0, 0.0, config.table.top_z, 1.0])[2]
        )

    def model(self, cloth_id: int) -> ClothModel:
        if cloth_id not in self._models:
            photo = self._station.photograph(self._cloth_spec(cloth_id))
            self._models[cloth_id] = make_model(
                photo.photo_bgr, photo.model_camera, photo.background_bgr, name=f"No.{cloth_id}"
            )
        return self._models[cloth_id]

    def radii(self) -> dict[int, float]:
        return {k: 0.5 * float(np.hypot(*self._cloth_spec(k).size)) for k in range(1, 13)}

    def _clear(self) -> None:
        for cloth in list(self.world.cloths):
            self.world.remove_body(cloth)
        if self._occluder is not None:
            self.world.remove_body(self._occluder)
            self._occluder = None
        self.world.robot.reset_joints(self.world.observation_joints)

    def _drop(self, placement: Placement, drop_height: float, rng: np.random.Generator) -> ClothBody:
        """Drops a cloth whose Σ_M sits at the placement seen from the observation camera,
        wrinkled and folded as the world's realism preset says."""
        point = self._camera_to_world @ [placement.x, placement.y, self._table_depth, 1.0]
        rotation_world = self._camera_to_world[:3, :3] @ rotation_about_z(placement.yaw)
        yaw_world = yaw_of(rotation_world @ FACE_UP)
        spec = self._cloth_spec(placement.cloth_id)
        defaults = self._defaults  # clean: no wrinkles, no folds, nothing drawn from rng
        look = self._look(rng, spec.size, defaults["wrinkle_amplitude"], defaults["fold_probability"])
        return self.world.add_cloth(
            spec, float(point[0]), float(point[1]), yaw_world, drop_height, settle=False, look=look
        )

    def render(self, scene: SceneSample, rng: np.random.Generator) -> RenderedScene:
        self._clear()
        if self.world.config.realism != "clean":  # clean draws nothing more: old trials reproduce
            self.world.reseed(int(rng.integers(2**31)))  # the scene's lamp direction, camera noise
        target = self._drop(scene.target, scene.drop_height, rng) if scene.target is not None else None
        distractor = (
            self._drop(scene.distractor, scene.drop_height, rng) if scene.distractor is not None else None
        )
        self.world.settle()
        if target is not None and scene.occluded_fraction > 0:
            nodes = target.nodes()[:, :2]
            direction = yaw_of(target.pose()[:3, :3]) + scene.occluder_direction
            normal = np.array([np.cos(direction), np.sin(direction)])
            along = (nodes - nodes.mean(axis=0)) @ normal
            start = float(np.quantile(along, 1.0 - scene.occluded_fraction))
            centre = nodes.mean(axis=0) + normal * (start + OCCLUDER_SIZE[0] / 2)
            self._occluder = self.world.add_occluder(
                (float(centre[0]), float(centre[1])), direction, OCCLUDER_SIZE
            )
        frame = self.world.stereo.render()
        camera = frame.transform_right_camera_to_world
        to_camera = invert_transform(camera)
        truth_target = to_camera @ target.pose() if target is not None else None
        truth_distractor = to_camera @ distractor.pose() if distractor is not None else None
        return RenderedScene(frame.left_bgr, frame.right_bgr, truth_target, truth_distractor)


__all__ = ["SimSource"]
