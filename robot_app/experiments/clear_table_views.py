"""What a person can watch of a clear-table job: one video and one recording for all cloths.

Like `EpisodeViews` for one pick and place, but the target changes from pick to pick:
each cloth gets its own entities in the recording (`cloths/No.n/recognised|filtered|true`,
`cloths/No.n/grasp_point`, logged when the cloth is first picked at), the video's
overlay names the cloth meant and the phase (also "survey", "lift check", "put back",
"box check"), and the end shows the simulator's verdict.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from robot_app.control.clear_table_records import TableResult
from robot_app.control.episode import PhaseRecord, VisionCycle
from robot_app.control.limits import JointLimits
from robot_app.experiments.clear_table_judge import TableVerdict
from robot_app.experiments.recording import EpisodeRecorder
from robot_app.experiments.recording_scene import SceneSampler, cell_layout, robot_bodies
from robot_app.geometry import invert_transform
from robot_app.sim import ClothBody, EpisodeVideo, SimCell, VisionOverlay, World
from robot_app.vision import ClothModel, ProjectedOutline, model_outline, project_outline


class TableViews:
    """The video and/or the recording of one job; both optional.

    Args:
        world: the cell with its pile in place.
        cell: the job's cell adapter.
        models: the known cloths' models, by name.
        limits: the joint limits (the joint plots are shares of them).
        video_file, record_file: where to write, or None.
        truth: model name -> the cloth's soft body (simulation: true outlines).
        name: the recording's name.
    """

    def __init__(
        self,
        world: World,
        cell: SimCell,
        models: Mapping[str, ClothModel],
        limits: JointLimits,
        video_file: Path | None,
        record_file: Path | None,
        truth: Mapping[str, ClothBody],
        name: str,
    ) -> None:
        self.world = world
        self.rig = world.stereo.rig
        self.models = models
        self.truth = truth
        self._outlines: dict[str, tuple] = {}
        self.video = EpisodeVideo(world, cell, video_file) if video_file is not None else None
        self.recorder: EpisodeRecorder | None = None
        self.sampler: SceneSampler | None = None
        if record_file is not None:
            self.recorder = EpisodeRecorder(record_file, name=name)
            bodies = robot_bodies(world)
            self.recorder.log_layout(cell_layout(world, limits, bodies))
            self.sampler = SceneSampler(world, self.recorder, bodies)

    @property
    def active(self) -> bool:
        return self.video is not None or self.recorder is not None

    @property
    def video_frames(self) -> int:
        return 0 if self.video is None else self.video.frames

    def on_phase(self, record: PhaseRecord) -> None:
        if self.recorder is not None:
            self.recorder.log_phase(record)

    def on_step(self, phase: str, meant: str | None) -> None:
        if self.sampler is not None:
            self.sampler.tick()
        if self.video is not None:
            self.video.tick(phase if meant is None else f"{meant}: {phase}")

    def on_recognition(self, cycle: VisionCycle, meant: str) -> None:
        outline = self._outline(meant)
        capture = cycle.capture
        recognised = project_outline(self.rig, cycle.recognition.transform_model_to_camera, outline)
        true: ProjectedOutline | None = None
        true_pose = None
        if meant in self.truth:
            true_pose = self.truth[meant].pose()
            to_camera = invert_transform(capture.transform_right_camera_to_world) @ true_pose
            true = project_outline(self.rig, to_camera, outline)
        if self.recorder is not None:
            left_pose = capture.transform_right_camera_to_world @ self.rig.transform_left_to_right
            self.recorder.log_vision_cycle(
                cycle, left_pose, recognised, true, true_pose, prefix=f"cloths/{meant}"
            )
        if self.video is not None:
            r, record = cycle.recognition, cycle.record
            verdict = "accepted" if record.accepted else "rejected"
            caption = (
                f"{meant} {record.mode} at {capture.time:.2f} s: {verdict}",
                f"fitness {r.fitness:.2f}  confidence {r.confidence:.2f}",
            )
            self.video.show_vision(
                VisionOverlay(capture.left_bgr, capture.right_bgr, recognised, true, caption, record.accepted)
            )

    def finish(self, result: TableResult, verdict: TableVerdict, end_time: float) -> None:
        if self.recorder is None:
            return
        text = f"{'CLEARED' if verdict.cleared else 'NOT CLEARED'}: {verdict.cause or result.stop_reason}"
        self.recorder.log_outcome(end_time, text, verdict.cleared)

    def close(self) -> None:
        try:
            if self.video is not None:
                self.video.close()
        finally:
            if self.recorder is not None:
                self.recorder.close()

    def _outline(self, name: str) -> tuple:
        if name not in self._outlines:
            self._outlines[name] = model_outline(self.models[name])
            if self.recorder is not None:
                self.recorder.log_target(self._outlines[name], prefix=f"cloths/{name}")
        return self._outlines[name]


__all__ = ["TableViews"]
