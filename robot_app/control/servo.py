"""The servo strategy: intercept the moving cloth, track it down, grasp it moving, lift it off.

The target is the grasp point as the Kalman filter predicts it (`GraspPath`), through a
smooth copy (`TrackFilter`) so that a fused recognition never steps it. The arm follows
it with one online trajectory (ruckig) from APPROACH to the end of LIFT, retargeted
every control period, in two modes:

- intercept (APPROACH, until the hand is within `CAUGHT_UP` of the target or T has come;
  a hand moving with the cloth would meet it at any T ahead): the intercept time T is the fixed point
  of "T = now + the time-optimal duration to the grasp point predicted for T" (ruckig's
  offline calculation), set when a recognition is fused and kept, as an absolute time, in
  between; every replan aims at the point predicted for T with the cloth's velocity and
  takes T - now as ruckig's minimum duration, so the hand meets the cloth when it is due
  (time-optimal alone, it would get there early, ahead of the cloth, then fall behind);
- track (from T on): the target is the predicted state (position, velocity, acceleration)
  `LOOKAHEAD` ahead, due then. A target one period ahead cannot be met exactly by one
  jerk-limited step, and the replans toward such targets lag or overshoot a smooth
  reference by 10-60 mm on a descent; 50 ms ahead and due then, the replanned segment
  is the reference itself to 0.2 mm.

APPROACH ends over the cloth at `track_height` once enough recognitions are fused and
the hand matches the cloth's position and velocity. DESCEND lowers the target with a
smooth profile at `DESCEND_SPEED` while tracking; the cameras are triggered while they
are at least `min_working_distance` from the cloth, and below that the last part is
blind, on the prediction (frames taken above it still arrive and are fused) if the
filter's velocity is significant, else on the last filtered pose held still
(`blind_hold`: a still cloth's velocity noise is not integrated). The
blind segment starts only on a prediction the views confirm (`descent_doubt`), and
before moving down DESCEND checks that the predicted grasp point stays within the arm's
reach until the hand is down (`descent_reach`; else outcome `unreachable`). The
fingers close while the hand moves with the cloth; LIFT rises the same way and follows
the belt until the hanging cloth is `lift_clearance` above it (or until following on
would take the hand out of reach or a joint past its limit), then stops over it.
"""

from __future__ import annotations

import numpy as np

from robot_app.arrays import FloatArray
from robot_app.control.arm_motion import ArmMotion
from robot_app.control.cell import StereoCapture
from robot_app.control.cloth_tracker import ClothTracker
from robot_app.control.descent_doubt import HOLD_CLEARANCE, HOLD_MARGIN, DescentDoubt, Verdict
from robot_app.control.descent_reach import leaves_reach
from robot_app.control.episode import EpisodeAbortError, Outcome
from robot_app.control.height_profile import HeightProfile, cloth_surface, tcp_height, vertical_speed
from robot_app.control.intercept import JointFollower, TrackFilter, hanging_reach
from robot_app.control.loop_settings import LoopSettings
from robot_app.control.online_trajectory import OnlineTrajectory
from robot_app.control.ruckig_input import RESULT_POSITIONAL_LIMITS, TrajectoryPlanningError
from robot_app.control.trajectory import time_optimal_duration

CAMERA_FRAME = "camera_right_optical"
TRACK_BANDWIDTH = 20.0  # [rad/s] of the smooth copy of the prediction: a step taken up in ~0.2 s
DESCEND_SPEED = 0.2  # [m/s] mean vertical speed of the DESCEND and LIFT profiles (at most)
VERTICAL_SHARE = 0.6  # of the joint velocity, acceleration and jerk limits a profile may use at its peaks
DESCEND_TIMEOUT = 4.0  # [s] of cell time for DESCEND before it counts as lost
INTERCEPT_ITERATIONS = 4  # fixed-point iterations of the intercept time (converges in 2-3)
LOOKAHEAD = 0.05  # [s] tracking aims at the target's state this far ahead, due then
LIMIT_MARGIN = 2e-3  # [rad] joint targets stay this far inside the position limits
CAUGHT_UP = 0.02  # [m] the hand this close to the target ends the intercept: tracking from then on


class ServoStrategy:
    """APPROACH, DESCEND, GRASP and LIFT on a cloth that may move.

    Args:
        arm: the commanded arm.
        tracker: the cloth as the loop knows it.
        settings: the loop's settings.
        table_z: height of the table (belt) top [m].
    """

    def __init__(self, arm: ArmMotion, tracker: ClothTracker, settings: LoopSettings, table_z: float) -> None:
        self.arm = arm
        self.tracker = tracker
        self.settings = settings
        self.table_z = float(table_z)
        self.follower = JointFollower(
            arm.kinematics,
            lambda p, seed: arm.solve_tcp(p, seed),
            arm.tcp_rotation,
            arm.limits.lower + LIMIT_MARGIN,
            arm.limits.upper - LIMIT_MARGIN,
        )
        q = arm.preferred_posture
        self.camera_above_tcp = float(arm.frame_position(CAMERA_FRAME, q)[2] - arm.tcp_position(q)[2])
        self.note = ""
        self._online: OnlineTrajectory | None = None  # one online run from APPROACH to the end of LIFT
        self._track = TrackFilter(TRACK_BANDWIDTH)
        self._intercept: float | None = None  # absolute cell time [s]; None once tracking
        self._height = HeightProfile(0.0, 0.0, 0.0, 1.0)  # TCP height above the grasp point over time
        self._blind = False  # the cameras are below the working distance: `blind_hold` aims the hand

    # ------------------------------------------------------------------ phases
    def approach(self) -> bool:
        """Intercepts the cloth and hovers over it at `track_height`, moving with it; False if lost."""
        s = self.settings
        self._end(to_rest=False)
        online = self._online = self.arm.start_online()
        self.follower.reset()
        self.tracker.start_tracking()
        self._blind = False
        now = self.arm.cell.time
        self._track.reset(self.tracker.grasp_path(now), now)
        self._height = HeightProfile(s.track_height, s.track_height, now, 1.0)
        try:
            self._intercept = self._plan_intercept(online)
        except EpisodeAbortError as abort:
            return self._out_of_reach(abort)
        start, fused = now, 0
        while True:
            in_view = self._in_view()
            updates = self.tracker.poll(may_capture=in_view, may_fuse=self._far_enough, sample_truth=True)
            fused += sum(u.accepted for u in updates)
            if self.tracker.lost:
                self.note = f"lost after {self.tracker.filter.consecutive_rejections} rejected recognitions"
                self._end(to_rest=True)
                return False
            try:
                self._renew(online, any(u.accepted for u in updates))
                position_error, velocity_error = self._follow(online)
            except EpisodeAbortError as abort:
                return self._out_of_reach(abort)
            matched = position_error <= s.approach_tolerance and velocity_error <= s.velocity_tolerance
            if fused >= s.min_accepted_updates and self._intercept is None and matched:
                speed = float(np.linalg.norm(self._target_velocity(self.arm.cell.time)[:2]))
                self.note = f"{fused} fused recognitions, cloth at {speed * 1e3:.0f} mm/s"
                return True
            if self.arm.cell.time - start > s.approach_timeout:
                self.note = f"no stable intercept within {s.approach_timeout:.1f} s"
                self._end(to_rest=True)
                return False

    def _out_of_reach(self, abort: EpisodeAbortError) -> bool:
        """APPROACH ends as lost (False: the loop looks again) when the predicted grasp point
        leaves the arm's reach: the prediction may be wrong, not the cloth gone (two looks on
        neighbouring peaks of a print made a still cloth "move" at 172 mm/s). Other aborts
        stand."""
        if abort.outcome is not Outcome.IK_UNREACHABLE:
            raise abort
        self.note = f"predicted grasp point out of reach, looking again: {abort.reason}"
        self._end(to_rest=True)
        return False

    def descend(self) -> bool:
        """Tracks down to the grasp height (blind below the working distance); False if lost.

        A doubt (`descent_doubt`) holds the hand `HOLD_MARGIN` above the height where the
        cameras go blind, the TCP at least `HOLD_CLEARANCE` above the cloth (rising back to
        it if it was already lower), until a recognition confirms the prediction; a lost
        doubt run ends DESCEND as lost (the loop looks again) instead of grasping where the
        cloth was.

        Raises:
            EpisodeAbortError: UNREACHABLE, before the hand moves down, when the predicted
                grasp point leaves the arm's reach before the hand could be down on it (a
                fast belt heading toward the base, where the PA10 cannot reach low).
        """
        s = self.settings
        online = self.online
        now = self.arm.cell.time
        self._height_to(s.grasp_height)
        problem = leaves_reach(self.arm, self.tracker.grasp_path(now), self._height.end, self.table_z, s)
        if problem is not None:
            self._end(to_rest=True)
            raise EpisodeAbortError(Outcome.UNREACHABLE, problem)
        blind_height = s.min_working_distance - self.camera_above_tcp  # TCP above the cloth
        hold = max(blind_height + HOLD_MARGIN, HOLD_CLEARANCE)
        start, seen, blind_from = now, 0, None
        records = self.tracker.recognitions
        doubt = DescentDoubt(records[-1].fitness if records else 0.0)
        while True:
            in_view = self._in_view()
            if not in_view and blind_from is None:
                blind_from = self._height_above_cloth()
            self._blind = not in_view
            updates = self.tracker.poll(may_capture=in_view, may_fuse=self._far_enough, sample_truth=True)
            records = self.tracker.recognitions  # one row per update, in order
            fitnesses = [r.fitness for r in records[len(records) - len(updates) :]]
            seen += sum(u.accepted for u in updates)
            if self.tracker.lost:
                self.note = "lost while descending"
                self._end(to_rest=True)
                return False
            for update, fitness in zip(updates, fitnesses, strict=True):
                verdict = doubt.judge(update, fitness)
                if verdict is Verdict.CLEARED:
                    self._height_to(s.grasp_height)
                elif verdict is Verdict.DOUBTED and self._height.last != hold:
                    self._height_to(hold)
            if doubt.lost:
                self.note = (
                    f"{doubt.doubted} recognitions in a row did not confirm the prediction on the way down"
                )
                self._end(to_rest=True)
                return False
            self._renew(online, any(u.accepted for u in updates))
            position_error, velocity_error = self._follow(online)
            down = not doubt.standing and self.arm.cell.time >= self._height.end
            if down and position_error <= s.grasp_tolerance and velocity_error <= s.velocity_tolerance:
                blind = "" if blind_from is None else f", blind below {blind_from * 1e3:.0f} mm"
                self.note = f"{seen} fused recognitions on the way down{blind}"
                return True
            if self.arm.cell.time - start > DESCEND_TIMEOUT:
                self.note = f"grasp point not reached within {DESCEND_TIMEOUT:.0f} s"
                self._end(to_rest=True)
                return False

    def close(self) -> None:
        """Closes the fingers while the hand keeps moving with the cloth."""
        online = self.online
        self.arm.cell.set_gripper(0.0)
        for _ in range(round(self.settings.close_time / self.arm.cell.dt)):
            updates = self.tracker.poll(may_capture=False, may_fuse=self._far_enough)
            self._renew(online, any(u.accepted for u in updates))
            try:
                self._follow(online)
            except EpisodeAbortError as abort:
                if abort.outcome is not Outcome.IK_UNREACHABLE:
                    raise
                self._hold_here(online)  # the prediction runs out of reach (past the belt's end)
                self.arm.hold(self.settings.close_time)
                return

    def lift(self) -> None:
        """Rises, following the belt until the hanging cloth is off it, then straight up."""
        s = self.settings
        self.tracker.stop()
        online = self.online
        reach = hanging_reach(self.tracker.model.points_in, self.tracker.grasp_point_model)
        lift_z = self.table_z + s.lift_height
        off_belt = min(self.table_z + s.grasp_height + reach + s.lift_clearance, lift_z - 0.01)
        grasp_z = self._target_position(self.arm.cell.time)[2] - self._height.at(self.arm.cell.time)
        self._height_to(lift_z - grasp_z)
        ended = ""  # why following ended before the cloth was off the belt
        while self.arm.tcp_position()[2] < off_belt:
            self._renew(online, fused=False)
            try:
                self._follow(online)
            except EpisodeAbortError as abort:
                if abort.outcome is not Outcome.IK_UNREACHABLE:
                    raise
                ended = " (then out of reach)"  # up from here: the cloth hangs on
                break
            except TrajectoryPlanningError as error:
                if error.code != RESULT_POSITIONAL_LIMITS:
                    raise
                ended = " (then a joint limit)"  # following on would pass it; the state did not advance
                break
        now = self.arm.cell.time
        q, dq = self._lift_goal(lift_z)
        online.set_target(q, dq, synchronized=False)
        while not online.finished:
            self.arm.step_online(online)
        self._end(to_rest=False)
        self.note = (
            f"followed the cloth for {now - self._height.start:.2f} s{ended}, "
            f"toward {off_belt - self.table_z:.2f} m"
        )

    # ------------------------------------------------------------------ the target
    def _renew(self, online: OnlineTrajectory, fused: bool) -> None:
        """Every period: the smooth copy follows the prediction (a blind hand: only if the
        cloth is seen to move, `blind_hold`); after a fused recognition during the intercept,
        the intercept time is set anew."""
        now = self.arm.cell.time
        path = self.tracker.blind_grasp_path(now) if self._blind else self.tracker.grasp_path(now)
        self._track.advance(path, now)
        if fused and self._intercept is not None:
            self._intercept = self._plan_intercept(online)

    def _target_position(self, t: float) -> FloatArray:
        """The TCP target for time `t` [s]: the height profile above the smoothed grasp point."""
        point = self._track.at(t)
        z = tcp_height(point[2], self._height.at(t), self.table_z, self.settings.min_table_clearance)
        return np.array([point[0], point[1], z])

    def _target_velocity(self, t: float) -> FloatArray:
        """The TCP target's velocity [m/s] at `t` [s]."""
        velocity = self._track.velocity_at(t)
        velocity[2] = self._height.rate(t)
        return velocity

    def _target_acceleration(self, t: float) -> FloatArray:
        """The TCP target's acceleration [m/s^2] at `t` [s]."""
        acceleration = self._track.acceleration_at(t)
        acceleration[2] = self._height.acceleration(t)
        return acceleration

    def _plan_intercept(self, online: OnlineTrajectory) -> float:
        """T = now + dt + the shortest time from the commanded state to the target for T."""
        now, dt = self.arm.cell.time, self.arm.cell.dt
        state = online.state
        limits = self.arm.limits
        v = np.clip(state.v, -limits.velocity, limits.velocity)
        a = np.clip(state.a, -limits.acceleration, limits.acceleration)
        horizon = self.settings.max_prediction
        intercept = now + dt  # from below: the least fixed point (a hand moving with the
        for _ in range(INTERCEPT_ITERATIONS):  # cloth is a fixed point at any T ahead)
            q, dq, _ = self._joint_target(self._target_position(intercept), self._target_velocity(intercept))
            duration = time_optimal_duration(limits, state.q, v, a, q, dq)
            previous, intercept = intercept, now + dt + min(duration, horizon)
            if abs(intercept - previous) < dt:
                break
        return intercept

    def _follow(self, online: OnlineTrajectory) -> tuple[float, float]:
        """One control period toward the target; returns the TCP's position [m] and
        velocity [m/s] error to the target now."""
        now = self.arm.cell.time
        if self._intercept is not None:
            close = np.linalg.norm(self.arm.tcp_position() - self._target_position(now)) < CAUGHT_UP
            if close or self._intercept <= now + LOOKAHEAD:
                self._intercept = None  # caught up: track from here on
        aim = now + LOOKAHEAD if self._intercept is None else self._intercept
        q, dq, ddq = self._joint_target(
            self._target_position(aim), self._target_velocity(aim), self._target_acceleration(aim)
        )
        online.set_target(q, dq, ddq, minimum_duration=aim - now)
        self.arm.step_online(online)
        now = self.arm.cell.time
        position_error = float(np.linalg.norm(self.arm.tcp_position() - self._target_position(now)))
        velocity_error = float(np.linalg.norm(self.arm.tcp_velocity() - self._target_velocity(now)))
        return position_error, velocity_error

    def _joint_target(
        self, position: FloatArray, velocity: FloatArray, acceleration: FloatArray | None = None
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Joint positions [rad], velocities [rad/s] and accelerations [rad/s^2] for the TCP
        target that the online trajectory can meet within the limits: positions
        `LIMIT_MARGIN` inside the range, velocities within 90 % of the limits and slow enough
        near a position limit to stop before it, accelerations that do not carry the
        velocity past its limit. (A cloth carried out of the arm's reach is then followed as
        far as the joints allow, and the IK reports it unreachable.)"""
        q, dq, ddq = self.follower.joints(position, velocity, acceleration)
        limits = self.arm.limits
        q = np.clip(q, limits.lower + LIMIT_MARGIN, limits.upper - LIMIT_MARGIN)
        room = np.where(dq > 0.0, limits.upper - q, q - limits.lower) - LIMIT_MARGIN / 2
        braking = np.sqrt(np.maximum(0.0, room) * limits.acceleration)  # stops with half the acceleration
        bound = np.minimum(0.9 * limits.velocity, braking)
        slowed = np.abs(dq) > bound
        dq = np.clip(dq, -bound, bound)
        spare = np.minimum(np.sqrt(2.0 * limits.jerk * (limits.velocity - np.abs(dq))), limits.acceleration)
        ddq = np.where(slowed, 0.0, np.clip(ddq, -spare, spare))
        return q, dq, ddq

    # ------------------------------------------------------------------ helpers
    @property
    def online(self) -> OnlineTrajectory:
        if self._online is None:
            raise RuntimeError("the servo's motion starts in APPROACH")
        return self._online

    def _end(self, *, to_rest: bool) -> None:
        """Ends the online run (its replan times logged once); with `to_rest`, stops the arm."""
        if self._online is not None:
            self.arm.end_online(self._online, to_rest=to_rest)
            self._online = None

    def _lift_goal(self, lift_z: float) -> tuple[FloatArray, FloatArray]:
        """Joints [rad] (at rest) with the TCP at `lift_z` [m] over where the hand is or, far
        out where the arm cannot raise the hand that high, as little toward the observation
        pose as it takes (the cloth must hang clear of the table to count as lifted)."""
        here = self.arm.tcp_position()
        home = self.arm.tcp_position(self.arm.preferred_posture)
        for share in (0.0, 0.25, 0.5, 0.75, 1.0):
            goal = here + share * (home - here)
            goal[2] = lift_z
            try:
                q, _, _ = self._joint_target(goal, np.zeros(3))
            except EpisodeAbortError as abort:
                if abort.outcome is not Outcome.IK_UNREACHABLE:
                    raise
                continue
            return q, np.zeros_like(q)
        return self.arm.command.q, np.zeros_like(self.arm.command.q)

    def _hold_here(self, online: OnlineTrajectory) -> None:
        """Brings the online motion to rest where the hand is (jerk-limited), then ends it."""
        online.set_target(self.arm.command.q, synchronized=False)
        while not online.finished:
            self.arm.step_online(online)
        self._end(to_rest=False)
        self._online = self.arm.start_online()

    def _height_to(self, height: float) -> None:
        """The height profile from where it is now to `height` [m] above the grasp point."""
        now = self.arm.cell.time
        self._height = self._height.to(height, now, self._vertical_speed(height - self._height.at(now)))

    def _vertical_speed(self, rise: float) -> float:
        """Mean speed [m/s] of a vertical profile over `rise` [m] from the commanded posture,
        on top of following the cloth (`height_profile.vertical_speed`)."""
        q = self.arm.command.q
        J = self.arm.kinematics.frame_jacobian(q, "tcp", "local_world_aligned")
        horizontal = self._target_velocity(self.arm.cell.time) * np.array([1.0, 1.0, 0.0])
        return vertical_speed(J, self.arm.limits, horizontal, rise, DESCEND_SPEED, VERTICAL_SHARE)

    def _height_above_cloth(self) -> float:
        """The TCP's height above the predicted cloth surface now [m]."""
        estimate = self.tracker.estimate_at(self.arm.cell.time)
        return float(self.arm.tcp_position()[2] - cloth_surface(estimate.z, self.table_z))

    def _in_view(self) -> bool:
        """True while the cameras are at least the working distance from the cloth."""
        camera_z = float(self.arm.frame_position(CAMERA_FRAME)[2])
        return self._camera_distance(camera_z, self.arm.cell.time) >= self.settings.min_working_distance

    def _far_enough(self, capture: StereoCapture) -> bool:
        """True if a frame was exposed with the cameras at least the working distance from the cloth."""
        camera_z = float(capture.transform_right_camera_to_world[2, 3])
        return self._camera_distance(camera_z, capture.time) >= self.settings.min_working_distance

    def _camera_distance(self, camera_z: float, t: float) -> float:
        """The cameras' height [m] at `camera_z` [m] above the cloth predicted to `t` [s].

        The cloth lies on the belt: its surface is taken between the belt and a wrinkle
        above it (`cloth_surface`), as the TCP's target takes it. The filter's depth alone
        sank 69 mm below the belt on close views, the cameras counted as 0.19 m or more
        from the cloth at 0.13-0.18 m, and those views were fused and sank it further
        (bench_pick_place episode 64).
        """
        estimate = self.tracker.estimate_at(t)
        return camera_z - cloth_surface(estimate.z, self.table_z)


__all__ = ["ServoStrategy"]
