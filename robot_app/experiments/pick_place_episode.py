"""One simulated pick-and-place episode from a config: world, scene, model, loop, results.

`run_episode` refuses a belt no robot could keep up with (outcome `unreachable`, see
`conveyor_check`), builds the pybullet cell, lays out the seeded scene, makes the target's
photo model at the Fig. 7 station (through `make_model`, as a real photo would go) and
runs `PickPlaceLoop`, which judges its outcome against the simulator's ground truth
(fraction of the cloth inside the box) once. `write_episode` stores the results folder.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from contextlib import ExitStack
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Literal

import numpy as np
import numpy.typing as npt
from pydantic import Field

from robot_app.config import StrictModel, dump_config
from robot_app.control import (
    SUCCESS_FRACTION,
    EpisodeResult,
    JointLimits,
    Kinematics,
    LoopSettings,
    Outcome,
    Phase,
    PhaseRecord,
    PickPlaceLoop,
    PoseFilterSettings,
    TrajectorySettings,
    observation_posture,
)
from robot_app.errors import ConfigError
from robot_app.experiments.conveyor_check import conveyor_problem
from robot_app.experiments.episode_views import EpisodeViews
from robot_app.experiments.recording import require_rerun
from robot_app.outputs import atomic_path, atomic_write_csv, atomic_write_text, output_folder
from robot_app.sim import (
    ConveyorEncoder,
    ModelStation,
    SceneSettings,
    SimCell,
    World,
    WorldConfig,
    cloth_spec,
    make_scene,
    observation_camera_pose,
)
from robot_app.sim.config import CATALOGUE_SIZE
from robot_app.vision import ClothModel, ModelSettings, RecognitionSettings, Recognizer, make_model


class NudgeSettings(StrictModel):
    """Pushes the target cloth once during a phase (regression test of the filter and replanning).

    Attributes:
        phase: the phase the push happens in (approach or descend).
        after: time into that phase when the cloth is moved [s].
        dx, dy: displacement on the table [m].
    """

    phase: Literal["approach", "descend"] = "approach"
    after: float = Field(0.5, ge=0.0)
    dx: float = 0.03
    dy: float = 0.02


class PickPlaceConfig(StrictModel):
    """The main job's config (`configs/pick_place.yaml`)."""

    seed: int = Field(0, ge=0)
    world: WorldConfig = WorldConfig()
    scene: SceneSettings = SceneSettings()
    model: ModelSettings = ModelSettings()
    recognition: RecognitionSettings = RecognitionSettings()
    filter: PoseFilterSettings = PoseFilterSettings()
    trajectory: TrajectorySettings = TrajectorySettings()
    loop: LoopSettings = LoopSettings()
    model_cloth: int | None = Field(
        None,
        ge=1,
        le=CATALOGUE_SIZE,
        description="cloth the robot looks for (default: scene.target); another = absent",
    )
    table_depth_window: float | None = Field(
        0.015,
        gt=0.0,
        description="the cloth lies on the known table: search depth = observation height ± this [m], "
        "tilt ≤ table_tilt_deg, depth window while tracking = this; None keeps recognition.propose.bounds",
    )
    table_tilt_deg: float = Field(5.0, gt=0.0, le=90.0)
    grasp_radius: float = Field(0.035, gt=0.0, le=0.1, description="nodes anchored around the TCP [m]")
    nudge: NudgeSettings | None = None

    @property
    def wanted(self) -> int:
        """Catalogue number of the cloth the robot is asked to pick."""
        return self.scene.target if self.model_cloth is None else self.model_cloth


@dataclass(frozen=True)
class Episode:
    """A finished episode with the simulator's verdict.

    Attributes:
        result: what the loop measured (placed_fraction filled from the simulator).
        target: catalogue number of the cloth the robot was asked to pick.
        present: that cloth was in the scene (false for absent-target scenes).
        box_centre: centre of the box floor in Σ_W [m].
    """

    result: EpisodeResult
    target: int
    present: bool
    box_centre: tuple[float, float, float]


def run_episode(
    config: PickPlaceConfig,
    *,
    gui: bool = False,
    on_phase: Callable[[PhaseRecord], None] | None = None,
    video_path: str | Path | None = None,
    stop: Callable[[], None] | None = None,
    record_path: str | Path | None = None,
) -> Episode:
    """Runs one pick-and-place episode in a fresh simulated cell.

    Args:
        config: the episode's settings; `config.seed` fixes the scene and the GA.
        gui: show pybullet's GUI.
        on_phase: called after every phase (progress output).
        video_path: write an MP4 of the episode there. It is written under a temporary
            name and renamed when closed, so it is whole (playable) or absent: an episode
            that fails with an error, or ends before its first frame, leaves no file.
        stop: called after every control step; raising `InterruptError` there ends the
            episode at that step with outcome INTERRUPTED (see `stop_at_safe_points`).
        record_path: write a Rerun recording (.rrd) of the episode there (needs the
            `viewer` extra, rerun-sdk). Like the video it is written under a temporary
            name: whole, or absent if the episode fails with an error.
    """
    w = config.world
    if any(abs(v) > 1e-12 for v in (*w.robot.base_xyz, w.robot.base_yaw)):
        raise ConfigError("world.robot.base_xyz/base_yaw: the loop needs the robot base at the world origin")
    if record_path is not None:
        require_rerun()  # before the model and the cell: a missing extra never costs an episode
    kinematics = Kinematics.from_urdf(w.robot.urdf, "base_link", "tcp")
    limits = JointLimits.from_urdf(w.robot.urdf, config.trajectory)
    observation = observation_posture(
        kinematics, limits, observation_camera_pose(w), w.robot.home_joints, config.loop.ik_tolerance
    )
    problem = conveyor_problem(w, config.scene, config.loop, kinematics, limits, observation)
    if problem is not None:
        refused = EpisodeResult.not_started(Outcome.UNREACHABLE, problem, config.loop.strategy.value)
        bx, by = w.box.centre_xy
        return Episode(refused, config.wanted, True, (float(bx), float(by), float(w.table.top_z)))
    model = _make_target_model(config)
    with ExitStack() as stack:
        video_file = stack.enter_context(atomic_path(video_path)) if video_path is not None else None
        record_file = stack.enter_context(atomic_path(record_path)) if record_path is not None else None
        return _run_in_cell(
            config, model, kinematics, limits, observation, gui, on_phase, video_file, record_file, stop
        )


def _run_in_cell(
    config: PickPlaceConfig,
    model: ClothModel,
    kinematics: Kinematics,
    limits: JointLimits,
    observation: npt.NDArray[np.float64],
    gui: bool,
    on_phase: Callable[[PhaseRecord], None] | None,
    video_file: Path | None,
    record_file: Path | None,
    stop: Callable[[], None] | None,
) -> Episode:
    w = config.world
    with World(w, gui=gui) as world:
        world.robot.reset_joints(observation)  # the episode starts at the controller's observation pose
        scene = make_scene(world, config.scene, seed=config.seed)
        present = config.wanted in (config.scene.target, config.scene.distractor)
        wanted_body = scene.target if config.wanted == config.scene.target else scene.distractor
        cell = SimCell(world, grasp_radius=config.grasp_radius)
        recognizer = Recognizer(model, world.stereo.rig, _recognition_settings(config))
        views = EpisodeViews(
            world,
            cell,
            model,
            limits,
            video_file=video_file,
            record_file=record_file,
            ground_truth=wanted_body.pose if wanted_body is not None else None,
            name=f"pick-place No.{config.wanted}, seed {config.seed}",
        )
        nudge = _Nudger(world, scene.target, config.nudge) if config.nudge is not None else None

        def on_step(_cell: object, _capture: object) -> None:
            if nudge is not None:
                nudge.tick(loop.current_phase)
            views.on_step(loop.current_phase.value)
            if stop is not None:
                stop()  # a safe point: between two control steps, the video frame written

        def on_phase_ended(record: PhaseRecord) -> None:
            views.on_phase(record)
            if on_phase is not None:
                on_phase(record)

        judged = wanted_body if wanted_body is not None else scene.target
        encoder = (
            ConveyorEncoder(scene.conveyor, lambda: world.time, config.loop.belt_encoder_std, config.seed)
            if scene.conveyor is not None
            else None
        )
        loop = PickPlaceLoop(
            cell,
            kinematics,
            recognizer,
            limits,
            world.transform_observation_camera_to_world,
            world.box.centre,
            w.table.top_z,
            config.loop,
            config.filter,
            posture_seed=w.robot.home_joints,
            on_phase=on_phase_ended,
            on_step=on_step if (views.active or nudge is not None or stop is not None) else None,
            on_recognition=views.on_recognition if views.active else None,
            ground_truth=wanted_body.pose if wanted_body is not None else None,
            placed_fraction=lambda: world.cloth_in_box(judged),
            target_present=present,
            belt_encoder=encoder,
        )
        try:
            result = loop.run()
            views.finish(result, world.time)
        finally:
            views.close()
        if video_file is not None and views.video_frames == 0:
            video_file.unlink(missing_ok=True)  # no frame, no playable video: leave none
        bx, by, bz = (float(v) for v in world.box.centre)
        return Episode(result, config.wanted, present, (bx, by, bz))


def _recognition_settings(config: PickPlaceConfig) -> RecognitionSettings:
    """The recogniser's settings with the depth narrowed to the known table, if asked."""
    window = config.table_depth_window
    if window is None:
        return config.recognition
    height = config.world.observation.height
    data = config.recognition.model_dump()
    data["propose"]["bounds"].update(z=(height - window, height + window), max_tilt_deg=config.table_tilt_deg)
    data["propose"]["tracking"]["depth_window"] = window
    return RecognitionSettings.model_validate(data)


def _make_target_model(config: PickPlaceConfig) -> ClothModel:
    with ModelStation.for_world(config.world) as station:
        photo = station.photograph(cloth_spec(config.wanted))
    return make_model(
        photo.photo_bgr, photo.model_camera, photo.background_bgr, config.model, name=f"No.{config.wanted}"
    )


class _Nudger:
    """Moves the target cloth once, `after` seconds into the configured phase."""

    def __init__(self, world: World, cloth, config: NudgeSettings) -> None:
        self.world, self.cloth, self.config = world, cloth, config
        self.start: float | None = None
        self.done = False

    def tick(self, phase: Phase) -> None:
        if self.done or phase.value != self.config.phase:
            return
        if self.start is None:
            self.start = self.world.time
        if self.world.time - self.start >= self.config.after:
            self.cloth.translate(self.config.dx, self.config.dy)
            self.done = True


def write_episode(out_dir: str | Path, config: PickPlaceConfig, episode: Episode) -> Path:
    """Writes the results folder: config.yaml, phases.csv, recognitions.csv, summary.json."""
    folder = Path(out_dir)
    result = episode.result
    summary = result.summary() | {
        "target": f"No.{episode.target}",
        "box_centre": episode.box_centre,
        "success_fraction_threshold": SUCCESS_FRACTION,
    }
    with output_folder(folder):  # each file is written whole (temporary name, then renamed)
        dump_config(config, folder / "config.yaml")
        atomic_write_csv(folder / "phases.csv", [asdict(p) | {"duration": p.duration} for p in result.phases])
        atomic_write_csv(folder / "recognitions.csv", [asdict(r) for r in result.recognitions])
        atomic_write_text(folder / "summary.json", json.dumps(summary, indent=2, default=_json_default))
    return folder


def _json_default(value: object) -> object:
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    return str(value)


__all__ = ["SUCCESS_FRACTION", "Episode", "NudgeSettings", "PickPlaceConfig", "run_episode", "write_episode"]
