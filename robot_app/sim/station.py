"""The model-generation station of Fig. 7: one camera 400 mm above a green sheet.

It has its own pybullet client (gravity off) so photographs never disturb a `World`,
its own lamp (`world.lighting.station`) and its own camera (`world.imaging.station`:
manual exposure, its own white balance, noise, JPEG). The cloth is laid flat with Σ_M
at the sheet's centre, its texture axes along the camera's image axes, so the camera
sees ^C R_M = I; the photo then goes through `make_model` like a real photograph.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import TracebackType

import numpy as np
import numpy.typing as npt
import pybullet as pb

from robot_app.arrays import FloatArray
from robot_app.errors import SimulationError
from robot_app.geometry import make_transform
from robot_app.sim.cameras import Lighting, render_bgr
from robot_app.sim.cloth_body import ClothBody
from robot_app.sim.cloth_mesh import build_cloth_mesh, cache_dir
from robot_app.sim.cloth_visual import build_render_mesh, render_obj_path
from robot_app.sim.cloths import ClothSpec
from robot_app.sim.config import (
    ClothPhysicsSettings,
    RangeSettings,
    StationSettings,
    WorldConfig,
)
from robot_app.sim.imaging import CameraModel
from robot_app.sim.lighting import station_lighting
from robot_app.sim.realism import AppearanceSettings, StationImagingSettings, StationLightingSettings
from robot_app.vision.camera import ModelCamera, PinholeCamera

FACE_UP = np.diag([1.0, -1.0, -1.0])  # camera looking down; also Σ_M of a face-up cloth


@dataclass(frozen=True)
class StationPhoto:
    """What the station produces for one cloth.

    Attributes:
        photo_bgr: (H, W, 3) uint8 photo of the cloth on the sheet (Fig. 4 b).
        background_bgr: (H, W, 3) uint8 photo of the empty sheet (Fig. 4 a).
        model_camera: intrinsics and distance to the sheet, for `make_model`.
        transform_model_to_camera: 4x4 ground truth ^C T_M of the cloth in the photo.
    """

    photo_bgr: npt.NDArray[np.uint8]
    background_bgr: npt.NDArray[np.uint8]
    model_camera: ModelCamera
    transform_model_to_camera: FloatArray


class ModelStation:
    """Renders model photos of catalogue cloths; a context manager owning one client.

    Args:
        config: camera distance [m], resolution, field of view, sheet size.
        physics: the cloth mesh spacing (the same meshes as in the World).
        sheet_rgb: colour of the green sheet (the World's, by default).
        lighting: the station's lamp (default: the clean cell's straight-down light).
        imaging: the station camera (default: ideal).
        appearance: flat cartoon or fabric cloths (default: flat).
    """

    def __init__(
        self,
        config: StationSettings | None = None,
        physics: ClothPhysicsSettings | None = None,
        sheet_rgb: tuple[float, float, float] = RangeSettings().sheet_rgb,
        lighting: StationLightingSettings | None = None,
        imaging: StationImagingSettings | None = None,
        appearance: AppearanceSettings | None = None,
    ) -> None:
        self.config = config or StationSettings()
        self._physics = physics or ClothPhysicsSettings()
        self._lighting: Lighting = station_lighting(lighting or StationLightingSettings())
        self._lamp_rgb = (lighting or StationLightingSettings()).key_rgb
        self._imaging = imaging or StationImagingSettings()
        self._appearance = appearance or AppearanceSettings()
        self._client = pb.connect(pb.DIRECT)
        if self._client < 0:
            raise SimulationError("could not connect to pybullet")
        pb.resetSimulation(pb.RESET_USE_DEFORMABLE_WORLD, physicsClientId=self._client)
        pb.setGravity(0, 0, 0, physicsClientId=self._client)
        half = [self.config.sheet_size[0] / 2, self.config.sheet_size[1] / 2, 0.0005]
        sheet = pb.createVisualShape(
            pb.GEOM_BOX, halfExtents=half, rgbaColor=[*sheet_rgb, 1.0], physicsClientId=self._client
        )
        pb.createMultiBody(0, -1, sheet, [0, 0, -0.0015], physicsClientId=self._client)
        width, height = self.config.image_size
        camera = PinholeCamera.from_fov((width, height), np.deg2rad(self.config.hfov_deg))
        self.model_camera = ModelCamera(camera, self.config.distance)
        self.transform_camera_to_world = make_transform(FACE_UP, [0.0, 0.0, self.config.distance])
        self._cache = cache_dir()

    @classmethod
    def for_world(cls, world: WorldConfig) -> ModelStation:
        """The station of a world config: its station, cloth meshes, sheet, lamp, camera, look."""
        return cls(
            world.station,
            world.cloth,
            world.range.sheet_rgb,
            world.lighting.station,
            world.imaging.station,
            world.appearance,
        )

    def photograph(self, spec: ClothSpec) -> StationPhoto:
        """Photographs the empty sheet, then the cloth lying flat in the middle of it.

        The camera's noise and white-balance error are drawn from the cloth's number:
        the same cloth gives the same photo.
        """
        camera = CameraModel(self._imaging, (spec.number, 17), self._lamp_rgb)
        background = camera.expose(self._render())[0]
        mesh = build_cloth_mesh(spec, self._physics.node_spacing, self._physics.boundary_spacing)
        pose = make_transform(FACE_UP, [0.0, 0.0, 0.0])
        render = None
        if self._appearance.fabric:
            render = render_obj_path(
                build_render_mesh(mesh, self._appearance.visual_spacing), self._cache, keep=True
            )
        cloth = ClothBody(
            self._client,
            mesh,
            pose,
            self._physics,
            self._cache,
            render_obj=render,
            fabric=self._appearance.fabric,
        )
        try:
            pb.stepSimulation(physicsClientId=self._client)  # soft-body visuals update on a step
            photo = camera.expose(self._render())[0]
            truth = np.asarray(np.linalg.solve(self.transform_camera_to_world, cloth.pose()), dtype=float)
        finally:
            cloth.remove()
        return StationPhoto(photo, background, self.model_camera, truth)

    def _render(self) -> npt.NDArray[np.uint8]:
        return render_bgr(
            self._client, self.model_camera.camera, self.transform_camera_to_world, lighting=self._lighting
        )

    def close(self) -> None:
        """Disconnects the client (idempotent)."""
        if self._client >= 0:
            pb.disconnect(self._client)
            self._client = -1

    def __enter__(self) -> ModelStation:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()


__all__ = ["ModelStation", "StationPhoto"]
