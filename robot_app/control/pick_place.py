"""The visual-servoing pick-and-place loop and its state machine (paper Sec. I, Fig. 1).

OBSERVE -> SEARCH (one-shot GA) -> APPROACH (each vision cycle: capture, multi-step GA,
pose in the world through the camera pose at capture time, Kalman filter, grasp
target, IK, ruckig replanning) -> DESCEND -> GRASP -> LIFT -> TRANSFER -> RELEASE -> HOME.

Failures are states, not exceptions: target lost -> back to OBSERVE; target not found
-> "not present"; IK unreachable -> abort with the reason; grasp missed -> retry. The
loop talks to the world only through a `Cell` (control period `cell.dt`, vision at
`vision_rate_hz` of cell time); every commanded joint sample is kept and checked
against the position, velocity, acceleration and jerk limits at the end.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial

import numpy as np
import numpy.typing as npt
from pydantic import Field

from robot_app.arrays import FloatArray
from robot_app.config import StrictModel
from robot_app.control.cell import Cell, StereoCapture
from robot_app.control.episode import (
    EpisodeAbortError,
    EpisodeResult,
    Outcome,
    Phase,
    PhaseRecord,
    RecognitionRecord,
    VisionCycle,
)
from robot_app.control.grasp_point import visible_grasp_point
from robot_app.control.kinematics import Kinematics
from robot_app.control.limits import JointLimits, check_limits
from robot_app.control.pose_filter import PoseFilter, PoseFilterSettings
from robot_app.control.trajectory import OnlineTrajectory, plan_point_to_point
from robot_app.errors import InterruptError, TrajectoryError
from robot_app.geometry import (
    invert_transform,
    make_transform,
    pose_error,
    rotation_about_z,
    transform_points,
    yaw_of,
)
from robot_app.vision import ClothModel, Recognition, Recognizer


class LoopSettings(StrictModel):
    """Settings of the loop. Heights are of the TCP [m]; times are cell time [s]."""

    vision_rate_hz: float = Field(15.0, ge=10.0, le=30.0, description="vision cycles per second")
    search_attempts: int = Field(3, ge=1, description="one-shot GA runs before 'not present'")
    candidate_confidence: float = Field(
        0.05,
        ge=0.0,
        le=1.0,
        description="recognition confidence below 'found' (recognition.decide.threshold) but at least "
        "this: centre the cameras on the candidate and look again",
    )
    max_observe_returns: int = Field(2, ge=0, description="returns to OBSERVE after losing the cloth")
    grasp_retries: int = Field(2, ge=0, description="new attempts after a missed grasp")
    min_accepted_updates: int = Field(3, ge=1, description="fused recognitions before descending")
    approach_tolerance: float = Field(0.004, gt=0.0, description="TCP to target to end APPROACH [m]")
    approach_timeout: float = Field(6.0, gt=0.0)
    settle_time: float = Field(0.3, ge=0.0, description="wait after arriving at the observation pose")
    pregrasp_height: float = Field(0.08, gt=0.0, description="TCP above the cloth before the last move")
    grasp_height: float = Field(
        0.022, ge=0.0, description="TCP above the recognised cloth surface (fingertips reach 0.01 below it)"
    )
    min_table_clearance: float = Field(0.02, ge=0.0, description="TCP never lower above the table")
    close_time: float = Field(0.3, gt=0.0, description="time the fingers get to close")
    lift_height: float = Field(0.40, gt=0.05, description="TCP above the table after lifting")
    lift_check: float = Field(0.05, gt=0.0, description="cloth must be this far off the table [m]")
    transfer_height: float = Field(0.40, gt=0.05, description="TCP above the table over the box")
    release_clearance: float = Field(
        0.02, ge=0.0, description="lowest point of the hanging cloth above the box floor when let go [m]"
    )
    min_release_height: float = Field(0.06, gt=0.0, description="TCP never lower than this over the box")
    release_speed: float = Field(0.3, gt=0.0, le=1.0, description="limit scale for lowering into the box")
    release_wait: float = Field(1.0, ge=0.0, description="time for the cloth to fall and settle")
    gripper_open: float = Field(0.08, gt=0.0, le=0.08)
    max_episode_time: float = Field(60.0, gt=0.0)
    ik_time_budget: float = Field(0.02, gt=0.0, description="per IK solve [s]; one retry gets 5x")
    ik_tolerance: float = Field(1e-4, gt=0.0, description="IK position tolerance [m] (and [rad])")
    collision_check_period: float = Field(0.05, gt=0.0, description="[s] between contact checks")
    track_generations: int | None = Field(None, ge=0, description="None: the recogniser's default")


@dataclass
class _Command:
    """Last commanded joint state (positions [rad], velocities, accelerations)."""

    q: FloatArray
    v: FloatArray
    a: FloatArray


PhaseCallback = Callable[[PhaseRecord], None]
StepCallback = Callable[[Cell, StereoCapture | None], None]
RecognitionCallback = Callable[[VisionCycle], None]


class PickPlaceLoop:
    """One robot, one target cloth model, one episode per `run()`.

    Args:
        cell: the robot cell (simulated or real).
        kinematics: arm kinematics with the `tcp` frame, poses in Σ_W.
        recognizer: the target's recogniser (model + rig).
        limits: joint limits every commanded sample must respect.
        observation_joints: joint configuration of the observation pose [rad].
        place_position: (3,) point above which the cloth is released [m] in Σ_W (box floor centre).
        table_z: height of the table top [m].
        settings: loop settings.
        filter_settings: Kalman filter settings.
        on_phase: called with each finished phase (progress lines).
        on_step: called after every control step with the last capture (video).
        on_recognition: called once per recognition, in order, with what the vision cycle
            saw and concluded (`VisionCycle`: recordings, video overlays).
        ground_truth: returns the cloth's true 4x4 pose in Σ_W (simulation only), for the log.
    """

    def __init__(
        self,
        cell: Cell,
        kinematics: Kinematics,
        recognizer: Recognizer,
        limits: JointLimits,
        observation_joints: npt.ArrayLike,
        place_position: npt.ArrayLike,
        table_z: float,
        settings: LoopSettings | None = None,
        filter_settings: PoseFilterSettings | None = None,
        *,
        on_phase: PhaseCallback | None = None,
        on_step: StepCallback | None = None,
        on_recognition: RecognitionCallback | None = None,
        ground_truth: Callable[[], FloatArray] | None = None,
    ) -> None:
        self.cell = cell
        self.kinematics = kinematics
        self.recognizer = recognizer
        self.model: ClothModel = recognizer.model
        self.limits = limits
        self.observation_joints = np.array(observation_joints, dtype=float)
        if not limits.contains(self.observation_joints):
            raise TrajectoryError("the observation joints are outside the trajectory's joint limits")
        self.place_position = np.asarray(place_position, dtype=float).reshape(3)
        self.table_z = float(table_z)
        self.settings = settings or LoopSettings()
        self.filter = PoseFilter(filter_settings, tuple(self.model.symmetry_angles))
        self.on_phase = on_phase
        self.on_step = on_step
        self.on_recognition = on_recognition
        self.ground_truth = ground_truth
        # the hand keeps the observation orientation: cameras look straight down throughout
        self.tcp_rotation = kinematics.frame_pose(self.observation_joints, "tcp")[:3, :3].copy()
        self._note = ""
        self._last_capture: StereoCapture | None = None
        self._reset_logs()

    @property
    def current_phase(self) -> Phase:
        """The phase the loop is in."""
        return self._current

    # ------------------------------------------------------------------ episode
    def run(self) -> EpisodeResult:
        """Runs one episode from the current arm state; never raises for a failed pick.

        An `InterruptError` raised by `on_step` (a stop requested by the user) ends the
        episode where it is, with outcome INTERRUPTED and the phases so far.
        """
        self._reset_logs()
        wall_start = time.perf_counter()
        start_time = self.cell.time
        q0 = self.cell.joint_positions()
        self._command = _Command(self._clip(q0), np.zeros(len(q0)), np.zeros(len(q0)))
        outcome, reason = Outcome.PLACED, "cloth released over the box"
        try:
            self._episode()
        except EpisodeAbortError as stop:
            outcome, reason = stop.outcome, stop.reason
        except TrajectoryError as err:
            outcome, reason = Outcome.TRAJECTORY_ERROR, str(err)
        except InterruptError as err:  # raised by on_step at a safe point: end here, as it stands
            outcome, reason = Outcome.INTERRUPTED, f"{err} during {self._current.value}"
        if outcome not in (Outcome.PLACED, Outcome.TIMEOUT, Outcome.INTERRUPTED):
            self._safe_home()
        return self._result(outcome, reason, start_time, wall_start)

    def _episode(self) -> None:
        s = self.settings
        while True:
            self._phase(Phase.OBSERVE, self._observe)
            found = self._phase(Phase.SEARCH, self._search)
            if not found:
                raise EpisodeAbortError(
                    Outcome.NOT_PRESENT, f"the target was not found in {s.search_attempts} searches"
                )
            if not self._phase(Phase.APPROACH, self._approach):
                self.observe_returns += 1
                if self.observe_returns > s.max_observe_returns:
                    raise EpisodeAbortError(
                        Outcome.LOST, f"target lost {self.observe_returns} times during APPROACH"
                    )
                continue
            grasp_xyz = self._grasp_position()
            self._phase(Phase.DESCEND, partial(self._descend, grasp_xyz))
            self._phase(Phase.GRASP, self._grasp)
            if self._phase(Phase.LIFT, partial(self._lift, grasp_xyz)):
                break
            self.cell.release()
            self.cell.set_gripper(s.gripper_open)
            if self.grasp_attempts > s.grasp_retries:
                raise EpisodeAbortError(
                    Outcome.GRASP_FAILED, f"cloth not lifted after {self.grasp_attempts} grasps"
                )
        self._phase(Phase.TRANSFER, self._transfer)
        self._phase(Phase.RELEASE, self._release)
        self._phase(Phase.HOME, lambda: self._move_to_joints(self.observation_joints))

    def _phase(self, phase: Phase, body: Callable[[], object]) -> object:
        start, wall = self.cell.time, time.perf_counter()
        self._current = phase
        note = ""
        try:
            result = body()
            note = self._note
            return result
        finally:
            record = PhaseRecord(phase.value, start, self.cell.time, time.perf_counter() - wall, note)
            self.phases.append(record)
            self._note = ""
            if self.on_phase is not None:
                self.on_phase(record)

    # ------------------------------------------------------------------ phases
    def _observe(self) -> None:
        self.cell.set_gripper(self.settings.gripper_open)
        self._move_to_joints(self.observation_joints)
        self._hold(self.settings.settle_time)

    def _search(self) -> bool:
        s = self.settings
        for attempt in range(s.search_attempts):
            capture, recognition, pose = self._recognize_once(seed=attempt)
            if not recognition.found and recognition.confidence >= s.candidate_confidence:
                # A partial view (image border, occluder) scores low: look again with the
                # cameras centred over the candidate before deciding.
                self._log_recognition(
                    capture, recognition, pose, "search", False, "candidate: looking closer"
                )
                self._move_to_joints(self._solve_tcp(self._centring_position(pose[:3, 3])))
                self._hold(s.settle_time)
                capture, recognition, pose = self._recognize_once(seed=attempt + s.search_attempts)
            accepted = recognition.found
            if accepted:
                self.filter.reset(pose, capture.time)
            self._log_recognition(
                capture, recognition, pose, "search", accepted, "reset" if accepted else "not found"
            )
            if accepted:
                self._note = (
                    f"found with confidence {recognition.confidence:.3f}, fitness {recognition.fitness:.3f} "
                    f"(attempt {attempt + 1})"
                )
                self._last_capture = capture
                return True
            self._move_to_joints(self.observation_joints)
        self._note = "not found"
        return False

    def _recognize_once(self, seed: int) -> tuple[StereoCapture, Recognition, FloatArray]:
        capture = self.cell.capture()
        recognition = self.recognizer.recognize(capture.left_bgr, capture.right_bgr, seed=seed)
        pose = capture.transform_right_camera_to_world @ recognition.transform_model_to_camera
        return capture, recognition, pose

    def _centring_position(self, point: FloatArray) -> FloatArray:
        """TCP position (at the observation height) that puts the right camera above `point`."""
        tcp = self.kinematics.frame_pose(self.observation_joints, "tcp")[:3, 3]
        camera = self.kinematics.frame_pose(self.observation_joints, "camera_right_optical")[:3, 3]
        return np.array([point[0] - (camera[0] - tcp[0]), point[1] - (camera[1] - tcp[1]), tcp[2]])

    def _approach(self) -> bool:
        """Servo the TCP above the grasp point at the observation height; False if lost."""
        s = self.settings
        online = OnlineTrajectory(self.limits, self.cell.dt, self._command.q)
        online.reset(self._command.q, self._command.v, self._command.a)
        period = 1.0 / s.vision_rate_hz
        start = self.cell.time
        next_vision = self.cell.time
        accepted_updates = 0
        target_xyz: FloatArray | None = None
        previous = self._last_capture
        if previous is None:
            raise EpisodeAbortError(Outcome.LOST, "APPROACH needs the capture the cloth was found in")
        while True:
            if self.cell.time >= next_vision:
                next_vision += period
                capture = self.cell.capture()
                motion = invert_transform(capture.transform_right_camera_to_world) @ (
                    previous.transform_right_camera_to_world
                )
                recognition = self.recognizer.track(
                    capture.left_bgr, capture.right_bgr, motion, generations=s.track_generations
                )
                previous = capture
                pose = capture.transform_right_camera_to_world @ recognition.transform_model_to_camera
                update = self.filter.update(pose, recognition.fitness, capture.time)
                self._log_recognition(
                    capture, recognition, pose, "track", update.accepted, str(update.reason), update.nis
                )
                if self.filter.lost:
                    self._note = f"lost after {self.filter.consecutive_rejections} rejected recognitions"
                    self._finish_online(online)
                    return False
                if update.accepted:
                    accepted_updates += 1
                    target_xyz = self._hover_position()
                    q_goal = self._solve_tcp(target_xyz)
                    online.set_target(q_goal)
            sample = online.step()
            self._send(sample.q, sample.v, sample.a)
            if target_xyz is not None and accepted_updates >= s.min_accepted_updates and online.finished:
                reached = self.kinematics.frame_pose(self._command.q, "tcp")[:3, 3]
                if np.linalg.norm(reached - target_xyz) <= s.approach_tolerance:
                    self._note = f"{accepted_updates} fused recognitions"
                    self._record_online(online)
                    return True
            if self.cell.time - start > s.approach_timeout:
                self._note = f"no stable target within {s.approach_timeout:.1f} s"
                self._finish_online(online)
                return False

    def _descend(self, grasp_xyz: FloatArray) -> None:
        s = self.settings
        self.cell.set_gripper(s.gripper_open)
        above = grasp_xyz + np.array([0.0, 0.0, s.pregrasp_height])
        self._move_to_joints(self._solve_tcp(above))
        self._move_to_joints(self._solve_tcp(grasp_xyz))

    def _grasp(self) -> None:
        self.grasp_attempts += 1
        self.cell.set_gripper(0.0)
        if self.ground_truth is not None:  # where the fingers close against where they were meant to
            self.grasp_offsets.append(self._grasp_offset(self.ground_truth()))
        self._hold(self.settings.close_time)
        held = self.cell.grasp()
        self._note = f"attempt {self.grasp_attempts}: {held} hold points"

    def _grasp_offset(self, transform_model_to_world: FloatArray) -> tuple[float, float]:
        """TCP minus the true grasp point, (x, y) [m]; for a symmetric cloth, the nearest of
        the points its symmetric poses put there (the loop may have seen it half-turned)."""
        tcp = self.kinematics.frame_pose(self.cell.joint_positions(), "tcp")[:3, 3]
        offsets = []
        for angle in (0.0, *self.model.symmetry_angles):
            turned = transform_model_to_world @ make_transform(rotation_about_z(angle), np.zeros(3))
            meant = transform_points(turned, self._grasp_point_model[None])[0]
            offsets.append((float(tcp[0] - meant[0]), float(tcp[1] - meant[1])))
        return min(offsets, key=lambda d: np.hypot(*d))

    def _lift(self, grasp_xyz: FloatArray) -> bool:
        lifted = np.array([grasp_xyz[0], grasp_xyz[1], self.table_z + self.settings.lift_height])
        self._move_to_joints(self._solve_tcp(lifted))
        holding = self.cell.holding()
        self._note = "cloth lifted" if holding else "grasp missed: cloth not lifted"
        return holding

    def _transfer(self) -> None:
        over = self.place_position.copy()
        over[2] = self.table_z + self.settings.transfer_height
        self._move_to_joints(self._solve_tcp(over))

    def _release(self) -> None:
        s = self.settings
        # Lower the cloth until its lowest point (at most its longest reach from the grasp
        # point below the fingers) is just above the floor, slowly: a soft body that hits
        # the table fast goes through it.
        reach = float(
            np.max(np.linalg.norm(self.model.points_in[:, :2] - self._grasp_point_model[:2], axis=1))
        )
        low = self.place_position.copy()
        low[2] = self.table_z + max(s.min_release_height, s.grasp_height + reach + s.release_clearance)
        self._move_to_joints(self._solve_tcp(low), speed=s.release_speed)
        self.cell.release()
        self._hold(s.release_wait)  # let the cloth fall clear before the fingers open
        self.cell.set_gripper(s.gripper_open)

    # ------------------------------------------------------------------ targets
    def _hover_position(self) -> FloatArray:
        """TCP above the current grasp estimate, at the observation height."""
        grasp = self._grasp_position()
        hover_z = self.kinematics.frame_pose(self.observation_joints, "tcp")[2, 3]
        return np.array([grasp[0], grasp[1], hover_z])

    def _grasp_position(self) -> FloatArray:
        """TCP position for grasping: the model's grasp point under the filtered pose."""
        estimate = self.filter.estimate
        if estimate is None:
            raise EpisodeAbortError(Outcome.LOST, "no filtered cloth pose to grasp")
        pose = estimate.as_transform()
        point = transform_points(pose, self._grasp_point_model[None])[0]
        z = max(point[2] + self.settings.grasp_height, self.table_z + self.settings.min_table_clearance)
        return np.array([point[0], point[1], z])

    def _solve_tcp(self, position: FloatArray) -> FloatArray:
        target = make_transform(self.tcp_rotation, position)
        for budget in (self.settings.ik_time_budget, 5 * self.settings.ik_time_budget):
            result = self.kinematics.solve_ik(
                target,
                self._command.q,
                frame="tcp",
                time_budget=budget,
                position_tolerance=self.settings.ik_tolerance,
                orientation_tolerance=self.settings.ik_tolerance,
                preferred_posture=self.observation_joints,
            )
            self.ik_times_ms.append(result.time_s * 1e3)
            if result.success and self.limits.contains(result.q):
                break
        if not result.success or not self.limits.contains(result.q):
            where = ", ".join(f"{v:.3f}" for v in position)
            raise EpisodeAbortError(
                Outcome.IK_UNREACHABLE,
                f"no IK solution within the joint limits for the TCP at ({where}) m: "
                f"residual {result.position_error * 1e3:.1f} mm, "
                f"{np.rad2deg(result.orientation_error):.2f} deg",
            )
        return np.array(result.q)

    # ------------------------------------------------------------------ motion
    def _move_to_joints(self, q_goal: FloatArray, speed: float = 1.0) -> None:
        """Jerk-limited move to rest at `q_goal`, with the limits scaled by `speed` (0, 1]."""
        trajectory = plan_point_to_point(
            self._command.q,
            q_goal,
            self.limits if speed >= 1.0 else self.limits.scaled(speed),
            v_start=self._command.v,
            a_start=self._command.a,
            dt=self.cell.dt,
        )
        self.ruckig_times_us.append(trajectory.calculation_time_s * 1e6)
        steps = round(trajectory.duration / self.cell.dt)
        for k in range(1, steps + 1):
            sample = trajectory.sample(k * self.cell.dt)
            self._send(sample.q, sample.v, sample.a)
        self._command.v[:] = 0.0
        self._command.a[:] = 0.0

    def _finish_online(self, online: OnlineTrajectory) -> None:
        """Brings an interrupted online motion to rest where it is heading (jerk-limited)."""
        self._record_online(online)
        self._move_to_joints(self._clip(self._command.q))

    def _record_online(self, online: OnlineTrajectory) -> None:
        self.ruckig_times_us.extend(t * 1e6 for t in online.calculation_times)

    def _clip(self, q: FloatArray) -> FloatArray:
        return np.clip(np.asarray(q, dtype=float), self.limits.lower, self.limits.upper)

    def _hold(self, duration: float) -> None:
        for _ in range(round(duration / self.cell.dt)):
            self._send(self._command.q, np.zeros_like(self._command.q), np.zeros_like(self._command.q))

    def _send(self, q: FloatArray, v: FloatArray, a: FloatArray) -> None:
        if self.cell.time - self._episode_start > self.settings.max_episode_time:
            raise EpisodeAbortError(
                Outcome.TIMEOUT, f"episode longer than {self.settings.max_episode_time:.0f} s"
            )
        self._command = _Command(np.array(q, dtype=float), np.array(v, dtype=float), np.array(a, dtype=float))
        self.cell.command_joints(self._command.q, self._command.v)
        self.cell.step()
        self._times.append(self.cell.time)
        self._Q.append(self._command.q)
        self._V.append(self._command.v)
        self._A.append(self._command.a)
        if self.cell.time >= self._next_collision_check:
            self._next_collision_check += self.settings.collision_check_period
            self.collisions += self.cell.collisions()
        if self.on_step is not None:
            self.on_step(self.cell, self._last_capture)

    def _safe_home(self) -> None:
        """After an abort: open, let go and return to the observation pose if possible."""
        try:
            self.cell.release()
            self.cell.set_gripper(self.settings.gripper_open)
            self._move_to_joints(self.observation_joints)
        except (EpisodeAbortError, TrajectoryError):
            pass

    # ------------------------------------------------------------------ logs
    def _reset_logs(self) -> None:
        self.phases: list[PhaseRecord] = []
        self.recognitions: list[RecognitionRecord] = []
        self.ruckig_times_us: list[float] = []
        self.ik_times_ms: list[float] = []
        self._times: list[float] = []
        self._Q: list[FloatArray] = []
        self._V: list[FloatArray] = []
        self._A: list[FloatArray] = []
        self.collisions = 0
        self.grasp_attempts = 0
        self.grasp_offsets: list[tuple[float, float]] = []
        self.observe_returns = 0
        self._note = ""
        self._current = Phase.OBSERVE
        self._episode_start = self.cell.time
        self._next_collision_check = self.cell.time
        self._last_capture = None
        self._grasp_point_model = np.asarray(self.model.grasp_point, dtype=float)

    def _log_recognition(
        self,
        capture: StereoCapture,
        recognition: Recognition,
        pose: FloatArray,
        mode: str,
        accepted: bool,
        reason: str,
        nis: float = math.nan,
    ) -> None:
        self._last_capture = capture
        if mode == "search" and recognition.found:
            self._grasp_point_model = visible_grasp_point(
                self.model,
                self.recognizer.rig,
                recognition.transform_model_to_camera,
                capture,
                self.recognizer.settings.fitness,
            )
        errors: dict[str, float] = {}
        if self.ground_truth is not None:
            error = pose_error(pose, self.ground_truth(), tuple(self.model.symmetry_angles))
            errors = {
                "error_x_mm": error.x_mm,
                "error_y_mm": error.y_mm,
                "error_z_mm": error.z_mm,
                "error_yaw_deg": error.yaw_deg,
            }
        record = RecognitionRecord(
            time=capture.time,
            phase=self._current.value,
            mode=mode,
            found=recognition.found,
            fitness=recognition.fitness,
            accepted=accepted,
            reason=reason,
            x=float(pose[0, 3]),
            y=float(pose[1, 3]),
            z=float(pose[2, 3]),
            yaw=yaw_of(pose[:3, :3]),
            evaluations=recognition.evaluations,
            recognition_s=recognition.time_s,
            **errors,
        )
        self.recognitions.append(record)
        if self.on_recognition is not None:
            grasp_point = self._grasp_point_model.copy()
            grasp_point.setflags(write=False)
            world_pose = np.array(pose, dtype=float)
            world_pose.setflags(write=False)
            self.on_recognition(
                VisionCycle(record, capture, recognition, world_pose, self.filter.estimate, nis, grasp_point)
            )

    def _result(self, outcome: Outcome, reason: str, start_time: float, wall_start: float) -> EpisodeResult:
        n = len(self._times)
        dof = self.limits.dof
        times = np.asarray(self._times) if n else np.zeros(0)
        Q = np.asarray(self._Q).reshape(n, dof)
        V = np.asarray(self._V).reshape(n, dof)
        A = np.asarray(self._A).reshape(n, dof)
        report = check_limits(times, Q, V, A, self.limits, tol=1e-6)
        return EpisodeResult(
            outcome=outcome,
            success=outcome is Outcome.PLACED and report.violations == 0,
            reason=reason,
            placed_fraction=None,
            sim_time=self.cell.time - start_time,
            wall_s=time.perf_counter() - wall_start,
            phases=tuple(self.phases),
            recognitions=tuple(self.recognitions),
            limit_report=report,
            commanded_samples=n,
            collisions=self.collisions,
            grasp_attempts=self.grasp_attempts,
            grasp_offsets=tuple(self.grasp_offsets),
            observe_returns=self.observe_returns,
            filter_accepted=self.filter.accepted_count,
            filter_rejected=self.filter.rejected_count,
            ruckig_times_us=tuple(self.ruckig_times_us),
            ik_times_ms=tuple(self.ik_times_ms),
        )


__all__ = ["LoopSettings", "PickPlaceLoop"]
