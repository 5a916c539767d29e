"""The clear-table job in the simulated cell: config, world, pile, models, run, verdict.

`run_clear_table` builds the cell with its boxes, lays the seeded pile
(`sim.make_pile`), photographs every cloth the robot knows at the Fig. 7 station and
makes its model (through `make_model`, as a real photo would go), runs `TableClearer`
and has the simulator judge the end (`clear_table_judge.judge`): where each cloth of
the pile really is.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from contextlib import ExitStack
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from pydantic import Field, model_validator

from robot_app.arrays import FloatArray
from robot_app.config import SettingValueError, StrictModel
from robot_app.control.box_check import BoxCheckSettings
from robot_app.control.clear_table_records import (
    BoxPlace,
    ClearTableSettings,
    SurveyRecord,
    TableArea,
    TableResult,
)
from robot_app.control.episode import PhaseRecord
from robot_app.control.intercept import hanging_reach
from robot_app.control.kinematics import Kinematics
from robot_app.control.limits import JointLimits, TrajectorySettings
from robot_app.control.pick_checks import AttemptState
from robot_app.control.pick_place import LoopSettings, carry_over_box, release_into_box
from robot_app.control.pose_filter import PoseFilterSettings
from robot_app.control.sort_rule import SortSettings, cloth_name
from robot_app.control.table_clearer import TableClearer
from robot_app.errors import ConfigError
from robot_app.experiments.clear_table_faults import (
    FaultSettings,
    LiftTruth,
    PickWitness,
    ScaleSettings,
    WristScale,
    catch_nearest,
)
from robot_app.experiments.clear_table_judge import TableVerdict, final_place, judge
from robot_app.experiments.clear_table_views import TableViews
from robot_app.experiments.recording import require_rerun
from robot_app.geometry import invert_transform, transform_points
from robot_app.outputs import atomic_path
from robot_app.sim import ModelStation, SimCell, World, WorldConfig, cloth_spec
from robot_app.sim.cameras import RIGHT_FRAME, segmentation
from robot_app.sim.config import CATALOGUE_SIZE
from robot_app.sim.pile import Pile, PileCloth, PileSettings, make_pile
from robot_app.vision import ClothModel, ModelSettings, RecognitionSettings, Recognizer, make_model
from robot_app.vision.identify import Identification, IdentifySettings

WORLD_DEFAULTS: dict[str, Any] = {  # what the job's world differs in from pick-place's
    "boxes": [
        {"name": "colours", "centre_xy": (0.30, -0.56)},
        {"name": "whites", "centre_xy": (0.30, 0.56)},
    ],
    # cloths lie on cloths (sim/pile.py), and one pressed by another stays on the table;
    # four solver steps a step: at one, lifts from piles and put-backs flung cloths off the
    # table; at two, some lifts still snapped (scripts/pile_physics.py)
    "cloth": {"collision_margin": 0.008, "sdf_voxel_size": 0.05, "substeps": 4},
    "cameras": {"image_size": (320, 240)},
}


class ClearTableConfig(StrictModel):
    """The clear-table job's config (`configs/clear_table.yaml`).

    Attributes:
        known: catalogue numbers the robot has photo models of (None: the whole catalogue).
        pile_height: highest cloth above the table the search looks for [m] (the
            recognition's depth range is the table's depth minus this, plus `depth_below`).
        depth_below: ... and this below the table's depth [m].
        tracking_depth_window: the loop's depth window while tracking [m].
        table_tilt_deg: largest tilt of a cloth searched for.
        grasp_radius: nodes anchored around the TCP [m] (the simulated grasp).
    """

    seed: int = Field(0, ge=0)
    world: WorldConfig = WorldConfig.model_validate(WORLD_DEFAULTS)
    pile: PileSettings = PileSettings()
    known: tuple[int, ...] | None = None
    sort: SortSettings = SortSettings(default="colours", boxes={"whites": (6, 17, 18)})
    model: ModelSettings = ModelSettings()
    recognition: RecognitionSettings = RecognitionSettings()
    identify: IdentifySettings = IdentifySettings()
    filter: PoseFilterSettings = PoseFilterSettings()
    trajectory: TrajectorySettings = TrajectorySettings()
    loop: LoopSettings = LoopSettings(
        grasp_retries=0
    )  # the job retries, reaching deeper (clear.deeper_after_miss)
    clear: ClearTableSettings = ClearTableSettings()
    box_check: BoxCheckSettings = BoxCheckSettings()
    faults: FaultSettings | None = None
    scale: ScaleSettings = ScaleSettings()
    pile_height: float = Field(0.06, gt=0.0, le=0.2)
    depth_below: float = Field(0.015, ge=0.0, le=0.1)
    tracking_depth_window: float = Field(0.02, gt=0.0, le=0.1)
    table_tilt_deg: float = Field(5.0, gt=0.0, le=90.0)
    grasp_radius: float = Field(0.035, gt=0.0, le=0.1)

    @model_validator(mode="before")
    @classmethod
    def _world_defaults(cls, data: Any) -> Any:
        """Keys of `world` a config leaves out take the job's defaults (`WORLD_DEFAULTS`)."""
        if not isinstance(data, dict) or not isinstance(data.get("world", {}), dict):
            return data
        world = dict(data.get("world", {}))
        if "boxes" not in world and "box" not in world:
            world["boxes"] = WORLD_DEFAULTS["boxes"]
        for section in ("cloth", "cameras"):
            given = world.get(section, {})
            if isinstance(given, dict):
                world[section] = {**WORLD_DEFAULTS[section], **given}
        return {**data, "world": world}

    @model_validator(mode="after")
    def _consistent(self) -> ClearTableConfig:
        names = tuple(b.name for b in self.world.all_boxes)
        self.sort.check_boxes(names, key="sort")
        self.sort.check_cloths(tuple(cloth_name(n) for n in range(1, CATALOGUE_SIZE + 1)), key="sort")
        if self.known is not None and any(not 1 <= n <= CATALOGUE_SIZE for n in self.known):
            raise SettingValueError(
                "known", f"catalogue numbers are 1-{CATALOGUE_SIZE}, got {list(self.known)}", list(self.known)
            )
        if any(abs(v) > 1e-12 for v in (*self.world.robot.base_xyz, self.world.robot.base_yaw)):
            raise ValueError(
                "world.robot.base_xyz/base_yaw: the loop needs the robot base at the world origin"
            )
        return self

    @property
    def known_numbers(self) -> tuple[int, ...]:
        return tuple(range(1, CATALOGUE_SIZE + 1)) if self.known is None else tuple(sorted(set(self.known)))


@dataclass(frozen=True)
class ClearTableEpisode:
    """A finished job with the simulator's verdict.

    Attributes:
        result: what the robot did and measured.
        verdict: where the cloths really ended, and what the robot missed.
        pile: catalogue numbers in the pile, drop order; max_overlap, same_family: its layout.
        phase_times: simulated time spent in each of the job's phases ("survey", "look
            around", "put back", the loop's phases, ...) [s]: where the job's time goes.
        lifts: the simulator's truth about every grasp (which cloths left the table with it).
        slides_held: simulation steps in which a lying cloth was kept from speeding up along
            the table by itself (`world.cloth.free_slide_speed`; 0 when that is off): how
            much the episode leaned on that guard against pybullet's soft-soft artefact.
    """

    result: TableResult
    verdict: TableVerdict
    pile: tuple[int, ...]
    max_overlap: float
    same_family: bool
    phase_times: dict[str, float] = field(default_factory=dict)
    lifts: tuple[LiftTruth, ...] = ()
    slides_held: int = 0


def run_clear_table(
    config: ClearTableConfig,
    *,
    on_phase: Callable[[PhaseRecord, str], None] | None = None,
    on_survey: Callable[[SurveyRecord], None] | None = None,
    video_path: str | Path | None = None,
    record_path: str | Path | None = None,
    stop: Callable[[], None] | None = None,
) -> ClearTableEpisode:
    """Runs the job once in a fresh simulated cell.

    Args:
        config: the job's settings; `config.seed` fixes the pile and the searches.
        on_phase: called after every loop phase with the cloth meant (progress output).
        on_survey: called after every survey.
        video_path, record_path: write an MP4 / a Rerun recording there (whole or absent,
            as for pick-place).
        stop: called after every control step; raising `InterruptError` there ends the
            job at that step (`interrupted`).
    """
    if record_path is not None:
        require_rerun()
    models = {cloth_name(n): _model(config.world, config.model, n) for n in config.known_numbers}
    with ExitStack() as stack:
        video_file = stack.enter_context(atomic_path(video_path)) if video_path is not None else None
        record_file = stack.enter_context(atomic_path(record_path)) if record_path is not None else None
        with World(config.world) as world:
            pile = make_pile(world, config.pile, seed=config.seed)
            return _run_in_cell(
                config, world, pile, models, on_phase, on_survey, video_file, record_file, stop
            )


def _sheet(w: WorldConfig) -> TableArea:
    """The green sheet on the table: the recognition range and its margin all round."""
    (cx, cy), (sx, sy), m = w.range.centre_xy, w.range.size_xy, w.range.sheet_margin
    return TableArea((cx - sx / 2 - m, cx + sx / 2 + m), (cy - sy / 2 - m, cy + sy / 2 + m))


def _table_top(w: WorldConfig) -> TableArea:
    """The table top's extent (the cell's config)."""
    (cx, cy), (sx, sy) = w.table.centre_xy, w.table.size_xy
    return TableArea((cx - sx / 2, cx + sx / 2), (cy - sy / 2, cy + sy / 2))


def _run_in_cell(
    config: ClearTableConfig,
    world: World,
    pile: Pile,
    models: dict[str, ClothModel],
    on_phase: Callable[[PhaseRecord, str], None] | None,
    on_survey: Callable[[SurveyRecord], None] | None,
    video_file: Path | None,
    record_file: Path | None,
    stop: Callable[[], None] | None,
) -> ClearTableEpisode:
    cell = SimCell(world, grasp_radius=config.grasp_radius)
    limits = JointLimits.from_urdf(config.world.robot.urdf, config.trajectory)
    settings = _recognition_settings(config)
    recognizers = {name: Recognizer(model, world.stereo.rig, settings) for name, model in models.items()}
    witness = PickWitness(world, pile, config.faults)
    scale = WristScale(cell, config.scale, config.seed)
    truth = {cloth_name(c.number): c.body for c in pile.cloths}
    views = TableViews(
        world, cell, models, limits, video_file, record_file, truth, f"clear-table, seed {config.seed}"
    )

    def phase(record: PhaseRecord, meant: str) -> None:
        witness.on_phase(record, meant)
        views.on_phase(record)
        if on_phase is not None:
            on_phase(record, meant)

    phase_times: dict[str, float] = {}
    clock = [world.time]

    def step(phase_name: str, meant: str | None) -> None:
        phase_times[phase_name] = phase_times.get(phase_name, 0.0) + world.time - clock[0]
        clock[0] = world.time
        witness.on_step(phase_name, meant)
        views.on_step(phase_name, meant)
        if stop is not None:
            stop()

    clearer = _clearer(
        config,
        world,
        cell,
        recognizers,
        limits,
        scale,
        on_phase=phase,
        on_step=step,
        on_recognition=views.on_recognition if views.active else None,
        on_survey=on_survey,
        ground_truth=lambda name: truth[name].pose if name in truth else None,
    )
    world.robot.reset_joints(
        clearer.observation_joints
    )  # the job starts at the controller's observation pose
    try:
        result = clearer.run()
        verdict = judge(world, pile, result, witness.lifts, config.sort, set(models), witness.flung)
        views.finish(result, verdict, world.time)
    finally:
        views.close()
    if video_file is not None and views.video_frames == 0:
        video_file.unlink(missing_ok=True)
    return ClearTableEpisode(
        result,
        verdict,
        tuple(c.number for c in pile.cloths),
        pile.max_overlap,
        pile.same_family,
        phase_times,
        tuple(witness.lifts),
        world.slides_held,
    )


def _clearer(
    config: ClearTableConfig,
    world: World,
    cell: SimCell,
    recognizers: dict[str, Recognizer],
    limits: JointLimits,
    scale: WristScale,
    **callbacks: Any,
) -> TableClearer:
    """The job for this cell (`callbacks`: TableClearer's on_phase, on_step, ...)."""
    w = config.world
    boxes = tuple(
        BoxPlace(b.name, b.centre.copy(), b.inner_size, b.wall_height, s.wall_thickness)
        for b, s in zip(world.boxes, world.config.all_boxes, strict=True)
    )
    return TableClearer(
        cell,
        Kinematics.from_urdf(w.robot.urdf, "base_link", "tcp"),
        recognizers,
        limits,
        world.transform_observation_camera_to_world,
        boxes,
        config.sort,
        w.table.top_z,
        config.clear,
        config.identify,
        config.loop,
        config.filter,
        config.box_check,
        weigh=scale.read,
        weights={
            name: scale.weigh_model(n) for name, n in ((cloth_name(n), n) for n in config.known_numbers)
        },
        posture_seed=w.robot.home_joints,
        sheet=_sheet(w),
        table_top=_table_top(w),
        **callbacks,
    )


@dataclass(frozen=True)
class FirstSurvey:
    """The job's first survey of a fresh pile, and the truth to judge it by.

    Attributes:
        identification: what the survey made of the pair (after the furniture is taken out).
        transform_camera_to_world: (4, 4) the right camera's pose at the survey.
        truth: cloth name -> (4, 4) its ground-truth pose Σ_M in Σ_W, for the cloths in the pile.
        visible: cloth name -> the share of its outline's area (laid flat at its true pose,
            projected into the true right camera) that the camera truly sees of it.
        pile: the pile's catalogue numbers, in drop order.
        same_family: the pile has two or more cloths of one hue family.
        max_overlap: the largest overlap of two of its cloths (share of the smaller).
    """

    identification: Identification
    transform_camera_to_world: FloatArray
    truth: dict[str, FloatArray]
    visible: dict[str, float]
    pile: tuple[int, ...]
    same_family: bool
    max_overlap: float


def _job_in_cell(config: ClearTableConfig, world: World, models: dict[str, ClothModel]) -> TableClearer:
    """The job for `world`'s cell with `models`, without callbacks, its arm at the
    observation pose (`first_survey`, `release_trial`)."""
    cell = SimCell(world, grasp_radius=config.grasp_radius)
    settings = _recognition_settings(config)
    recognizers = {name: Recognizer(model, world.stereo.rig, settings) for name, model in models.items()}
    limits = JointLimits.from_urdf(config.world.robot.urdf, config.trajectory)
    clearer = _clearer(config, world, cell, recognizers, limits, WristScale(cell, config.scale, config.seed))
    world.robot.reset_joints(clearer.observation_joints)
    return clearer


def first_survey(config: ClearTableConfig) -> FirstSurvey:
    """Builds the episode's pile and cell as `run_clear_table` does and makes only the job's
    first survey from the observation pose (`scripts/bench_survey.py`)."""
    models = {cloth_name(n): _model(config.world, config.model, n) for n in config.known_numbers}
    with World(config.world) as world:
        pile = make_pile(world, config.pile, seed=config.seed)
        clearer = _job_in_cell(config, world, models)
        found = clearer.first_survey()
        return FirstSurvey(
            found,
            clearer.survey_capture.transform_right_camera_to_world.copy(),
            {cloth_name(c.number): c.body.pose() for c in pile.cloths},
            _visible(world, pile),
            tuple(c.number for c in pile.cloths),
            pile.same_family,
            pile.max_overlap,
        )


@dataclass(frozen=True)
class ReleasedCloth:
    """One cloth of a release trial (`release_trial`).

    Attributes:
        name: the cloth.
        reach: how far it hung below the fingers (`intercept.hanging_reach` from where it
            was held) [m].
        off_centre: the grasp point's distance from its nodes' centroid on the table [m].
        heap: the top of what lay in the box before its release, as the box check measured
            it (`box_contents.contents_top`; the release takes it for the floor) [m].
        place: where it lay after the last release (`clear_table_judge.final_place`).
        over_rim: share of its nodes heaped over the box's rim.
        outside: share of its nodes outside the box's walls (10 % or more: partly in).
        release_s: simulated time of its release (lowering, letting go, the wait) [s].
        came_along: it went into the box with another cloth, held with it (`reach`: the
            extra the job counted for it).
        laid_again: the check's notes on a cloth over a wall and laying it again
            (`TableClearer.check_box`), "" where the rim stayed clear.
    """

    name: str
    reach: float
    off_centre: float
    heap: float
    place: str
    over_rim: float
    outside: float
    release_s: float
    came_along: bool = False
    laid_again: str = ""


APART = 0.045  # a release trial's grasp lies this far from every cloth still lying (grasp radius + 1 cm) [m]
TOGETHER = 0.008  # ... or, for a double pick, this near one (the grasp radius holds both) [m]


def release_trial(
    config: ClearTableConfig, box: str, edge: float = 1.0, pairs: bool = False
) -> tuple[ReleasedCloth, ...]:
    """Builds the episode's pile and cell as `run_clear_table` does, then picks its cloths
    one by one (the last dropped first) at a node drawn with `config.seed` and lays each
    into `box` with the job's own transfer, release and heap measure (`carry_over_box`,
    `release_into_box`, the box check's `contents_top`); where every cloth lies is judged
    after the last release (`scripts/bench_release.py`). The node is drawn among the
    cloth's nodes at least `APART` from every other cloth still on the table (all of them
    where none is), and of those among the share `edge` farthest from its centroid (1: any;
    0.1: near its edge, where it hangs longest). With `pairs`, among its nodes within
    `TOGETHER` of another cloth still on the table instead, where there are such, and the
    nearest such cloth is anchored too where the fingers did not take it (`catch_nearest`,
    as the bench's injected double pick): a double pick, which goes into the box as one
    load, its other cloths' hanging reach counted as the job counts it
    (`TableClearer.hanging_reach`, from their photo model's grasp point). No recognition:
    the grasp point is the simulator's node, so what is measured is the release alone; the
    robot knows the pile's cloths only.

    Raises:
        ConfigError: `box` is none of the cell's boxes, or `edge` not in (0, 1].
    """
    if not 0.0 < edge <= 1.0:
        raise ConfigError(f"edge must be in (0, 1], got {edge}")
    rng = np.random.default_rng((config.seed, 41))
    with World(config.world) as world:
        pile = make_pile(world, config.pile, seed=config.seed)
        numbers = [c.number for c in pile.cloths]
        config = ClearTableConfig.model_validate({**config.model_dump(), "known": numbers})
        models = {cloth_name(n): _model(config.world, config.model, n) for n in numbers}
        clearer = _job_in_cell(config, world, models)
        if box not in clearer.boxes:
            raise ConfigError(f"no box {box!r} in the cell (boxes: {', '.join(clearer.boxes)})")
        place, motion, loop = clearer.boxes[box], clearer.motion, clearer.loop_settings
        clearer.start()
        clearer.look_into_box(box)  # the reference of the checks after placing
        top = world.config.table.top_z
        held: list[tuple[PileCloth, str, float, float, float, float, bool, str]] = []
        boxed: set[int] = set()  # catalogue numbers of the cloths laid into the box
        for cloth in reversed(pile.cloths):
            if cloth.number in boxed:
                continue  # went into the box with another
            name = cloth_name(cloth.number)
            lying = [c for c in pile.cloths[: cloth.order] if c.number not in boxed]
            point = _trial_grasp(cloth, lying, edge, rng, together=pairs)
            nodes = cloth.body.nodes()
            grasp_model = transform_points(invert_transform(cloth.body.pose()), point[None])[0]
            motion.move_tcp([point[0], point[1], point[2] + loop.pregrasp_height])
            motion.move_tcp([point[0], point[1], point[2] + loop.grasp_height], speed=0.5)
            clearer.cell.set_gripper(0.0)
            motion.hold(loop.close_time)
            clearer.cell.grasp()
            if pairs and not any(c.body.is_grasped for c in lying):
                catch_nearest(world, [c.body for c in lying])  # a layer under: out of the grasp radius
            along = [c for c in lying if c.body.is_grasped]
            extra = max((clearer.hanging_reach(cloth_name(c.number)) for c in along), default=0.0)
            motion.move_tcp([point[0], point[1], top + loop.lift_height])
            carry_over_box(motion, place.centre, top, loop, extra, motion.tcp_position())
            reach = hanging_reach(models[name].points_in, grasp_model)
            start, before = world.time, clearer.box_heap(box)
            release_into_box(motion, clearer.cell, place.centre, top, loop, reach + extra, before)
            released = world.time - start
            attempt = AttemptState(None, place, np.eye(4), start, lost_name=name)
            clearer.check_box(attempt)  # the job's look: heap, rim, laid again where over a wall
            note = "; ".join(n for n in attempt.notes if "over the" in n or "laid again" in n)
            off = float(np.hypot(*(point[:2] - nodes[:, :2].mean(axis=0))))
            held.append((cloth, name, reach, off, before, released, False, note))
            held += [(c, cloth_name(c.number), extra, off, before, released, True, note) for c in along]
            boxed |= {cloth.number, *(c.number for c in along)}
            motion.move_to_joints(clearer.observation_joints)
        motion.hold(2.0)
        walls = next(b for b in world.boxes if b.name == box)
        return tuple(
            ReleasedCloth(
                name,
                reach,
                off,
                before,
                *final_place(world, cloth.body),
                1.0 - float(np.mean(walls.over_floor(cloth.body.nodes()))),
                released,
                came_along,
                note,
            )
            for cloth, name, reach, off, before, released, came_along, note in held
        )


def _trial_grasp(
    cloth: PileCloth, others: list[PileCloth], edge: float, rng: np.random.Generator, together: bool = False
) -> FloatArray:
    """A node of `cloth` for `release_trial`: at least `APART` from `others`' nodes (with
    `together`: within `TOGETHER` of them), any where none is, among the share `edge` of
    those farthest from its centroid."""
    nodes = cloth.body.nodes()
    gap = np.full(len(nodes), np.inf)
    for other in others:
        near = other.body.nodes()[:, :2]
        gap = np.minimum(gap, np.min(np.linalg.norm(nodes[:, None, :2] - near[None], axis=2), axis=1))
    wanted = gap <= TOGETHER if together else gap > APART
    choice = np.flatnonzero(wanted) if wanted.any() else np.arange(len(nodes))
    far = np.linalg.norm(nodes[choice, :2] - nodes[:, :2].mean(axis=0), axis=1)
    keep = max(1, round(edge * len(choice)))
    return nodes[choice[np.argsort(-far)[:keep]][int(rng.integers(keep))]].copy()


def _visible(world: World, pile: Pile) -> dict[str, float]:
    """Per pile cloth, its truly seen pixels in the right camera over its flat outline's."""
    camera, pose = world.stereo.true_rig.right, world.robot.frame_pose(RIGHT_FRAME)
    seen = segmentation(world.client, camera, pose, world.config.cameras.near, world.config.cameras.far)
    world_to_camera = invert_transform(pose)
    shares = {}
    for cloth in pile.cloths:
        outline = transform_points(world_to_camera, cloth.body.outline_world())
        whole = np.zeros(seen.shape, np.uint8)
        cv2.fillPoly(whole, [np.round(camera.project(outline)).astype(np.int32)], 1)
        shares[cloth_name(cloth.number)] = float(
            np.count_nonzero(seen == cloth.body.body_id) / max(int(np.count_nonzero(whole)), 1)
        )
    return shares


def _recognition_settings(config: ClearTableConfig) -> RecognitionSettings:
    """The recogniser's settings with the depth narrowed to the table and the pile on it."""
    height = config.world.observation.height
    data = config.recognition.model_dump()
    data["propose"]["bounds"].update(
        z=(height - config.pile_height, height + config.depth_below), max_tilt_deg=config.table_tilt_deg
    )
    data["propose"]["tracking"]["depth_window"] = config.tracking_depth_window
    try:
        return RecognitionSettings.model_validate(data)
    except ValueError as err:  # pragma: no cover - the bounds are validated above
        raise ConfigError(f"recognition bounds from pile_height/depth_below: {err}") from err


@functools.lru_cache(maxsize=64)
def _cached_model(world_json: str, model_json: str, number: int) -> ClothModel:
    world = WorldConfig.model_validate_json(world_json)
    settings = ModelSettings.model_validate_json(model_json)
    with ModelStation.for_world(world) as station:
        photo = station.photograph(cloth_spec(number))
    return make_model(
        photo.photo_bgr, photo.model_camera, photo.background_bgr, settings, name=cloth_name(number)
    )


def _model(world: WorldConfig, settings: ModelSettings, number: int) -> ClothModel:
    """Cloth No.`number`'s photo model (made once per process and settings)."""
    return _cached_model(world.model_dump_json(), settings.model_dump_json(), number)


__all__ = [
    "ClearTableConfig",
    "ClearTableEpisode",
    "FirstSurvey",
    "ReleasedCloth",
    "first_survey",
    "release_trial",
    "run_clear_table",
]
