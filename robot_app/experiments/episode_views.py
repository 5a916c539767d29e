"""What a person can watch of a simulated episode: the MP4 video and the Rerun recording.

`EpisodeViews` turns the loop's callbacks (`on_phase`, `on_step`, `on_recognition`) into
video frames and recording entries, computing each vision cycle's outlines once for
both. Any job that runs `PickPlaceLoop` in a `World` (one episode, a multi-cloth job,
a conveyor run) can use it: it needs the world, the loop's cell, the target model and
the loop's limits, and the true pose of the target when the simulator knows it.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from robot_app.arrays import FloatArray
from robot_app.control.episode import EpisodeResult, PhaseRecord, VisionCycle
from robot_app.control.limits import JointLimits
from robot_app.experiments.recording import EpisodeRecorder
from robot_app.experiments.recording_scene import SceneSampler, cell_layout, robot_bodies
from robot_app.geometry import invert_transform
from robot_app.sim import EpisodeVideo, SimCell, VisionOverlay, World
from robot_app.vision import ClothModel, ProjectedOutline, model_outline, project_outline


class CellViews:
    """The video and/or the recording of a job in a simulated cell; both optional.

    The parts every job shares: the writers, the layout of the cell in the recording, scene
    samples and frames each control step, phases, a vision cycle drawn with its recognised
    (and true) outline, and closing both writers whole. `EpisodeViews` (one pick and place)
    and `clear_table_views.TableViews` (a cloth per pick) add what their job knows.

    Args:
        world: the simulated cell, with its cloths in place.
        cell: the job's cell adapter.
        limits: the loop's joint limits (the joint plots are shares of them).
        video_file: write the MP4 there, or None.
        record_file: write the .rrd there, or None.
        name: the recording's name in the viewer.
    """

    def __init__(
        self,
        world: World,
        cell: SimCell,
        limits: JointLimits,
        video_file: Path | None,
        record_file: Path | None,
        name: str,
    ) -> None:
        self.world = world
        self.rig = world.stereo.rig
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
        """True if there is anything to write."""
        return self.video is not None or self.recorder is not None

    @property
    def video_frames(self) -> int:
        """Frames written to the video so far (0 without a video)."""
        return 0 if self.video is None else self.video.frames

    def on_phase(self, record: PhaseRecord) -> None:
        """A finished phase (the loop's `on_phase`)."""
        if self.recorder is not None:
            self.recorder.log_phase(record)

    def _step(self, label: str) -> None:
        """After a control step: scene samples and video frames that are due."""
        if self.sampler is not None:
            self.sampler.tick()
        if self.video is not None:
            self.video.tick(label)

    def _show_cycle(
        self,
        cycle: VisionCycle,
        outline: tuple,
        true_pose: FloatArray | None,
        label: str = "",
        prefix: str | None = None,
    ) -> None:
        """A vision cycle: outlines projected once, then the recording and the video.

        Args:
            cycle: what the loop saw and concluded.
            outline: the model's outline (`model_outline`).
            true_pose: the cloth's true 4x4 pose in Σ_W (simulation), or None.
            label: put before the video caption (the cloth meant).
            prefix: the recording's entity prefix for the cloth (None: the default).
        """
        capture = cycle.capture
        recognised = project_outline(self.rig, cycle.recognition.transform_model_to_camera, outline)
        true: ProjectedOutline | None = None
        if true_pose is not None:
            to_camera = invert_transform(capture.transform_right_camera_to_world) @ true_pose
            true = project_outline(self.rig, to_camera, outline)
        if self.recorder is not None:
            left_pose = capture.transform_right_camera_to_world @ self.rig.transform_left_to_right
            extra = {} if prefix is None else {"prefix": prefix}
            self.recorder.log_vision_cycle(cycle, left_pose, recognised, true, true_pose, **extra)
        if self.video is not None:
            r, record = cycle.recognition, cycle.record
            verdict = "accepted" if record.accepted else "rejected"
            caption = (
                f"{label}{record.mode} at {capture.time:.2f} s: {verdict}",
                f"fitness {r.fitness:.2f}  confidence {r.confidence:.2f}",
            )
            self.video.show_vision(
                VisionOverlay(capture.left_bgr, capture.right_bgr, recognised, true, caption, record.accepted)
            )

    def close(self) -> None:
        """Closes the video and finalises the recording (both kept whole)."""
        try:
            if self.video is not None:
                self.video.close()
        finally:
            if self.recorder is not None:
                self.recorder.close()


class EpisodeViews(CellViews):
    """The video and/or the recording of one pick-and-place episode; both optional.

    Args:
        world: the simulated cell, with its cloths in place.
        cell: the loop's cell adapter.
        model: the target's photo model (its outline is drawn).
        limits: the loop's joint limits (the joint plots are shares of them).
        video_file: write the MP4 there, or None.
        record_file: write the .rrd there, or None.
        ground_truth: the target's true 4x4 pose in Σ_W now, or None (no true outline).
        name: the recording's name in the viewer.
    """

    def __init__(
        self,
        world: World,
        cell: SimCell,
        model: ClothModel,
        limits: JointLimits,
        *,
        video_file: Path | None = None,
        record_file: Path | None = None,
        ground_truth: Callable[[], FloatArray] | None = None,
        name: str = "pick-place episode",
    ) -> None:
        super().__init__(world, cell, limits, video_file, record_file, name)
        self.ground_truth = ground_truth
        self.outline = model_outline(model)
        if self.recorder is not None:
            self.recorder.log_target(self.outline)

    def on_step(self, phase: str) -> None:
        """After a control step: scene samples and video frames that are due."""
        self._step(phase)

    def on_recognition(self, cycle: VisionCycle) -> None:
        """A vision cycle (the loop's `on_recognition`): outlines once, then video and recording."""
        true_pose = self.ground_truth() if self.ground_truth is not None else None
        self._show_cycle(cycle, self.outline, true_pose)

    def finish(self, result: EpisodeResult, end_time: float) -> None:
        """The outcome as the recording's last text entry (after the simulator's verdict)."""
        if self.recorder is None:
            return
        placed = (
            ""
            if result.placed_fraction is None
            else f"; {result.placed_fraction:.0%} of the cloth in the box"
        )
        verdict = "SUCCESS" if result.success else "FAILED"
        text = f"{verdict}: {result.outcome.value} ({result.reason}){placed}; collisions {result.collisions}"
        self.recorder.log_outcome(end_time, text, result.success)


__all__ = ["CellViews", "EpisodeViews"]
