"""Typed records of one pick-and-place episode: phases, recognitions, tracking, grasps, outcome.

`judge_success` is the one place an episode's success is decided.
"""

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
    # refused before the start: the belt takes the cloth away too soon, or no hand can close
    # on a lost cloth where it lies (clear-table's blind grasp, `table_furniture.graspable`)
    UNREACHABLE = "unreachable"


class Strategy(StrEnum):
    """How the loop goes from a recognised cloth to a grasp (`loop.strategy`)."""

    SERVO = "servo"  # predict to when the command acts, intercept, track down to the grasp
    LOOK_THEN_MOVE = "look_then_move"  # the wave-1 loop: hover over the last estimate, descend blind


SUCCESS_FRACTION = 0.9  # of the cloth's nodes inside the box walls: the cloth counts as placed


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

    time: float  # exposure of the capture [s]
    phase: str  # the phase the result arrived in
    mode: str  # "search" (one-shot GA), "track" (multi-step GA) or "check" (near a known pose, no GA)
    found: bool
    fitness: float
    accepted: bool
    reason: str
    x: float
    y: float
    z: float
    yaw: float
    evaluations: int
    recognition_s: float  # wall time of the recognition [s]
    available_time: float = float("nan")  # cell time the result reached the loop [s]
    dropped: bool = False  # the camera lost the frame triggered then; it came a period late
    error_x_mm: float | None = None
    error_y_mm: float | None = None
    error_z_mm: float | None = None
    error_yaw_deg: float | None = None

    @property
    def age(self) -> float:
        """Exposure to arrival in the loop [s]: camera latency plus recognition time."""
        return self.available_time - self.time


@dataclass(frozen=True)
class TrackingRecord:
    """The filtered cloth pose against the truth at one vision tick (simulation only).

    Attributes:
        time: cell time [s] the estimate was predicted to.
        phase: loop phase.
        error_x_mm, error_y_mm: filtered minus true position of Σ_M in Σ_W [mm].
        error_yaw_deg: filtered minus true yaw [deg], symmetry-aware.
        cloth_speed: the cloth's true speed at that time [m/s] (from the last two ticks).
    """

    time: float
    phase: str
    error_x_mm: float
    error_y_mm: float
    error_yaw_deg: float
    cloth_speed: float = float("nan")

    @property
    def error_xy_mm(self) -> float:
        return float(np.hypot(self.error_x_mm, self.error_y_mm))


@dataclass(frozen=True)
class GraspRecord:
    """Where the fingers closed, against where the loop meant to close them.

    Attributes:
        attempt: 1 for the first grasp of the episode.
        time: cell time of the closure [s].
        held: hold measure the cell reported (nodes anchored; 0 = nothing).
        tcp_speed: commanded TCP speed at closure [m/s] (a moving cloth: about the belt's).
        offset_mm: TCP to the intended grasp point on the true cloth, in the cloth's plane
            [mm] (None without ground truth); for a symmetric cloth, the nearest of the
            points its symmetric poses put there (the loop may have seen it turned).
        offset_xy: the same offset as TCP minus that point, (x, y) in Σ_W [m].
    """

    attempt: int
    time: float
    held: int
    tcp_speed: float
    offset_mm: float | None = None
    offset_xy: tuple[float, float] | None = None


@dataclass(frozen=True)
class VisionCycle:
    """One vision cycle as the loop lived it, handed to observers (recordings, videos, live views).

    The loop calls `on_recognition(cycle)` once per row of `EpisodeResult.recognitions`, in
    order, right after the row is made: the n-th call is the n-th row. Observers must not
    keep mutable state of the loop; everything here is a value or a read-only array.

    Attributes:
        record: the row this cycle adds to the episode's recognitions.
        capture: the stereo pair the recogniser looked at, with the right camera's pose at
            capture (exposure) time.
        recognition: the recogniser's full result (fitness, confidence, ^CR T_M, ...).
        transform_model_to_world: (4, 4) the recognised pose of Σ_M in Σ_W [m] (turned onto
            the filter's symmetry branch when tracking).
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
        outcome: how it ended.
        success: decided once, by `judge_success`.
        placed_fraction: fraction of the cloth's nodes inside the box at the end (sim).
        limit_report: limit check over every commanded sample.
        sim_time: simulated duration [s]; wall_s: wall-clock duration [s].
        strategy: the loop's strategy ("servo", "look_then_move").
        tracking: filtered-pose errors against the truth during APPROACH and DESCEND (sim).
        grasps: one record per closure of the gripper.
        grasp_offsets: per grasp with ground truth, its `GraspRecord.offset_xy` [m].
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
    strategy: str = Strategy.SERVO.value
    tracking: tuple[TrackingRecord, ...] = field(repr=False, default=())
    grasps: tuple[GraspRecord, ...] = ()

    @property
    def grasp_offsets(self) -> tuple[tuple[float, float], ...]:
        return tuple(g.offset_xy for g in self.grasps if g.offset_xy is not None)

    @classmethod
    def not_started(cls, outcome: Outcome, reason: str, strategy: str) -> EpisodeResult:
        """The result of an episode refused before its first command (e.g. UNREACHABLE)."""
        report = LimitReport(0, 0, 0, 0, 0, 0.0, 0.0, 0.0, 0.0)
        return cls(
            outcome=outcome,
            success=False,
            reason=reason,
            placed_fraction=None,
            sim_time=0.0,
            wall_s=0.0,
            phases=(),
            recognitions=(),
            limit_report=report,
            commanded_samples=0,
            collisions=0,
            grasp_attempts=0,
            observe_returns=0,
            filter_accepted=0,
            filter_rejected=0,
            strategy=strategy,
        )

    def summary(self) -> dict[str, Any]:
        """JSON-friendly summary (no per-sample data)."""

        def stats(values: tuple[float, ...]) -> dict[str, float | None]:
            if not values:
                return {"median": None, "max": None, "count": 0}
            return {"median": float(np.median(values)), "max": float(np.max(values)), "count": len(values)}

        def quantiles(values: list[float]) -> dict[str, float | None]:
            if not values:
                return {"median": None, "p95": None, "count": 0}
            median, p95 = float(np.median(values)), float(np.percentile(values, 95))
            return {"median": median, "p95": p95, "count": len(values)}

        offsets = [g.offset_mm for g in self.grasps if g.offset_mm is not None]
        return {
            "outcome": self.outcome.value,
            "success": self.success,
            "reason": self.reason,
            "strategy": self.strategy,
            "placed_fraction": self.placed_fraction,
            "sim_time_s": self.sim_time,
            "wall_s": self.wall_s,
            "commanded_samples": self.commanded_samples,
            "limit_violations": self.limit_report.violations,
            "limits": _limit_dict(self.limit_report),
            "collisions": self.collisions,
            "grasp_attempts": self.grasp_attempts,
            "observe_returns": self.observe_returns,
            "filter_accepted": self.filter_accepted,
            "filter_rejected": self.filter_rejected,
            "recognitions": len(self.recognitions),
            "ruckig_us": stats(self.ruckig_times_us),
            "ik_ms": stats(self.ik_times_ms),
            "final_cloth_pose": self.final_pose,
            "tracking_error_xy_mm": quantiles([t.error_xy_mm for t in self.tracking]),
            "grasp_offset_mm": offsets,
            "recognition_age_s": quantiles([r.age for r in self.recognitions if np.isfinite(r.age)]),
            "phases": [asdict(p) for p in self.phases],
        }


def judge_success(
    outcome: Outcome,
    *,
    limit_violations: int,
    collisions: int,
    grasp_attempts: int,
    placed_fraction: float | None,
    target_present: bool = True,
) -> bool:
    """The one decision whether an episode succeeded.

    With the target present: it was placed (outcome PLACED), no commanded sample broke a
    limit, the arm touched nothing, and, when the cell can tell (`placed_fraction` not
    None, simulation), at least SUCCESS_FRACTION of the cloth lies in the box. With the
    target absent: saying NOT_PRESENT without a grasp.
    """
    if not target_present:
        return outcome is Outcome.NOT_PRESENT and grasp_attempts == 0
    placed = placed_fraction is None or placed_fraction >= SUCCESS_FRACTION
    return outcome is Outcome.PLACED and limit_violations == 0 and collisions == 0 and placed


def _limit_dict(report: LimitReport) -> dict[str, Any]:
    return {
        key: float(value) if isinstance(value, float) else value for key, value in report._asdict().items()
    }


__all__ = [
    "SUCCESS_FRACTION",
    "EpisodeAbortError",
    "EpisodeResult",
    "GraspRecord",
    "Outcome",
    "Phase",
    "PhaseRecord",
    "RecognitionRecord",
    "Strategy",
    "TrackingRecord",
    "VisionCycle",
    "judge_success",
]
