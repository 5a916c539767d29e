"""What the loop knows about the cloth: recognitions as they arrive, the filter, the grasp point.

`ClothTracker` runs the `VisionPipeline`, fuses each result into the `PoseFilter` at the
exposure time it belongs to, and predicts the cloth (and its grasp point) to any later
time. A tracking result that turns or moves the cloth past the filter's gates, or that the
decision does not trust and the Mahalanobis gate rejects, reseeds the tracker on the
filter's prediction for the next frame: the multi-step GA has settled on a look-alike (the
cloth half or a quarter turn round, whose hue fitness is as good) and would stay there.
(A one-shot search would not do: its depth window is the observation pose's.) A tracking
result away from the prediction whose frame the prediction fits as well is a look-alike
(`control/look_alike.py`), not fused, and the tracker starts again from the prediction.
With a belt encoder (`control/belt_odometry.py`) the belt's velocity is fused into the
filter while the cloth lies on the belt: samples up to each result's exposure before it,
later ones into every prediction. `_record` is the one place a recognition becomes a
`RecognitionRecord`: it changes no state. With ground truth (simulation) it also samples
the filtered pose against the truth at every vision period of APPROACH and DESCEND
(`TrackingRecord`).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from robot_app.arrays import FloatArray
from robot_app.control.belt_odometry import BeltOdometry
from robot_app.control.blind_hold import blind_estimate
from robot_app.control.cell import BeltEncoder, Cell, StereoCapture
from robot_app.control.episode import RecognitionRecord, TrackingRecord, VisionCycle
from robot_app.control.grasp_point import visible_grasp_point
from robot_app.control.intercept import GraspPath
from robot_app.control.look_alike import look_alike
from robot_app.control.pose_filter import (
    FilterUpdate,
    PoseEstimate,
    PoseFilter,
    PoseFilterSettings,
    UpdateReason,
)
from robot_app.control.vision_pipeline import VisionPipeline, VisionResult
from robot_app.geometry import make_transform, pose_error, rotation_about_z, wrap_angle, yaw_of
from robot_app.vision import Recognizer

RESEED = (UpdateReason.YAW_JUMP, UpdateReason.POSITION_JUMP)
MOTION_SIGNIFICANCE = 3.0  # standard deviations of the filter's velocity that count as moving
MAX_LOOK_SPEED = 0.5  # [m/s] a cloth seen to move faster between two looks was not the same find
QUARTER_TURNS = (np.pi / 2, np.pi, 3 * np.pi / 2)
FIT_MARGIN = 0.02  # fitness a look's peak must gain on the other's frame (seen noise 0.005, neighbours 0.08)
BRANCH_TOLERANCE = np.deg2rad(10.0)  # a trusted yaw this close to a quarter turn off is that turn


class ClothTracker:
    """The target cloth as the loop knows it.

    Args:
        cell: the robot cell.
        recognizer: the target's recogniser.
        pipeline: the camera and recogniser timing.
        filter_settings: the Kalman filter's noise model and gates.
        predict_motion: move the tracker's kept poses by the filter's predicted cloth motion
            between exposures, not only by the camera's (servo), when the filter's velocity
            is significant (beyond MOTION_SIGNIFICANCE standard deviations). Always on, the
            short tracking GA settles near the prediction and its measurements confirm the
            filter's own velocity error (a still cloth drifted at 7 mm/s in a pilot run and
            was grasped 10 mm off); never on, the tracker lags a cloth at 100 mm/s (grasp
            offsets 9 mm median, 57 mm p95 in a pilot run, against 1.5 / 3 with it).
        phase: returns the loop's current phase name (for the records).
        ground_truth: the cloth's true 4x4 pose in Σ_W now (simulation only).
        on_recognition: called with each recognition's `VisionCycle` right after its row is
            recorded (recordings, video overlays).
        belt_encoder: the conveyor's encoder, fused into the filter's velocity while the
            cloth lies on the belt (`BeltOdometry`); None: vision only.
        encoder_rate_hz: encoder samples per second [Hz].
    """

    def __init__(
        self,
        cell: Cell,
        recognizer: Recognizer,
        pipeline: VisionPipeline,
        filter_settings: PoseFilterSettings | None,
        *,
        predict_motion: bool,
        phase: Callable[[], str],
        ground_truth: Callable[[], FloatArray] | None = None,
        on_recognition: Callable[[VisionCycle], None] | None = None,
        belt_encoder: BeltEncoder | None = None,
        encoder_rate_hz: float = 100.0,
    ) -> None:
        self.cell = cell
        self.recognizer = recognizer
        self.model = recognizer.model
        self.pipeline = pipeline
        self.filter = PoseFilter(filter_settings, tuple(self.model.symmetry_angles))
        self.on_recognition = on_recognition
        self.predict_motion = predict_motion
        self.phase = phase
        self.ground_truth = ground_truth
        self.odometry = BeltOdometry(belt_encoder, encoder_rate_hz) if belt_encoder is not None else None
        if ground_truth is not None:
            pipeline.on_capture = self._note_exposure
        self.reset()

    def reset(self) -> None:
        """Starts an episode: no records, the model's own grasp point."""
        self.recognitions: list[RecognitionRecord] = []
        self.tracking: list[TrackingRecord] = []
        self.grasp_point_model = np.asarray(self.model.grasp_point, dtype=float).copy()
        self.last_capture: StereoCapture | None = None
        self._next_sample = -math.inf
        self._last_truth: tuple[float, FloatArray] | None = None
        self._exposure_truth: dict[float, FloatArray] = {}
        if self.odometry is not None:
            self.odometry.reset()
        self.pipeline.stop()

    # ------------------------------------------------------------------ search
    def search(self, seed: int, capture: StereoCapture | None = None) -> VisionResult:
        """A one-shot recognition of a frame triggered now, or of `capture`, one taken
        before of a still scene (available later: wait for it)."""
        result = self.pipeline.search(seed, capture)
        self.last_capture = result.capture
        return result

    def take_search(self, result: VisionResult, *, candidate: bool = False) -> bool:
        """Uses a search result once it has arrived: a found cloth (re)starts the filter at
        its exposure and chooses the grasp point inside its visible part.

        Args:
            result: the search's result.
            candidate: the result only makes the loop look closer (recorded, not used).

        Returns:
            True if the cloth was found and the filter restarted.
        """
        found = bool(result.recognition.found) and not candidate
        if found:
            self._restart(result.transform_model_to_world, result.capture.time, result)
        reason = "candidate: looking closer" if candidate else ("reset" if found else "not found")
        self._record(result, found, reason)
        return found

    def take_second_look(
        self,
        first: VisionResult,
        second: VisionResult,
        checks: tuple[VisionResult, VisionResult] | None = None,
    ) -> bool:
        """Starts the filter from two one-shot recognitions at the observation pose, with
        the velocity between them (a moving cloth's first tracking frame is then predicted
        where it is, not where the search saw it a latency ago).

        `checks` are each look's pose polished on the other look's frame
        (`VisionPipeline.check`): the first's on the second frame, the second's on the
        first frame. Two looks that disagree may be one cloth that moved or one look on a
        worse peak (a periodic print shifted by a period, or turned a quarter, fits its hue
        nearly as well). A look's peak that fits the other look's frame better than that
        look did explains both frames (the higher fitness over the two wins if both do) and
        gives both measurements; else (a moving cloth the polish did not follow) the two
        looks do. A still No.4 took a 20 mm "velocity" from a second look one period off
        (bench_conveyor episode 20), and a first look a quarter turn off turned every later
        view onto its branch (grasp 70 mm off).
        The tracker starts from the filter when the first look's peak wins (its kept poses
        are the second look's), and the grasp point is chosen anew when the second's wins.

        The measurements are used if the decision trusts the later one, it is on the
        earlier one's yaw branch (within the filter's yaw gate) and it moved no faster than
        MAX_LOOK_SPEED; else the filter keeps the earlier one. Returns whether they were used.
        """
        self.last_capture = second.capture
        on_second, on_first = checks if checks is not None else (None, None)
        earlier, later = first, second
        if on_second is not None and on_first is not None:
            # a peak explains both frames if it fits the other look's frame better than that look
            first_fits = bool(on_second.recognition.found) and (
                on_second.recognition.fitness > second.recognition.fitness + FIT_MARGIN
            )
            second_fits = (
                bool(on_first.recognition.found)
                and bool(second.recognition.found)
                and on_first.recognition.fitness > first.recognition.fitness + FIT_MARGIN
            )
            first_peak = first.recognition.fitness + on_second.recognition.fitness
            second_peak = on_first.recognition.fitness + second.recognition.fitness
            if first_fits and not (second_fits and second_peak > first_peak):
                later = on_second
            elif second_fits:
                earlier = on_first
        if earlier is on_first:
            self._restart(on_first.transform_model_to_world, on_first.capture.time, second)
        recognition = later.recognition
        pose = self._on_branch(later.transform_model_to_world, later.capture.time, recognition.found)
        dt = later.capture.time - earlier.capture.time
        start = earlier.transform_model_to_world
        moved = float(np.linalg.norm(pose[:2, 3] - start[:2, 3]))
        turned = abs(float(wrap_angle(yaw_of(pose[:3, :3]) - yaw_of(start[:3, :3]))))
        used = (
            bool(recognition.found)
            and dt > 0.0
            and moved <= MAX_LOOK_SPEED * dt
            and turned <= self.filter.settings.max_yaw_jump
        )
        if used:
            self.filter.reset_from_two(start, earlier.capture.time, pose, later.capture.time)
        verdict = "second look: velocity" if used else "second look: not used"
        if on_second is None or on_first is None:
            self._record(second, used, verdict, pose=pose)
            return used
        peak = "first look's peak" if later is on_second else "second look's peak"
        for result in (on_first, second, on_second):  # rows in exposure order (recordings)
            kept = result is later or result is earlier
            branch = (
                pose
                if result is later
                else self._on_branch(
                    result.transform_model_to_world, result.capture.time, result.recognition.found
                )
            )
            self._record(
                result, used and kept, f"{verdict} ({peak})" if kept else f"not the {peak}", pose=branch
            )
        if later is on_second:
            self.pipeline.reseed(self._predicted_pose)  # the kept poses are the second look's peak
        return used

    # ------------------------------------------------------------------ tracking
    def start_tracking(self) -> None:
        """Triggers the camera at the vision rate from now on."""
        self.pipeline.start_tracking()

    def stop(self) -> None:
        """Stops the camera; results still on their way are dropped."""
        self.pipeline.stop()

    def poll(
        self,
        *,
        may_capture: bool = True,
        may_fuse: Callable[[StereoCapture], bool] | None = None,
        sample_truth: bool = False,
    ) -> list[FilterUpdate]:
        """Call once per control period while tracking: fuses the results that arrived.

        Args:
            may_capture: False keeps the camera from triggering (too close to the cloth).
            may_fuse: False for a frame exposed too close to the cloth: its result is
                recorded, not fused (`UpdateReason.TOO_CLOSE`); default: every frame may be.
            sample_truth: record the filtered pose against the truth every vision period.

        Returns:
            The filter's verdict on each result that arrived, oldest first.
        """
        motion = self._cloth_motion if self.predict_motion else None
        prediction = self._predicted_pose if self.filter.estimate is not None else None
        if self.odometry is not None:
            self.odometry.sample(self.cell.time, self.filter)
        updates = []
        for result in self.pipeline.poll(may_capture=may_capture, cloth_motion=motion, prediction=prediction):
            self.last_capture = result.capture
            if self.odometry is not None:  # the belt's velocity up to the exposure first
                self.odometry.fuse_until(self.filter, result.capture.time)
            recognition = result.recognition
            pose = self._on_branch(result.transform_model_to_world, result.capture.time, recognition.found)
            update = look_alike(self.filter, result, pose)
            if may_fuse is not None and not may_fuse(result.capture):
                update = FilterUpdate(False, UpdateReason.TOO_CLOSE, math.nan, self.filter.estimate)
            if update is None:
                update = self.filter.update(
                    pose, result.fitness, result.capture.time, trusted=bool(recognition.found)
                )
            self._record(result, update.accepted, str(update.reason), update.nis, pose)
            updates.append(update)
            wrong_peak = update.reason is UpdateReason.MAHALANOBIS and not recognition.found
            if update.reason in RESEED or wrong_peak or update.reason is UpdateReason.LOOK_ALIKE:
                self.pipeline.reseed(self._predicted_pose)  # the tracker settled on a look-alike
        if sample_truth and self.ground_truth is not None and self.cell.time >= self._next_sample:
            self._next_sample = self.cell.time + self.pipeline.period
            self._sample_truth()
        return updates

    @property
    def lost(self) -> bool:
        return self.filter.lost

    # ------------------------------------------------------------------ prediction
    def estimate_at(self, t: float) -> PoseEstimate:
        """The filtered cloth pose predicted to time `t` [s] (not before the last fused exposure)."""
        estimate = self.filter.estimate
        if estimate is None:
            raise RuntimeError("the cloth tracker has no estimate: search first")
        if self.odometry is not None:
            return self.odometry.estimate_at(self.filter, t)
        return self.filter.estimate_at(max(t, estimate.time))

    def grasp_path(self, t: float) -> GraspPath:
        """The grasp point's predicted track, from the estimate predicted to `t` [s]."""
        return GraspPath.from_estimate(self.estimate_at(t), self.grasp_point_model)

    def blind_grasp_path(self, t: float) -> GraspPath:
        """The grasp path a blind hand follows (`blind_hold`): the prediction to `t` [s] if
        the filter's velocity is significant, else the last filtered pose held still (with
        a belt encoder: the filter brought up to now with its samples)."""
        last = self.filter.estimate
        if last is None:
            raise RuntimeError("the cloth tracker has no estimate: search first")
        if self.odometry is not None:
            last = self.odometry.estimate_at(self.filter, self.cell.time)
        return GraspPath.from_estimate(blind_estimate(last, t, self.estimate_at(t)), self.grasp_point_model)

    def _cloth_motion(self, t_from: float, t_to: float) -> FloatArray | None:
        """The filter's predicted rigid motion of the cloth in Σ_W between two exposures."""
        estimate = self.filter.estimate
        if estimate is None or t_to <= t_from:
            return None
        if self.odometry is not None:
            estimate = self.odometry.estimate_at(self.filter, t_from)
        velocity_std = np.sqrt(np.maximum(np.diag(estimate.covariance)[4:8], 0.0))
        moving = float(np.linalg.norm(estimate.velocity[:2])) > MOTION_SIGNIFICANCE * float(
            np.linalg.norm(velocity_std[:2])
        )
        turning = abs(estimate.yaw_rate) > MOTION_SIGNIFICANCE * float(velocity_std[3])
        if not (moving or turning):
            return None
        start = self.estimate_at(t_from)
        end = self.estimate_at(t_to)
        if not moving:
            end = PoseEstimate(
                start.x, start.y, start.z, end.yaw, end.velocity, end.yaw_rate, end.covariance, end.time
            )
        turn = make_transform(rotation_about_z(end.yaw - start.yaw if turning else 0.0), np.zeros(3))
        to_origin = make_transform(np.eye(3), -start.position)
        to_end = make_transform(np.eye(3), end.position)
        return np.asarray(to_end @ turn @ to_origin, dtype=float)

    def _on_branch(self, pose: FloatArray, t: float, trusted: bool) -> FloatArray:
        """The recognised pose turned about Σ_M's z onto the branch nearest the prediction.

        A symmetric cloth recognised half a turn round is the same cloth, not a jump: the
        model's symmetry angles always count, and so does a quarter or half turn (within
        BRANCH_TOLERANCE) of a recognition the decision trusts, for the decision compares the
        model photo's appearance and has accepted the cloth that way round (a plain square
        napkin whose photo model found no symmetry in its weave). The grasp point stays on
        the same part of the cloth.
        """
        estimate = self.filter.estimate
        if estimate is None:
            return pose
        predicted = self.filter.estimate_at(max(t, estimate.time)).yaw
        best, best_turn = pose, abs(float(wrap_angle(yaw_of(pose[:3, :3]) - predicted)))
        quarter = QUARTER_TURNS if trusted else ()
        for angle in (*self.model.symmetry_angles, *quarter):
            turned = np.asarray(pose @ make_transform(rotation_about_z(angle), np.zeros(3)), dtype=float)
            turn = abs(float(wrap_angle(yaw_of(turned[:3, :3]) - predicted)))
            same_cloth = angle in self.model.symmetry_angles or turn < BRANCH_TOLERANCE
            if same_cloth and turn < best_turn:
                best, best_turn = turned, turn
        return best

    def _predicted_pose(self, t: float) -> FloatArray:
        """The filter's pose of the cloth at time `t` [s], 4x4 in Σ_W."""
        return self.estimate_at(t).as_transform()

    # ------------------------------------------------------------------ records
    def _restart(self, pose_world: FloatArray, time: float, view: VisionResult) -> None:
        """Restart the filter at `pose_world` [m] seen at `time` [s] and choose the grasp
        point again in the part of the cloth `view` saw."""
        self.filter.reset(pose_world, time)
        self.grasp_point_model = visible_grasp_point(
            self.model,
            self.recognizer.rig,
            view.recognition.transform_model_to_camera,
            view.capture,
            self.recognizer.settings.fitness,
        )

    def _record(
        self,
        result: VisionResult,
        accepted: bool,
        reason: str,
        nis: float = math.nan,
        pose: FloatArray | None = None,
    ) -> None:
        """Appends the recognition's row (the one place recognitions are recorded); `pose`
        is the pose the filter was given (default: the recognised one)."""
        pose = result.transform_model_to_world if pose is None else pose
        recognition = result.recognition
        errors: dict[str, float] = {}
        truth = self._exposure_truth.get(result.capture.time)  # a check shares its frame's
        if truth is not None:
            error = pose_error(pose, truth, tuple(self.model.symmetry_angles))
            errors = {
                "error_x_mm": error.x_mm,
                "error_y_mm": error.y_mm,
                "error_z_mm": error.z_mm,
                "error_yaw_deg": error.yaw_deg,
            }
        record = RecognitionRecord(
            time=result.capture.time,
            phase=self.phase(),
            mode=result.mode,
            found=bool(recognition.found),
            fitness=float(result.fitness),
            accepted=accepted,
            reason=reason,
            x=float(pose[0, 3]),
            y=float(pose[1, 3]),
            z=float(pose[2, 3]),
            yaw=yaw_of(pose[:3, :3]),
            evaluations=int(recognition.evaluations),
            recognition_s=float(result.compute_s),
            available_time=float(result.available_time),
            dropped=bool(result.capture.dropped),
            **errors,
        )
        self.recognitions.append(record)
        if self.on_recognition is not None:
            grasp_point = self.grasp_point_model.copy()
            grasp_point.setflags(write=False)
            world_pose = np.array(pose, dtype=float)
            world_pose.setflags(write=False)
            self.on_recognition(
                VisionCycle(
                    record, result.capture, recognition, world_pose, self.filter.estimate, nis, grasp_point
                )
            )

    def _note_exposure(self, capture: StereoCapture) -> None:
        """Keeps the true pose at an exposure (simulation): a recognition's error is against
        the cloth as it was then, not when the result arrived."""
        if self.ground_truth is not None:
            self._exposure_truth = {t: T for t, T in self._exposure_truth.items() if t > capture.time - 5.0}
            self._exposure_truth[capture.time] = self.ground_truth()

    def _sample_truth(self) -> None:
        now = self.cell.time
        truth = self.ground_truth() if self.ground_truth is not None else None
        if truth is None or self.filter.estimate is None:
            return
        estimate = self.estimate_at(now)
        error = pose_error(estimate.as_transform(), truth, tuple(self.model.symmetry_angles))
        speed = math.nan
        if self._last_truth is not None and now > self._last_truth[0]:
            then, before = self._last_truth
            speed = float(np.linalg.norm(truth[:2, 3] - before[:2, 3]) / (now - then))
        self._last_truth = (now, truth)
        self.tracking.append(TrackingRecord(now, self.phase(), error.x_mm, error.y_mm, error.yaw_deg, speed))


__all__ = ["ClothTracker"]
