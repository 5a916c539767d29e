"""The clear-table job's recovery moves: a wrong or double lift laid back onto free table
(`put_back`), and, when a survey leaves nothing to pick, the places to look again from
(`places_to_look`, `look_from`).

`TableRecovery` remembers, over one job run, where it put cloths back and where it has
looked since the last pick attempt (any pick: one of the loop's or a blind one of a lost
cloth; the ledger's count of attempts tells, so no pick path has to reset it).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import numpy as np

from robot_app.arrays import FloatArray
from robot_app.control.cell import Cell, StereoCapture
from robot_app.control.clear_table_records import BoxPlace, ClearTableSettings, TableArea
from robot_app.control.intercept import hanging_reach
from robot_app.control.job_motion import JobMotion, LayOutPath, cloth_half_width, lay_out_paths
from robot_app.control.loop_settings import LoopSettings
from robot_app.control.table_survey import TablePlane
from robot_app.errors import IKError
from robot_app.vision import ClothModel, PinholeCamera
from robot_app.vision.identify import Identification


class TableRecovery:
    """Put back and look around for one job.

    Args:
        motion: the job's own moves.
        cell: the robot cell (the gripper).
        table: the table plane in the right camera.
        camera: the right camera (its image size bounds the view).
        settings: the job's settings (`put_back`, `put_down_*`, `look_around`, `look_apart`).
        loop_settings: the gripper's openings and waits (`release_wait`, `close_time`,
            `gripper_open`, `settle_time`).
        table_top: the table top's extent (None: unknown; a put-back then lays out
            within the survey's view only, wherever that lies).
        boxes: the collection boxes, whose walls no laid cloth may lie on.
    """

    def __init__(
        self,
        motion: JobMotion,
        cell: Cell,
        table: TablePlane,
        camera: PinholeCamera,
        settings: ClearTableSettings,
        loop_settings: LoopSettings,
        table_top: TableArea | None = None,
        boxes: Sequence[BoxPlace] = (),
        sheet: TableArea | None = None,
    ) -> None:
        self.motion = motion
        self.table_top = table_top
        self.sheet = sheet
        self.boxes = tuple(boxes)
        self.cell = cell
        self.table = table
        self.camera = camera
        self.settings = settings
        self.loop_settings = loop_settings
        self.looked: list[FloatArray] = []  # places looked at since the last pick attempt
        self.put_back_spots: list[FloatArray] = []
        self._attempts = 0  # pick attempts booked when `looked` was last started afresh

    def forget(self) -> None:
        """A new job run: no put-back spots, nothing looked at."""
        self.looked = []
        self.put_back_spots = []
        self._attempts = 0

    # ------------------------------------------------------------------ looking around
    def places_to_look(
        self,
        capture: StereoCapture,
        ident: Identification,
        last_seen: Mapping[str, FloatArray],
        look_for: Callable[[str], bool],
        dropped_on: tuple[FloatArray, ...] = (),
        attempts: int = 0,
    ) -> list[FloatArray]:
        """Where to look again when a survey left nothing to pick (`look_around`): put-back
        spots, then places on the way of a drop (`dropped_on`, (x, y) [m]), then cloths
        seen before (`last_seen`, (x, y) [m]) that `look_for` names, then unknown regions;
        none within `look_apart` of one another or of a place already looked at since the
        last pick attempt (`attempts`: the job's pick attempts booked so far; a new one
        gives `look_around` looks again)."""
        if attempts != self._attempts:
            self.looked, self._attempts = [], attempts
        candidates = [
            *reversed(self.put_back_spots),
            *dropped_on,
            *(xy for name, xy in last_seen.items() if look_for(name)),
            *(np.array(self.table.point(capture, region.centroid)) for region in ident.unknown),
        ]
        places: list[FloatArray] = []
        here = capture.transform_right_camera_to_world[:2, 3]
        for xy in candidates:
            taken = [here, *self.looked, *places]
            if all(float(np.hypot(*(xy - other))) > self.settings.look_apart for other in taken):
                places.append(np.asarray(xy, dtype=float))
        return places[: max(0, self.settings.look_around - len(self.looked))]

    def look_from(
        self,
        place: FloatArray,
        camera_offset: FloatArray,
        camera_z: float,
        from_xy: FloatArray | None = None,
    ) -> bool:
        """Moves the right camera over `place` at the height `camera_z` [m] (cameras looking
        down; `camera_offset`: camera minus TCP [m]). Where the arm cannot reach that pose,
        the camera goes as far towards `place` from `from_xy` ((2,) [m]; None: not at all)
        as it reaches, in quarters of the way: the view is some 0.5 m wide, so a pose short
        of the place still sees what lies there (bench episode 64, session 20: a put-back heap
        at x = 0.79-0.86 m, y = 0.23-0.32 m; both looks over it were out of reach, the survey
        saw nothing and the job stopped). False if no such pose is reachable."""
        target = np.asarray(place, dtype=float)[:2]
        start = target if from_xy is None else np.asarray(from_xy, dtype=float)[:2]
        for share in (1.0, 0.75, 0.5, 0.25) if from_xy is not None else (1.0,):
            xy = start + share * (target - start)
            tcp = np.array([xy[0] - camera_offset[0], xy[1] - camera_offset[1], camera_z - camera_offset[2]])
            try:
                self.motion.move_tcp(tcp)
            except IKError:
                continue
            self.motion.hold(self.loop_settings.settle_time)
            return True
        return False

    # ------------------------------------------------------------------ put back
    def put_back(
        self,
        survey: StereoCapture,
        model: ClothModel,
        grasp_point_model: FloatArray | None,
        obstacles_xy: FloatArray | None,
        notes: list[str],
        lifted_at: FloatArray | None = None,
    ) -> tuple[FloatArray, FloatArray]:
        """Lays what the gripper holds back onto the table, spread out over free table in
        the survey's view and on the table top, clear of the boxes (`job_motion.lay_out_paths`;
        where no laid cloth fits in the view, over the table beyond it); if no such path is
        reachable, lowers it while moving away from the view's middle (towards it where the
        table ends that way). Lets go and rises clear of the laid
        cloth; the caller goes on from there (no way back to the lift pose: the next move
        is home). Where a blind grasp could not reach the table under the hand (a look at
        what hangs took it there), it first goes back over `lifted_at` ((3,) [m], the TCP
        after the lift), at its height now: the laid cloth starts under the hand. Replay of
        held-out episode 519 (session 30): the look at a lift of four cloths took them
        towards the arm's base, the put-back laid them out from there, and nine blind grasps
        had no IK solution. Returns the laid strip: from above where it was lifted to where
        it was let go ((2,) x, y [m] each)."""
        s, table_z = self.settings, self.table.table_z
        above = self.motion.tcp_position()
        if lifted_at is not None and not self._graspable_at(above[:2]):
            back = np.array([lifted_at[0], lifted_at[1], above[2]])
            try:
                self.motion.move_tcp(back)
                notes.append("put back from over the lift: no blind grasp reaches the table under the look")
                above = back
            except IKError:
                pass
        if not (s.put_back.lay_out and self.lay_down(survey, model, grasp_point_model, obstacles_xy, notes)):
            outward = above[:2] - survey.transform_right_camera_to_world[:2, 3]
            outward = outward / max(float(np.linalg.norm(outward)), 1e-9)
            slid = above[:2] + s.put_down_slide * outward
            if self.table_top is not None and not self.table_top.contains(slid, s.put_back.view_margin)[0]:
                outward = -outward  # the table ends that way: towards the view's middle
            notes.append(
                f"put back lowered by the lift, {s.put_down_slide * 1000:.0f} mm towards "
                f"({outward[0]:+.2f}, {outward[1]:+.2f})"
                + (": no lay-out path reachable" if s.put_back.lay_out else "")
            )
            down = above.copy()
            down[:2] += s.put_down_slide * outward
            down[2] = table_z + s.put_down_height
            self.motion.move_tcp(down, speed=s.put_down_speed)
        self.cell.release()
        self.put_back_spots.append(self.motion.tcp_position()[:2])
        strip = (above[:2].copy(), self.put_back_spots[-1].copy())
        self.motion.hold(self.loop_settings.release_wait)
        self.cell.set_gripper(self.loop_settings.gripper_open)
        self.motion.hold(self.loop_settings.close_time)
        # straight up first: the open fingers leave the laid cloth alone
        up = self.motion.tcp_position()
        up[2] = table_z + s.put_down_height + s.put_back.max_length
        self.motion.move_tcp(up)
        return strip

    def lay_down(
        self,
        survey: StereoCapture,
        model: ClothModel,
        grasp_point_model: FloatArray | None,
        obstacles_xy: FloatArray | None,
        notes: list[str],
    ) -> bool:
        """Lays what the gripper holds down along the first reachable lay-out path from
        where the hand is (`put_back`'s), still holding it; False (nothing moved) when no
        path is reachable."""
        above = self.motion.tcp_position()
        path = self._lay_out_joints(survey, model, grasp_point_model, obstacles_xy, above, notes)
        if path is None:
            return False
        for q in path:
            self.motion.move_to_joints(q, speed=self.settings.put_down_speed)
        return True

    def _lay_out_joints(
        self,
        survey: StereoCapture,
        model: ClothModel,
        grasp_point_model: FloatArray | None,
        obstacles_xy: FloatArray | None,
        above: FloatArray,
        notes: list[str],
    ) -> list[FloatArray] | None:
        """Joints of the first reachable lay-out path (most free first), or None."""
        grasp = grasp_point_model if grasp_point_model is not None else model.grasp_point
        reach = hanging_reach(model.points_in, grasp)
        width, height = self.camera.image_size
        view = self.table.pixels(survey, [0, width - 1, width - 1, 0], [0, 0, height - 1, height - 1])
        obstacles = obstacles_xy if obstacles_xy is not None else np.empty((0, 2))
        table = None if self.table_top is None else self.table_top.corners()
        walls = [(b.centre[:2], b.outer_half) for b in self.boxes]
        half_width = cloth_half_width(model.points_in)

        def paths_within(room: FloatArray, area: FloatArray | None = table) -> tuple[LayOutPath, ...]:
            return lay_out_paths(
                above[:2],
                reach,
                self.table.table_z,
                self.settings.put_down_height,
                obstacles,
                room,
                self.settings.put_back,
                half_width=half_width,
                table_xy=area,
                keep_out=walls,
            )

        def fitting(paths: tuple[LayOutPath, ...]) -> tuple[LayOutPath, ...]:
            return tuple(p for p in paths if p.fits)

        # with `put_back.on_sheet`, first where the laid cloth fits on the green sheet
        sheet = self.sheet.corners() if self.sheet is not None and self.settings.put_back.on_sheet else None
        on_sheet = () if sheet is None else fitting(paths_within(view, sheet))
        in_view = paths_within(view)
        # where no laid cloth fits in the view (the lift was at its edge), the sheet and then
        # the table beyond it before a laid cloth half outside the view or a heap lowered on
        # the spot
        inside = bool(fitting(in_view))
        beyond_sheet = () if sheet is None or inside else fitting(paths_within(sheet, sheet))
        beyond = () if table is None or inside else paths_within(table)
        ordered = [
            *on_sheet,
            *fitting(in_view),
            *beyond_sheet,
            *fitting(beyond),
            *(p for p in (*in_view, *beyond) if not p.fits),
        ]
        for path in ordered:
            joints: list[FloatArray] = []
            try:
                for point in path.waypoints:
                    joints.append(self.motion.solve_tcp(point))
            except IKError:
                continue
            if not self._graspable_along(path, half_width):
                continue
            notes.append(
                f"put back laid out over {min(reach, self.settings.put_back.max_length) * 1000:.0f} mm "
                f"towards ({path.direction[0]:+.2f}, {path.direction[1]:+.2f})"
                + ("" if path.fits else ", the laid cloth partly outside the view")
            )
            return joints
        return None

    def _graspable_along(self, path: LayOutPath, half_width: float) -> bool:
        """Can a blind grasp later reach the laid cloth (`_graspable_at`): over the strip's
        start, middle and end (where the hand lets go), `half_width` [m] to either side of
        the end and `put_back.reach_margin` past it (a heap spreads past the end)? The
        likeliest misses are asked first. A cloth laid towards the arm's base lay out of
        every grasp's reach (bench episode 30, session 20: No.7 laid back to x = 0.22 m,
        then four blind attempts `out of reach`; the replay of held-out 519, session 30:
        four cloths laid out to (0.24, -0.27), 0.37 m from the base, spread across the
        strip to 0.28 m, where no blind grasp reaches the table)."""
        end = path.waypoints[-1][:2]
        across = np.array([-path.direction[1], path.direction[0]]) * half_width
        past = end + self.settings.put_back.reach_margin * path.direction
        middle = path.waypoints[len(path.waypoints) // 2][:2]
        spots = (past, end + across, end - across, end, middle, path.waypoints[0][:2])
        return all(self._graspable_at(xy) for xy in spots)

    def _graspable_at(self, xy: FloatArray) -> bool:
        """Does a blind grasp reach the table at `xy` ((2,) [m]): the pregrasp, grasp
        (`lost.grasp_height`) and lift heights over it?"""
        table_z, loop = self.table.table_z, self.loop_settings
        heights = (loop.pregrasp_height, self.settings.lost.grasp_height, loop.lift_height)
        return all(self.motion.reaches([xy[0], xy[1], table_z + h]) for h in heights)


__all__ = ["TableRecovery"]
