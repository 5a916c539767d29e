"""The visual-servoing pick-and-place loop and its state machine (paper Sec. I, Fig. 1).

OBSERVE -> SEARCH (one-shot GA on a frame whose result arrives after the camera's and
the recogniser's latency; the servo looks twice, for the cloth's velocity) -> APPROACH
-> DESCEND -> GRASP -> LIFT -> TRANSFER -> RELEASE -> HOME. APPROACH to LIFT belong to
the strategy (`loop.strategy`): `servo`
(`servo.py`: predict the cloth to when the command acts, intercept, track down, grasp it
moving, lift it off the belt) or `look_then_move` (`look_then_move.py`, the baseline).

Failures are states, not exceptions: target lost -> back to OBSERVE; target not found
-> "not present"; IK unreachable -> abort with the reason; grasp missed -> retry. The
loop talks to the world only through a `Cell`; the observation posture comes from the
controller's own IK (`Kinematics`); every commanded joint sample is kept and checked
against the position, velocity, acceleration and jerk limits at the end; success is
decided once, by `judge_success`.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Protocol

import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray
from robot_app.control.arm_motion import ArmMotion
from robot_app.control.cell import BeltEncoder, Cell, StereoCapture
from robot_app.control.cloth_tracker import ClothTracker
from robot_app.control.episode import (
    EpisodeAbortError,
    EpisodeResult,
    GraspRecord,
    Outcome,
    Phase,
    PhaseRecord,
    Strategy,
    VisionCycle,
    judge_success,
)
from robot_app.control.intercept import hanging_reach
from robot_app.control.kinematics import Kinematics
from robot_app.control.limits import JointLimits
from robot_app.control.look_then_move import LookThenMoveStrategy
from robot_app.control.loop_settings import LoopSettings
from robot_app.control.pose_filter import PoseFilterSettings
from robot_app.control.release_watch import wait_until_settled
from robot_app.control.servo import CAMERA_FRAME, ServoStrategy
from robot_app.control.vision_pipeline import VisionPipeline, VisionResult
from robot_app.errors import IKError, InterruptError, TrajectoryError
from robot_app.geometry import make_transform, rotation_about_z, transform_points, yaw_of
from robot_app.vision import Recognizer

PhaseCallback = Callable[[PhaseRecord], None]
StepCallback = Callable[[Cell, StereoCapture | None], None]
RecognitionCallback = Callable[[VisionCycle], None]
LIFTED = "cloth lifted"  # a LIFT phase note that starts so: the gripper holds the cloth off the table
EMPTY_GRASP = "grasp missed: cloth not lifted"  # the LIFT note when the fingers hold nothing
CENTRING_SHARES = (1.0, 0.75, 0.5, 0.25)  # of the way to centre the cameras over a candidate, in turn


class HandMotion(Protocol):
    """What the hand-over to a box needs of an arm mover (`ArmMotion`, `JobMotion`)."""

    def solve_tcp(self, position: npt.ArrayLike) -> FloatArray:
        """Joints putting the TCP at `position` [m], the cameras looking down."""
        ...

    def move_to_joints(self, q_goal: npt.ArrayLike, speed: float = 1.0) -> None:
        """Jerk-limited move to rest at `q_goal` [rad], the limits scaled by `speed`."""
        ...

    def move_slowing_down(self, q_goal: npt.ArrayLike, speed: float, below: float) -> None:
        """Move to rest at `q_goal` [rad], the limits scaled by `speed` once the TCP is at or
        below `below` [m], full above, without a stop."""
        ...

    def hold(self, duration: float) -> None:
        """Holds still for `duration` [s]."""
        ...


# [m] a TRANSFER that arrives moving down goes below its height only this near the box's middle,
# and elsewhere no more than VIA_DIP below it (a stop-over transfer bows 1-2 mm down in joint space)
VIA_RADIUS, VIA_DIP = 0.05, 0.003
HEAP_STEP = 0.05  # [m] a heap's carrying height is lowered in these steps to the reachable


def carry_over_box(
    motion: HandMotion,
    place_position: FloatArray,
    table_z: float,
    settings: LoopSettings,
    extra_reach: float = 0.0,
    tcp: FloatArray | None = None,
) -> None:
    """TRANSFER: the TCP over `place_position` (the box floor's centre, Σ_W [m]) at
    `transfer_height` above the table.

    A load that hangs `extra_reach` [m] lower than the meant cloth alone (a double pick that
    goes into the box with its other cloth: it hangs from the held one) is carried that much
    higher, risen straight up first from the TCP at `tcp` ((3,) [m]) where given; where
    that is out of reach, as high as the arm reaches, in `HEAP_STEP`s. Replay of held-out
    episode 429 (session 29): three cloths of colours lifted together at 0.40 m hung down to
    the table, were dragged across it and the lowest caught outside the box's 0.1 m wall,
    and the heap fell beside the box."""
    over = np.asarray(place_position, dtype=float).reshape(3).copy()
    extra = max(0.0, float(extra_reach))
    while True:
        over[2] = table_z + settings.transfer_height + extra
        try:
            q_over = motion.solve_tcp(over)
            q_up = None if tcp is None or extra <= 0.0 else motion.solve_tcp([tcp[0], tcp[1], over[2]])
            break
        except (EpisodeAbortError, IKError):
            if extra <= 0.0:
                raise
            extra = max(0.0, extra - HEAP_STEP)
    if q_up is not None:
        motion.move_to_joints(q_up)
    motion.move_to_joints(q_over)


def release_lowering(
    motion: HandMotion,
    place_position: FloatArray,
    table_z: float,
    settings: LoopSettings,
    reach: float,
    heap: float = 0.0,
) -> tuple[FloatArray, float | None]:
    """Where RELEASE lowers the hand (`release_into_box`): the joints [rad] with the hanging
    cloth's lowest point `release_clearance` above the box floor (the top of what lies in
    the box, `heap` [m] over the floor), then `release_fold` lower (never below
    `min_release_height`), and the TCP height [m] (Σ_W z) from which on the lowering is
    slow (None: all of it)."""
    s = settings
    floor = table_z + max(0.0, float(heap))
    low = np.asarray(place_position, dtype=float).reshape(3).copy()
    low[2] = floor + max(s.min_release_height, s.grasp_height + reach + s.release_clearance - s.release_fold)
    below = None if s.release_slow_from is None else floor + s.grasp_height + reach + s.release_slow_from
    return motion.solve_tcp(low), below


def release_into_box(
    motion: HandMotion,
    cell: Cell,
    place_position: FloatArray,
    table_z: float,
    settings: LoopSettings,
    reach: float,
    heap: float = 0.0,
    lowering: tuple[FloatArray, float | None] | None = None,
) -> str:
    """RELEASE: lowers the cloth hanging `reach` [m] below the fingers until its lowest point
    is `release_clearance` above the box floor (the top of what lies in the box, `heap` [m]
    over the floor: `box_contents`), then `release_fold` lower still (folding it
    onto the floor; never below `min_release_height`), slowly (`release_speed`: a soft body
    that hits the floor fast goes through it) from where its lowest point is
    `release_slow_from` above the floor on, at the full limits above that, without a stop
    (`release_lowering`; `lowering`: that one, as the TRANSFER planned it); lets go, waits
    until the hand camera sees the cloth at rest (`release_watch`; at most `release_wait`)
    and opens the fingers. Returns a note on the wait."""
    s = settings
    q_low, slow_below = (
        lowering
        if lowering is not None
        else release_lowering(motion, place_position, table_z, s, reach, heap)
    )
    if slow_below is None:
        motion.move_to_joints(q_low, speed=s.release_speed)
    else:
        motion.move_slowing_down(q_low, s.release_speed, slow_below)
    cell.release()
    note = f"waited {s.release_wait:.2f} s after letting go"
    if s.release_settle_share is None:
        motion.hold(s.release_wait)  # let the cloth fall clear before the fingers open
    else:
        watch = wait_until_settled(
            motion,
            cell,
            rate_hz=s.vision_rate_hz,
            longest=s.release_wait,
            threshold=s.release_settle_threshold,
            share=s.release_settle_share,
            frames=s.release_settle_frames,
        )
        seen = "at rest" if watch.settled else f"still moving ({watch.last_change:.1%} of the view)"
        note = f"cloth {seen} {watch.waited:.2f} s after letting go ({watch.frames} frames)"
    cell.set_gripper(s.gripper_open)
    return note


class PickPlaceLoop:
    """One robot, one target cloth model, one episode per `run()`.

    Args:
        cell: the robot cell (simulated or real).
        kinematics: arm kinematics with the `tcp` and `camera_right_optical` frames, in Σ_W.
        recognizer: the target's recogniser (model + rig).
        limits: joint limits every commanded sample must respect.
        observation_camera_pose: (4, 4) pose of the right camera at the observation pose
            in Σ_W [m]; the loop's IK turns it into the observation joints.
        place_position: (3,) point above which the cloth is released [m] in Σ_W (box floor centre).
        table_z: height of the table top [m].
        settings: loop settings.
        filter_settings: Kalman filter settings.
        posture_seed: joints [rad] the observation IK starts from (e.g. the arm's home).
        on_phase: called with each finished phase (progress lines).
        on_step: called after every control step with the last capture (video).
        on_recognition: called once per recognition, in order, with what the vision cycle
            saw and concluded (`VisionCycle`: recordings, video overlays).
        ground_truth: returns the cloth's true 4x4 pose in Σ_W (simulation only), for the log.
        placed_fraction: returns the fraction of the cloth in the box at the end (simulation
            only); part of the success decision.
        target_present: the cloth is in the cell (False: success is saying "not present").
        belt_encoder: the conveyor's encoder (`cell.BeltEncoder`), used if
            `loop.belt_encoder` is on; None: the cell has none.
        expected_pose: (4, 4) where the caller's own recognition, from the observation
            pose, found the cloth in Σ_W [m] (the clear-table job's survey): when every
            search fails, the last search's frame is checked there (`_search`).
        box_heap: how high what already lies in the box heaps over its floor [m] (the
            clear-table job's `box_contents`): RELEASE takes its top for the floor.
        first_look: a frame the caller took at the observation pose of a scene that has
            not moved since (the clear-table job's survey), with the arm gone elsewhere
            meanwhile (a look into a box): OBSERVE does not go back, the first search
            recognises this frame, and APPROACH first moves straight over the cloth
            (`LookThenMoveStrategy.come_over`); look-then-move only.

    Raises:
        IKError: the observation pose has no IK solution within the joint limits.
    """

    def __init__(
        self,
        cell: Cell,
        kinematics: Kinematics,
        recognizer: Recognizer,
        limits: JointLimits,
        observation_camera_pose: npt.ArrayLike,
        place_position: npt.ArrayLike,
        table_z: float,
        settings: LoopSettings | None = None,
        filter_settings: PoseFilterSettings | None = None,
        *,
        posture_seed: npt.ArrayLike | None = None,
        on_phase: PhaseCallback | None = None,
        on_step: StepCallback | None = None,
        on_recognition: RecognitionCallback | None = None,
        ground_truth: Callable[[], FloatArray] | None = None,
        placed_fraction: Callable[[], float] | None = None,
        target_present: bool = True,
        belt_encoder: BeltEncoder | None = None,
        expected_pose: npt.ArrayLike | None = None,
        box_heap: float = 0.0,
        first_look: StereoCapture | None = None,
    ) -> None:
        self.cell = cell
        self.first_look = first_look
        self.box_heap = float(box_heap)  # release_into_box takes no heap below the floor
        self.expected_pose = None if expected_pose is None else np.asarray(expected_pose, dtype=float)
        self.kinematics = kinematics
        self.recognizer = recognizer
        self.model = recognizer.model
        self.limits = limits
        self.settings = settings or LoopSettings()
        self.observation_joints = observation_posture(
            kinematics, limits, observation_camera_pose, posture_seed, self.settings.ik_tolerance
        )
        self.place_position = np.asarray(place_position, dtype=float).reshape(3)
        self.table_z = float(table_z)
        self.on_phase = on_phase
        self.on_step = on_step
        self.ground_truth = ground_truth
        self.placed_fraction = placed_fraction
        self.target_present = target_present
        s = self.settings
        # the hand keeps the observation orientation: cameras look straight down throughout
        tcp_rotation = kinematics.frame_pose(self.observation_joints, "tcp")[:3, :3]
        self.arm = ArmMotion(
            cell, kinematics, limits, s, tcp_rotation, self.observation_joints, self._after_step
        )
        pipeline = VisionPipeline(
            cell,
            recognizer,
            s.vision_rate_hz,
            s.vision_latency,
            s.track_generations,
            recognizer.settings.propose.tracking.view_floor,
        )
        self.tracker = ClothTracker(
            cell,
            recognizer,
            pipeline,
            filter_settings,
            predict_motion=s.strategy is Strategy.SERVO,
            phase=lambda: self._current.value,
            ground_truth=ground_truth,
            on_recognition=on_recognition,
            belt_encoder=belt_encoder if s.belt_encoder and s.strategy is Strategy.SERVO else None,
            encoder_rate_hz=s.belt_encoder_rate_hz,
        )
        self.strategy: ServoStrategy | LookThenMoveStrategy = (
            ServoStrategy(self.arm, self.tracker, s, self.table_z)
            if s.strategy is Strategy.SERVO
            else LookThenMoveStrategy(self.arm, self.tracker, s, self.table_z)
        )
        if first_look is not None and s.strategy is Strategy.SERVO:
            raise ValueError("first_look needs loop.strategy look_then_move: the servo's search looks twice")
        self._current = Phase.OBSERVE
        self._note = ""
        self.phases: list[PhaseRecord] = []
        self.grasps: list[GraspRecord] = []
        # how much lower than the cloth alone what it lifted hangs [m] (`carry_over_box`);
        # a job that places a double pick together sets it after the lift
        self.extra_reach = 0.0
        # RELEASE's lowering (joints, slow-from height) where TRANSFER arrived into it moving
        self._lowering: tuple[FloatArray, float | None] | None = None

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
        wall_start = time.perf_counter()
        start_time = self.cell.time
        self.arm.reset()
        self.tracker.reset()
        self.phases, self.grasps = [], []
        self.grasp_attempts = self.observe_returns = 0
        self.extra_reach = 0.0
        self._lowering = None
        # the caller's frame for the first search, and whether APPROACH starts from elsewhere
        self._first_look, self._come_over = self.first_look, False
        self._current = Phase.OBSERVE
        outcome, reason = Outcome.PLACED, "cloth released over the box"
        try:
            self._episode()
        except EpisodeAbortError as stop:
            outcome, reason = stop.outcome, stop.reason
        except TrajectoryError as err:
            outcome, reason = Outcome.TRAJECTORY_ERROR, str(err)
        except InterruptError as err:  # raised by on_step at a safe point: end here, as it stands
            outcome, reason = Outcome.INTERRUPTED, f"{err} during {self._current.value}"
        self.tracker.stop()
        if outcome not in (Outcome.PLACED, Outcome.TIMEOUT, Outcome.INTERRUPTED):
            self._safe_home()
        return self._result(outcome, reason, start_time, wall_start)

    def _episode(self) -> None:
        s = self.settings
        while True:
            self._phase(Phase.OBSERVE, self._observe)
            if not self._phase(Phase.SEARCH, self._search):
                raise EpisodeAbortError(
                    Outcome.NOT_PRESENT, f"the target was not found in {s.search_attempts} searches"
                )
            reached = self._phase(Phase.APPROACH, self._approach)
            if reached:
                reached = self._phase(Phase.DESCEND, self.strategy.descend)
            if not reached:
                self.observe_returns += 1
                if self.observe_returns > s.max_observe_returns:
                    raise EpisodeAbortError(
                        Outcome.LOST, f"target lost {self.observe_returns} times during {self._current.value}"
                    )
                continue
            self._phase(Phase.GRASP, self._grasp)
            if self._phase(Phase.LIFT, self._lift):
                break
            self.cell.release()
            self.cell.set_gripper(s.gripper_open)
            if self.grasp_attempts > s.grasp_retries:
                raise EpisodeAbortError(
                    Outcome.GRASP_FAILED, f"cloth not lifted after {self.grasp_attempts} grasps"
                )
        self._phase(Phase.TRANSFER, self._transfer)
        self._phase(Phase.RELEASE, self._release)
        self._phase(Phase.HOME, lambda: self.arm.move_to_joints(self.observation_joints))

    def _phase(self, phase: Phase, body: Callable[[], object]) -> object:
        start, wall = self.cell.time, time.perf_counter()
        self._current = phase
        self._note = self.strategy.note = ""
        try:
            return body()
        finally:
            note = self._note or self.strategy.note
            record = PhaseRecord(phase.value, start, self.cell.time, time.perf_counter() - wall, note)
            self.phases.append(record)
            if self.on_phase is not None:
                self.on_phase(record)

    def _after_step(self) -> None:
        if self.on_step is not None:
            self.on_step(self.cell, self.tracker.last_capture)

    # ------------------------------------------------------------------ phases
    def _observe(self) -> None:
        self.tracker.stop()
        self.cell.set_gripper(self.settings.gripper_open)
        if self._first_look is not None:
            self._note = "the search takes the caller's frame: no move"
            return
        if np.allclose(self.arm.command.q, self.observation_joints, atol=1e-4) and not np.any(
            self.arm.command.v
        ):
            return  # already there and still: nothing to settle
        self.arm.move_to_joints(self.observation_joints)
        self.arm.hold(self.settings.settle_time)

    def _search(self) -> bool:
        """One-shot recognitions at the observation pose; the arm holds while each one is
        computed (the cloth may move meanwhile: the filter starts at the exposure time).
        When all fail and the caller found the cloth itself (`expected_pose`), the last
        search's frame is checked at that pose (`VisionPipeline.check`, no GA): held-out
        episode 395 (session 28): the survey found a crumpled cloth laid back at 0.67-0.73,
        the loop's three searches (GA peaks elsewhere) did not, twice, and the cloth stayed."""
        s = self.settings
        result: VisionResult | None = None
        for attempt in range(s.search_attempts):
            result = self._searched(seed=attempt)
            recognition = result.recognition
            if not recognition.found and recognition.confidence >= s.candidate_confidence:
                # A partial view (image border, occluder) scores low: look again with the
                # cameras centred over the candidate before deciding.
                self.tracker.take_search(result, candidate=True)
                self.arm.move_to_joints(self._centring_joints(result.transform_model_to_world[:3, 3]))
                self.arm.hold(s.settle_time)
                result = self._searched(seed=attempt + s.search_attempts)
            if self.tracker.take_search(result):
                self._come_over = result.capture is self.first_look and not self._at_observation()
                self._note = (
                    f"found with confidence {result.recognition.confidence:.3f}, "
                    f"fitness {result.recognition.fitness:.3f} (attempt {attempt + 1}), "
                    f"result {result.age * 1e3:.0f} ms after the exposure"
                )
                if s.strategy is Strategy.SERVO:  # a second look gives the cloth's velocity
                    second = self._searched(seed=attempt + 2 * s.search_attempts)
                    # each look's pose on the other's frame: did the cloth move, or one GA run?
                    pipeline, seed = self.tracker.pipeline, attempt + 3 * s.search_attempts
                    on_second = pipeline.check(second.capture, result.transform_model_to_world, seed)
                    on_first = pipeline.check(result.capture, second.transform_model_to_world, seed)
                    self.arm.hold_until(on_first.available_time)
                    if self.tracker.take_second_look(result, second, (on_second, on_first)):
                        speed = np.linalg.norm(self.tracker.estimate_at(self.cell.time).velocity[:2])
                        self._note += f", moving at {speed * 1e3:.0f} mm/s"
                return True
            self.arm.move_to_joints(self.observation_joints)
        if result is not None and self.expected_pose is not None:
            checked = self.tracker.pipeline.check(result.capture, self.expected_pose, 3 * s.search_attempts)
            self.arm.hold_until(checked.available_time)
            if self.tracker.take_search(checked):
                seen = checked.recognition
                self._note = (
                    f"not found in {s.search_attempts} searches; checked where the caller found it: "
                    f"confidence {seen.confidence:.3f}, fitness {seen.fitness:.3f}"
                )
                return True
        self._note = "not found"
        return False

    def _searched(self, seed: int) -> VisionResult:
        capture, self._first_look = self._first_look, None  # the caller's frame, once
        result = self.tracker.search(seed, capture)
        self.arm.hold_until(result.available_time)
        return result

    def _at_observation(self) -> bool:
        return bool(np.allclose(self.arm.command.q, self.observation_joints, atol=1e-4))

    def _approach(self) -> bool:
        """APPROACH, first straight over the cloth where the search took the caller's frame
        and the arm is still elsewhere (its cameras need not see the cloth there)."""
        if self._come_over and isinstance(self.strategy, LookThenMoveStrategy):
            self._come_over = False
            self.strategy.come_over()
        return self.strategy.approach()

    def _centring_joints(self, point: FloatArray) -> FloatArray:
        """Joints (at the observation height) that put the right camera above `point`, or
        as near it as the arm reaches on the way there from the observation pose
        (`CENTRING_SHARES` of the way), else the observation joints: the search then looks
        again from where it is. bench_clear_table episode 32 (session 19): a candidate at
        x = 0.78 m put the TCP 10 mm out of reach and ended the attempt ik_unreachable."""
        tcp = self.arm.tcp_position(self.observation_joints)
        camera = self.arm.frame_position(CAMERA_FRAME, self.observation_joints)
        target = np.array([point[0] - (camera[0] - tcp[0]), point[1] - (camera[1] - tcp[1]), tcp[2]])
        for share in CENTRING_SHARES:
            try:
                return self.arm.solve_tcp(tcp + share * (target - tcp))
            except EpisodeAbortError as err:
                if err.outcome is not Outcome.IK_UNREACHABLE:
                    raise
        return self.observation_joints

    def _grasp(self) -> None:
        self.grasp_attempts += 1
        self.strategy.close()
        offset = self._grasp_offset()
        tcp_speed = float(np.linalg.norm(self.arm.tcp_velocity()))
        held = self.cell.grasp()
        mm, xy = offset if offset is not None else (None, None)
        self.grasps.append(GraspRecord(self.grasp_attempts, self.cell.time, held, tcp_speed, mm, xy))
        shown = "" if mm is None else f", {mm:.1f} mm from the intended point"
        self._note = f"attempt {self.grasp_attempts}: {held} hold points{shown}"

    def _grasp_offset(self) -> tuple[float, tuple[float, float]] | None:
        """TCP (measured joints) to the intended grasp point on the true cloth: the distance in
        the cloth's plane [mm] and (x, y) in Σ_W [m]. For a symmetric cloth, the nearest of the
        points its symmetric poses put there (the loop may have seen it turned)."""
        if self.ground_truth is None:
            return None
        truth = self.ground_truth()
        tcp = self.arm.tcp_position(self.cell.joint_positions())
        normal = truth[:3, 2]
        best: tuple[float, tuple[float, float]] | None = None
        for angle in (0.0, *self.model.symmetry_angles):
            turned = truth @ make_transform(rotation_about_z(angle), np.zeros(3))
            d = tcp - transform_points(turned, self.tracker.grasp_point_model[None])[0]
            in_plane = float(np.linalg.norm(d - (d @ normal) * normal) * 1e3)
            if best is None or in_plane < best[0]:
                best = (in_plane, (float(d[0]), float(d[1])))
        return best

    def _lift(self) -> bool:
        self.strategy.lift()
        holding = self.cell.holding()
        lifted = LIFTED if holding else EMPTY_GRASP
        self._note = f"{lifted}; {self.strategy.note}" if self.strategy.note else lifted
        return holding

    def _transfer(self) -> None:
        """Over the box; where `loop.transfer_via_drop` is set (and the load is the meant
        cloth alone), arriving there moving down into RELEASE's lowering (`arrive_lowering`);
        a hand that came empty is brought to rest over the box first."""
        s = self.settings
        self._lowering = None
        lowering = None
        if self.extra_reach <= 0.0 and s.transfer_via_drop > 0.0:
            lowering = release_lowering(
                self.arm, self.place_position, self.table_z, s, self._reach(), self.box_heap
            )
        q_low, below = lowering if lowering is not None else (None, None)
        if q_low is None or below is None:  # a double pick carried along, or all of it slow
            tcp = self.arm.tcp_position()
            carry_over_box(self.arm, self.place_position, self.table_z, s, self.extra_reach, tcp)
            return
        over = np.asarray(self.place_position, dtype=float).reshape(3).copy()
        over[2] = self.table_z + s.transfer_height
        q_over = self.arm.solve_tcp(over)
        drops = (s.transfer_via_drop, s.transfer_via_drop / 2)
        drop = self.arm.arrive_lowering(q_over, q_low, s.release_speed, below, drops, VIA_RADIUS, VIA_DIP)
        if drop is None:
            self.arm.move_to_joints(q_over)
        elif self.cell.holding():
            self._lowering = lowering
            self._note = f"over the box moving down ({drop * 1e3:.0f} mm into the lowering)"
        else:
            self.arm.move_to_joints(q_over)  # came empty: at rest for what follows

    def _reach(self) -> float:
        """How far below the fingers the load hangs [m]."""
        return hanging_reach(self.model.points_in, self.tracker.grasp_point_model) + self.extra_reach

    def _release(self) -> None:
        lowering, self._lowering = self._lowering, None
        self._note = release_into_box(
            self.arm,
            self.cell,
            self.place_position,
            self.table_z,
            self.settings,
            self._reach(),
            self.box_heap,
            lowering,
        )

    def _safe_home(self) -> None:
        """After an abort: open, let go and return to the observation pose if possible."""
        try:
            self.cell.release()
            self.cell.set_gripper(self.settings.gripper_open)
            self.arm.move_to_joints(self.observation_joints)
        except (EpisodeAbortError, TrajectoryError):
            pass

    # ------------------------------------------------------------------ result
    def _result(self, outcome: Outcome, reason: str, start_time: float, wall_start: float) -> EpisodeResult:
        report = self.arm.limit_report()
        placed = self.placed_fraction() if self.placed_fraction is not None else None
        final = None
        if self.ground_truth is not None:
            pose = self.ground_truth()
            final = (float(pose[0, 3]), float(pose[1, 3]), float(pose[2, 3]), yaw_of(pose[:3, :3]))
        success = judge_success(
            outcome,
            limit_violations=report.violations,
            collisions=self.arm.collisions,
            grasp_attempts=self.grasp_attempts,
            placed_fraction=placed,
            target_present=self.target_present,
        )
        return EpisodeResult(
            outcome=outcome,
            success=success,
            reason=reason,
            placed_fraction=placed,
            sim_time=self.cell.time - start_time,
            wall_s=time.perf_counter() - wall_start,
            phases=tuple(self.phases),
            recognitions=tuple(self.tracker.recognitions),
            limit_report=report,
            commanded_samples=self.arm.samples,
            collisions=self.arm.collisions,
            grasp_attempts=self.grasp_attempts,
            observe_returns=self.observe_returns,
            filter_accepted=self.tracker.filter.accepted_count,
            filter_rejected=self.tracker.filter.rejected_count,
            ruckig_times_us=tuple(self.arm.ruckig_times_us),
            ik_times_ms=tuple(self.arm.ik_times_ms),
            final_pose=final,
            strategy=self.settings.strategy.value,
            tracking=tuple(self.tracker.tracking),
            grasps=tuple(self.grasps),
        )


def observation_posture(
    kinematics: Kinematics,
    limits: JointLimits,
    observation_camera_pose: npt.ArrayLike,
    seed: npt.ArrayLike | None,
    tolerance: float,
) -> FloatArray:
    """Joints [rad] putting the right camera at the observation pose (the controller's IK).

    Raises:
        IKError: no solution within the joint limits, with the residual.
    """
    target = np.asarray(observation_camera_pose, dtype=float)
    start = kinematics.neutral if seed is None else np.asarray(seed, dtype=float)
    result = kinematics.solve_ik(
        target,
        start,
        frame=CAMERA_FRAME,
        time_budget=0.5,
        position_tolerance=tolerance,
        orientation_tolerance=tolerance,
        preferred_posture=start,
    )
    if not (result.success and limits.contains(result.q)):
        raise IKError(
            "no IK solution within the joint limits for the observation pose: residual "
            f"{result.position_error * 1e3:.2f} mm, {np.rad2deg(result.orientation_error):.3f} deg"
        )
    q = np.array(result.q)
    q.setflags(write=False)
    return q


__all__ = [
    "LIFTED",
    "HandMotion",
    "LoopSettings",
    "PickPlaceLoop",
    "carry_over_box",
    "observation_posture",
    "release_into_box",
    "release_lowering",
]
