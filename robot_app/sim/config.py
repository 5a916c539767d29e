"""Typed settings of the simulated cell, its cameras, its cloth physics and its scenes.

All lengths [m], angles [rad] unless the field name says `_deg`; positions are in Σ_W
(robot base at the origin, z up). `configs/world.yaml` holds the defaults written out.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

from pydantic import Field, field_validator, model_validator

from robot_app.config import StrictModel, load_config
from robot_app.sim.realism import (
    DEFAULT_REALISM,
    AppearanceSettings,
    ImagingSettings,
    LightingSettings,
    Realism,
    fill_preset_defaults,
)

Vec2 = tuple[float, float]
Vec3 = tuple[float, float, float]

CATALOGUE_SIZE = 20  # sample cloths No.1-No.20 (robot_app.sim.cloths.CATALOGUE)

REPO_ROOT = Path(__file__).resolve().parents[2]
DEFAULT_URDF = REPO_ROOT / "urdf" / "pa10.urdf"
DEFAULT_WORLD_CONFIG = REPO_ROOT / "configs" / "world.yaml"


class TableSettings(StrictModel):
    """The table the cloths lie on; its top face is the plane z = `top_z`."""

    centre_xy: Vec2 = (0.35, 0.0)
    size_xy: Vec2 = Field((1.3, 1.4), description="table top extent [m]")
    top_z: float = 0.0
    height: float = Field(0.72, gt=0.0, description="floor to table top [m]")


class RangeSettings(StrictModel):
    """The recognition range of paper Sec. III and the green sheet that covers it."""

    centre_xy: Vec2 = (0.55, 0.0)
    size_xy: Vec2 = Field((0.39, 0.51), description="extent along world x, y [m]")
    sheet_margin: float = Field(0.12, ge=0.0, description="green sheet beyond the range [m]")
    sheet_rgb: Vec3 = (0.10, 0.62, 0.16)


class BoxSettings(StrictModel):
    """A collection box: open top, four walls standing on the table.

    `name` is what a sort rule (`robot-app clear-table`'s `sort`) calls the box.
    """

    name: str = Field("box", min_length=1, max_length=40, pattern=r"^[A-Za-z0-9_.-]+$")
    centre_xy: Vec2 = (0.30, -0.56)
    inner_size: float = Field(0.22, gt=0.0)
    wall_height: float = Field(0.10, gt=0.0)
    wall_thickness: float = Field(0.01, gt=0.0)


class RobotSettings(StrictModel):
    """Where the PA10 stands and how its joints are driven."""

    urdf: Path = DEFAULT_URDF
    base_xyz: Vec3 = (0.0, 0.0, 0.0)
    base_yaw: float = 0.0
    position_gain: float = Field(0.3, gt=0.0, le=1.0)
    home_joints: tuple[float, ...] = (0.0, 0.5, 0.0, 1.4, 0.0, 1.2, 0.0)

    @field_validator("urdf")
    @classmethod
    def _resolve_urdf(cls, value: Path) -> Path:
        """A relative path is taken from the current folder, else from the repository root."""
        if value.is_absolute() or value.is_file():
            return value
        return REPO_ROOT / value

    @field_validator("home_joints")
    @classmethod
    def _seven_joints(cls, value: tuple[float, ...]) -> tuple[float, ...]:
        if len(value) != 7:
            raise ValueError(f"home_joints needs 7 angles [rad] (S1..W2), got {len(value)}")
        return value


class ObservationSettings(StrictModel):
    """Observation pose: the right camera `height` above the range centre, looking down.

    `camera_yaw` turns the camera about the world z axis: 0 puts the image x axis along
    world +y and the image y axis along world +x (the image 'down' points away from
    the robot), so the 510 mm side of the range fills the image width.
    """

    height: float = Field(0.58, gt=0.1)
    camera_yaw: float = 0.0


class CameraSettings(StrictModel):
    """Hand cameras: ideal pinholes from a resolution and a horizontal field of view.

    `rig_file`: a stereo rig YAML (e.g. from `robot-app calibrate`) that the recogniser and
    the loop use instead of the URDF's cameras; None uses the truth. Rendering always
    uses the true cameras.
    """

    image_size: tuple[int, int] = (640, 480)
    hfov_deg: float = Field(48.0, gt=1.0, lt=170.0)
    near: float = Field(0.02, gt=0.0)
    far: float = Field(3.0, gt=0.0)
    rig_file: Path | None = Field(
        None, description="calibrated rig YAML the recogniser and loop use; None = the URDF truth"
    )

    @field_validator("rig_file")
    @classmethod
    def _resolve_rig_file(cls, value: Path | None) -> Path | None:
        """A relative path is taken from the current folder, else from the repository root."""
        if value is None or value.is_absolute() or value.is_file():
            return value
        return REPO_ROOT / value

    @field_validator("image_size")
    @classmethod
    def _positive_size(cls, value: tuple[int, int]) -> tuple[int, int]:
        if value[0] < 8 or value[1] < 8:
            raise ValueError("image_size must be at least [8, 8] pixels")
        return value


class ClothPhysicsSettings(StrictModel):
    """pybullet mass-spring cloth parameters (shared by all catalogue cloths)."""

    # Physics time grows with the node count (pybullet's solver sweeps every node and spring
    # about 80 times a step). 35 mm instead of 25 mm has 40% fewer nodes and takes less than
    # half the time; every point of a cloth stays within 30 mm of a node (grasp radius 35 mm).
    # The spring constants go with the spacing h: for the same cloth (weight per area
    # against stretch and bend) with a fixed node mass, the elastic and damping constants
    # scale as 1/h^2 and the bending one as 1/h^6 (a bending spring lengthens with the
    # square of its hinge angle). These are the 25 mm mesh's 100, 0.4 and 2.0 carried to
    # 35 mm. With a stiffer bend (2.0 or 0.5) the 35 mm No.11, laid into the box, stayed
    # propped against a wall in up to 4 of 40 pick-and-place episodes (0 of 40 at 25 mm).
    node_spacing: float = Field(0.035, gt=0.005, description="interior lattice side [m]")
    boundary_spacing: float = Field(0.03, gt=0.003, description="outline node spacing [m]")
    elastic_stiffness: float = Field(
        50.0, gt=0.0, description="spring stiffness [N/m] between nodes of 0.5 g (cloth_body.NODE_MASS)"
    )
    damping_stiffness: float = Field(0.2, ge=0.0, description="spring damping [N s/m]")
    bending_stiffness: float = Field(0.27, ge=0.0, description="bending spring stiffness [N/m]")
    friction: float = Field(0.8, ge=0.0)
    collision_margin: float = Field(0.003, gt=0.0)
    settle_time: float = Field(1.0, gt=0.0, description="simulated time to let a cloth settle [s]")
    substeps: Literal[1, 2, 4, 8] = Field(
        1,
        description="pybullet solver steps per simulation step (numSubSteps); piles of cloths need 4: "
        "at 1 (1/240 s) a cloth lifted from a pile or put back onto one presses nodes 2-5 cm into the "
        "cloths and the table, whose contacts then fling them off at 10-30 m/s (powers of two: "
        "pybullet's fixed-step accumulator then takes exactly this many solver steps per step)",
    )
    solid_table: bool = Field(
        True,
        description="after every step, a free cloth node pybullet's soft contact let into the table top "
        "is set back onto it (World.step); without it, a node trapped in the table under another cloth "
        "made put-back heaps slide off the table by themselves (scripts/pile_physics.py --alone)",
    )
    keep_layers: bool = Field(
        True,
        description="a free cloth node lying low keeps its side (above or below) of every other free "
        "cloth it lies over or under (World.step, sim/cloth_layers.py); without it, pybullet's soft "
        "contact lets resting layers sink through each other within seconds, and a lift brings the "
        "cloths under the lifted one up, hooked into it",
    )
    keep_layers_held: bool = Field(
        False,
        description="with keep_layers, the free cloths also keep their side of a cloth the gripper "
        "holds (sim/cloth_layers.py): without it, a lift threads the held cloth's edges through a "
        "cloth beside it (pybullet's soft contact) and the two hang together at every lift",
    )
    uncross_layers: bool = Field(
        False,
        description="with keep_layers, two free cloths whose meshes pass through each other (an edge "
        "of one through a triangle of the other) are given one order, the one most of their nodes "
        "lay in, and the nodes on the wrong side are set back (sim/cloth_layers.py): a pair put back "
        "together lands crossed and, without it, stays crossed and comes up together at every lift",
    )
    free_slide_speed: float | None = Field(
        None,
        gt=0.0,
        description="a free cloth lying on the table (outside the boxes, not falling) that the hand "
        "cannot be moving (not held, not near a hand that pushes, not touching a cloth that is) may "
        "not speed up along it beyond this [m/s]: it gets back the speed it had (World.step); "
        "pybullet's crossed soft-soft contact speeds put-back heaps up by themselves. null: off",
    )
    sdf_voxel_size: float = Field(
        0.25,
        gt=0.005,
        le=1.0,
        description="voxel of pybullet's signed distance field for cloth-rigid contacts [m]; cloths "
        "pressed onto the table by cloths on them sink through it with 0.25 m, not with 0.05 m",
    )


class StationSettings(StrictModel):
    """The Fig. 7 model-generation station: one camera `distance` above a green sheet."""

    distance: float = Field(0.40, gt=0.05)
    image_size: tuple[int, int] = (640, 480)
    hfov_deg: float = Field(48.0, gt=1.0, lt=170.0)
    sheet_size: Vec2 = (0.6, 0.5)


class WorldConfig(StrictModel):
    """Everything that places and drives the simulated cell.

    `realism` names the preset (robot_app.sim.realism) that fills every `lighting`,
    `imaging` and `appearance` key not given explicitly.
    """

    realism: Realism = DEFAULT_REALISM
    lighting: LightingSettings = LightingSettings()
    imaging: ImagingSettings = ImagingSettings()
    appearance: AppearanceSettings = AppearanceSettings()

    table: TableSettings = TableSettings()
    range: RangeSettings = RangeSettings()
    box: BoxSettings = BoxSettings()
    boxes: tuple[BoxSettings, ...] | None = Field(
        None,
        description="the cell's collection boxes, first = `box` (pick-place's); null: one box, `box`",
    )
    robot: RobotSettings = RobotSettings()
    observation: ObservationSettings = ObservationSettings()
    cameras: CameraSettings = CameraSettings()
    cloth: ClothPhysicsSettings = ClothPhysicsSettings()
    station: StationSettings = StationSettings()
    physics_hz: float = Field(240.0, ge=60.0, le=2000.0)
    gravity: float = Field(9.81, ge=0.0)

    @model_validator(mode="before")
    @classmethod
    def _preset_defaults(cls, data: Any) -> Any:
        return fill_preset_defaults(data)

    @model_validator(mode="after")
    def _first_box_is_box(self) -> WorldConfig:
        """With `boxes`, `box` is their first (set one of the two, or both alike); names differ."""
        if self.boxes is None:
            return self
        if not self.boxes:
            raise ValueError("boxes: give at least one box, or null for the one box `box`")
        if "box" in self.model_fields_set and self.box != self.boxes[0]:
            raise ValueError("box and boxes[0] differ: set world.boxes alone (its first is the main box)")
        names = [b.name for b in self.boxes]
        if len(set(names)) != len(names):
            raise ValueError(f"boxes need distinct names, got {names}")
        object.__setattr__(self, "box", self.boxes[0])
        return self

    @property
    def all_boxes(self) -> tuple[BoxSettings, ...]:
        """Every collection box of the cell, the main one (`box`) first."""
        return (self.box,) if self.boxes is None else self.boxes


ConveyorProfileName = Literal["constant", "stop_and_go", "ramp"]


class SceneSettings(StrictModel):
    """What `make_scene` puts on the table, and how the belt under the range moves it.

    With `conveyor_speed` > 0 the target lies at the upstream edge of the range (its pose
    drawn as usual, then moved against the belt until it touches the range's edge), as a
    cloth a belt has just brought fully into view, and the belt carries it across.
    """

    target: int = Field(3, ge=1, le=CATALOGUE_SIZE, description="catalogue number No.1-No.20")
    occluder: bool = False
    occluded_fraction: float = Field(0.45, ge=0.0, lt=1.0)
    occluder_size: Vec2 = (0.20, 0.34)
    distractor: int | None = Field(None, ge=1, le=CATALOGUE_SIZE)
    drop_height: float = Field(0.0, ge=0.0, le=0.5)
    position_margin: float = Field(
        0.02, ge=0.0, description="keep the target's centre this far inside the range [m]"
    )
    wrinkle_amplitude: float | None = Field(
        None, ge=0.0, le=0.03, description="highest wrinkle of a laid cloth [m]; null: the realism preset's"
    )
    fold_probability: float | None = Field(
        None, ge=0.0, le=1.0, description="chance a cloth lies with a corner folded over; null: the preset's"
    )
    # The conveyor (sim/conveyor.py): the green sheet is a belt that carries every cloth node
    # lying on it (and not held) at the belt's speed. 0 m/s: a still table, as before.
    conveyor_speed: float = Field(0.0, ge=0.0, allow_inf_nan=False, description="belt speed [m/s]")
    conveyor_direction_deg: float = Field(
        0.0, ge=-360.0, le=360.0, description="direction of travel in Σ_W, from +x toward +y [deg]"
    )
    conveyor_profile: ConveyorProfileName = Field(
        "constant", description="constant | stop_and_go (runs, stops, runs ...) | ramp (0 to speed)"
    )
    conveyor_run_time: float = Field(2.0, gt=0.0, description="stop_and_go: time running per cycle [s]")
    conveyor_stop_time: float = Field(1.0, ge=0.0, description="stop_and_go: time standing per cycle [s]")
    conveyor_acceleration: float = Field(
        0.5, gt=0.0, description="stop_and_go: the belt's acceleration when it starts and stops [m/s^2]"
    )
    conveyor_ramp_time: float = Field(4.0, gt=0.0, description="ramp: time from standstill to speed [s]")


def load_world_config(path: str | Path | None = None, overrides: tuple[str, ...] = ()) -> WorldConfig:
    """Reads a world YAML (default: `configs/world.yaml` when present, else built-in defaults)."""
    if path is None and DEFAULT_WORLD_CONFIG.is_file():
        path = DEFAULT_WORLD_CONFIG
    return load_config(WorldConfig, path, overrides)


__all__ = [
    "CATALOGUE_SIZE",
    "DEFAULT_URDF",
    "DEFAULT_WORLD_CONFIG",
    "BoxSettings",
    "CameraSettings",
    "ClothPhysicsSettings",
    "ConveyorProfileName",
    "ObservationSettings",
    "RangeSettings",
    "RobotSettings",
    "SceneSettings",
    "StationSettings",
    "TableSettings",
    "WorldConfig",
    "load_world_config",
]
