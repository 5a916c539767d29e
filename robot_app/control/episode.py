"""Typed records of one pick-and-place episode: phases, recognitions, outcome."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from enum import StrEnum
from typing import TYPE_CHECKING, Any

import numpy as np

from robot_app.arrays import FloatArray
from robot_app.control.limits import LimitReport
from robot_app.errors import RobotAppError

if TYPE_CHECKING:
    from robot_app.control.cell import StereoCapture
    from robot_app.control.pose_filter import PoseEstimate
    from robot_app.vision import Recognition


class Phase(StrEnum):
    """States of the pick-and-place state machine, in their usual order."""

    OBSERVE = "observe"
    SEARCH = "search"
    APPROACH = "approach"
    DESCEND = "descend"
    GRASP = "grasp"
    LIFT = "lift"
    TRANSFER = "transfer"
    RELEASE = "release"
    HOME = "home"


class Outcome(StrEnum):
    """How an episode ended. Only PLACED is a pick and place; the rest are reasons."""

    PLACED = "placed"
    NOT_PRESENT = "not_present"
    LOST = "lost"
    IK_UNREACHABLE = "ik_unreachable"
    GRASP_FAILED = "grasp_failed"
    TRAJECTORY_ERROR = "trajectory_error"
    TIMEOUT = "timeout"
    INTERRUPTED = "interrupted"  # the user stopped it (SIGINT/SIGTERM) between two control steps


class EpisodeAbortError(RobotAppError):
    """The loop stopped an episode before the cloth was placed (not found, lost, timeout ...).

    Raised inside the loop and turned into its `EpisodeResult`; never leaves `run()`.

    Attributes:
        outcome: how the episode ended.
        reason: one line saying why.
    """

    def __init__(self, outcome: Outcome, reason: str) -> None:
        super().__init__(reason)
        self.outcome = outcome
        self.reason = reason


@dataclass(frozen=True)
class PhaseRecord:
    """One pass through a phase: simulated start/end [s] and wall time [s]."""

    phase: str
    start_time: float
    end_time: float
    wall_s: float
    note: str = ""

    @property
    def duration(self) -> float:
        return self.end_time - self.start_time


@dataclass(frozen=True)
class RecognitionRecord:
    """One recognition of the loop, in the world frame; errors only with ground truth.

    Units: metres and radians, except the `_mm`/`_deg` error fields for reports.
    """

    time: float
    phase: str
    mode: str  # "search" (one-shot GA) or "track" (multi-step GA)
    found: bool
    fitness: float
    accepted: bool
    reason: str
    x: float
    y: float
    z: float
    yaw: float
    evaluations: int
    recognition_s: float
    error_x_mm: float | None = None
    error_y_mm: float | None = None
    error_z_mm: float | None = None
    error_yaw_deg: float | None = None


@dataclass(frozen=True)
class VisionCycle:
    """One vision cycle as the loop lived it, handed to observers (recordings, videos, live views).

    The loop calls `on_recognition(cycle)` once per row of `EpisodeResult.recognitions`, in
    order, right after the row is made: the n-th call is the n-th row. Observers must not
    keep mutable state of the loop; everything here is a value or a read-only array.

    Attributes:
        record: the row this cycle adds to the episode's recognitions.
        capture: the stereo pair the recogniser looked at, with the right camera's pose at
            capture time.
        recognition: the recogniser's full result (fitness, confidence, ^CR T_M, ...).
        transform_model_to_world: (4, 4) the recognised pose of Σ_M in Σ_W [m].
        filtered: the pose filter's estimate after this cycle; None before its first fix.
        nis: normalised innovation squared of this cycle's filter update [-]; NaN when the
            filter computed none (a search, a (re)initialisation, a too low fitness).
        grasp_point_model: (3,) the point the loop means to grasp, in Σ_M [m].
    """

    record: RecognitionRecord
    capture: StereoCapture
    recognition: Recognition
    transform_model_to_world: FloatArray
    filtered: PoseEstimate | None
    nis: float
    grasp_point_model: FloatArray


@dataclass(frozen=True)
class EpisodeResult:
    """Everything one episode measured.

    Attributes:
        outcome: how it ended; `success` additionally needs the cloth in the box and no
            limit violation.
        placed_fraction: fraction of the cloth's nodes inside the box at the end (sim).
        limit_report: limit check over every commanded sample.
        sim_time: simulated duration [s]; wall_s: wall-clock duration [s].
        grasp_offsets: per grasp, the TCP minus the true position of the cloth point
            the loop meant to grasp, (x, y) in Σ_W [m] (simulation only: needs the truth).
    """

    outcome: Outcome
    success: bool
    reason: str
    placed_fraction: float | None
    sim_time: float
    wall_s: float
    phases: tuple[PhaseRecord, ...]
    recognitions: tuple[RecognitionRecord, ...]
    limit_report: LimitReport
    commanded_samples: int
    collisions: int
    grasp_attempts: int
    observe_returns: int
    filter_accepted: int
    filter_rejected: int
    ruckig_times_us: tuple[float, ...] = field(repr=False, default=())  # every offline plan and online replan
    ik_times_ms: tuple[float, ...] = field(repr=False, default=())
    final_pose: tuple[float, ...] | None = None  # (x, y, z, yaw) of the cloth at the end
    grasp_offsets: tuple[tuple[float, float], ...] = ()

    def summary(self) -> dict[str, Any]:
        """JSON-friendly summary (no per-sample data)."""

        def stats(values: tuple[float, ...]) -> dict[str, float | None]:
            if not values:
                return {"median": None, "max": None, "count": 0}
            return {"median": float(np.median(values)), "max": float(np.max(values)), "count": len(values)}

        return {
            "outcome": self.outcome.value,
            "success": self.success,
            "reason": self.reason,
            "placed_fraction": self.placed_fraction,
            "sim_time_s": self.sim_time,
            "wall_s": self.wall_s,
            "commanded_samples": self.commanded_samples,
            "limit_violations": self.limit_report.violations,
            "limits": _limit_dict(self.limit_report),
            "collisions": self.collisions,
            "grasp_attempts": self.grasp_attempts,
            "grasp_offsets_mm": [[1000 * x, 1000 * y] for x, y in self.grasp_offsets],
            "observe_returns": self.observe_returns,
            "filter_accepted": self.filter_accepted,
            "filter_rejected": self.filter_rejected,
            "recognitions": len(self.recognitions),
            "ruckig_us": stats(self.ruckig_times_us),
            "ik_ms": stats(self.ik_times_ms),
            "final_cloth_pose": self.final_pose,
            "phases": [asdict(p) for p in self.phases],
        }


def _limit_dict(report: LimitReport) -> dict[str, Any]:
    return {
        key: float(value) if isinstance(value, float) else value for key, value in report._asdict().items()
    }


__all__ = [
    "EpisodeAbortError",
    "EpisodeResult",
    "Outcome",
    "Phase",
    "PhaseRecord",
    "RecognitionRecord",
    "VisionCycle",
]
