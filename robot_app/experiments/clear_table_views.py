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
from robot_app.control.episode import VisionCycle
from robot_app.control.limits import JointLimits
from robot_app.experiments.clear_table_judge import TableVerdict
from robot_app.experiments.episode_views import CellViews
from robot_app.sim import ClothBody, SimCell, World
from robot_app.vision import ClothModel, model_outline


class TableViews(CellViews):
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
        super().__init__(world, cell, limits, video_file, record_file, name)
        self.models = models
        self.truth = truth
        self._outlines: dict[str, tuple] = {}

    def on_step(self, phase: str, meant: str | None) -> None:
        self._step(phase if meant is None else f"{meant}: {phase}")

    def on_recognition(self, cycle: VisionCycle, meant: str) -> None:
        true_pose = self.truth[meant].pose() if meant in self.truth else None
        self._show_cycle(cycle, self._outline(meant), true_pose, f"{meant} ", f"cloths/{meant}")

    def finish(self, result: TableResult, verdict: TableVerdict, end_time: float) -> None:
        if self.recorder is None:
            return
        text = f"{'CLEARED' if verdict.cleared else 'NOT CLEARED'}: {verdict.cause or result.stop_reason}"
        self.recorder.log_outcome(end_time, text, verdict.cleared)

    def _outline(self, name: str) -> tuple:
        if name not in self._outlines:
            self._outlines[name] = model_outline(self.models[name])
            if self.recorder is not None:
                self.recorder.log_target(self._outlines[name], prefix=f"cloths/{name}")
        return self._outlines[name]


__all__ = ["TableViews"]
