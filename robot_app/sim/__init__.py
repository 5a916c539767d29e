"""Simulation: the pybullet cell, its soft-body cloths, cameras and model station.

One image source and one robot among possible others; `robot_app.vision` never imports
this package.
"""

from robot_app.sim import _quiet  # noqa: F401  (first: pybullet imported with its banner silenced)
from robot_app.sim.cameras import (
    Lighting,
    StereoFrame,
    gl_projection_matrix,
    gl_view_matrix,
    render_bgr,
)
from robot_app.sim.cell import SimCell
from robot_app.sim.cloth_body import ClothBody
from robot_app.sim.cloth_mesh import ClothMesh, build_cloth_mesh, cache_dir
from robot_app.sim.cloths import CATALOGUE, ClothSpec, cloth_spec, outline_polygon, texture_image
from robot_app.sim.config import (
    ClothPhysicsSettings,
    SceneSettings,
    StationSettings,
    WorldConfig,
    load_world_config,
)
from robot_app.sim.conveyor import BeltArea, BeltMotion, Conveyor, ConveyorEncoder
from robot_app.sim.imaging import CameraModel, FrameClock
from robot_app.sim.lighting import ShadowMap, draw_lighting
from robot_app.sim.realism import (
    PRESETS,
    REALISM_NAMES,
    AppearanceSettings,
    ImagingSettings,
    LightingSettings,
)
from robot_app.sim.robot import Contact, SimRobot
from robot_app.sim.scene import Scene, make_scene
from robot_app.sim.station import ModelStation, StationPhoto
from robot_app.sim.stereo import StereoCamera
from robot_app.sim.video import EpisodeVideo, VisionOverlay
from robot_app.sim.world import BoxGeometry, World, observation_camera_pose

__all__ = [
    "CATALOGUE",
    "PRESETS",
    "REALISM_NAMES",
    "AppearanceSettings",
    "BeltArea",
    "BeltMotion",
    "BoxGeometry",
    "CameraModel",
    "ClothBody",
    "ClothMesh",
    "ClothPhysicsSettings",
    "ClothSpec",
    "Contact",
    "Conveyor",
    "ConveyorEncoder",
    "EpisodeVideo",
    "FrameClock",
    "ImagingSettings",
    "Lighting",
    "LightingSettings",
    "ModelStation",
    "Scene",
    "SceneSettings",
    "ShadowMap",
    "SimCell",
    "SimRobot",
    "StationPhoto",
    "StationSettings",
    "StereoCamera",
    "StereoFrame",
    "VisionOverlay",
    "World",
    "WorldConfig",
    "build_cloth_mesh",
    "cache_dir",
    "cloth_spec",
    "draw_lighting",
    "gl_projection_matrix",
    "gl_view_matrix",
    "load_world_config",
    "make_scene",
    "observation_camera_pose",
    "outline_polygon",
    "render_bgr",
    "texture_image",
]
