"""The clear-table job's recovery moves: a wrong or double lift laid back onto free table
(`put_back`), and, when a survey leaves nothing to pick, the places to look again from
(`places_to_look`, `look_from`).

`TableRecovery` remembers, over one job run, where it put cloths back and where it has
looked since the last pick attempt.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np
from scipy.spatial import cKDTree

from robot_app.arrays import FloatArray
from robot_app.control.cell import Cell, StereoCapture
from robot_app.control.clear_table_records import ClearTableSettings
from robot_app.control.intercept import hanging_reach
from robot_app.control.job_motion import JobMotion, cloth_half_width, lay_out_paths
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
    """

    def __init__(
        self,
        motion: JobMotion,
        cell: Cell,
        table: TablePlane,
        camera: PinholeCamera,
        settings: ClearTableSettings,
        loop_settings: LoopSettings,
    ) -> None:
        self.motion = motion
        self.cell = cell
        self.table = table
        self.camera = camera
        self.settings = settings
        self.loop_settings = loop_settings
        self.looked: list[FloatArray] = []  # places looked at since the last pick attempt
        self.put_back_spots: list[FloatArray] = []
        self.laid: list[tuple[FloatArray, FloatArray]] = []  # each put-back's (start, let-go) (x, y) [m]

    def forget(self) -> None:
        """A new job run: no put-back spots, nothing looked at."""
        self.looked = []
        self.put_back_spots = []
        self.laid = []

    # ------------------------------------------------------------------ looking around
    def places_to_look(
        self,
        capture: StereoCapture,
        ident: Identification,
        last_seen: Mapping[str, FloatArray],
        look_for: Callable[[str], bool],
        dropped_on: tuple[FloatArray, ...] = (),
    ) -> list[FloatArray]:
        """Where to look again when a survey left nothing to pick (`look_around`): put-back
        spots, then places on the way of a drop (`dropped_on`, (x, y) [m]), then cloths
        seen before (`last_seen`, (x, y) [m]) that `look_for` names, then unknown regions;
        none within `look_apart` of one another or of a place already looked at."""
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

    def look_from(self, place: FloatArray, camera_offset: FloatArray, camera_z: float) -> bool:
        """Moves the right camera over `place` at the height `camera_z` [m] (cameras looking
        down; `camera_offset`: camera minus TCP [m]); False if the arm cannot reach that pose."""
        tcp = np.array(
            [place[0] - camera_offset[0], place[1] - camera_offset[1], camera_z - camera_offset[2]]
        )
        try:
            self.motion.move_tcp(tcp)
        except IKError:
            return False
        self.motion.hold(self.loop_settings.settle_time)
        return True

    # ------------------------------------------------------------------ put back
    def put_back(
        self,
        survey: StereoCapture,
        model: ClothModel,
        grasp_point_model: FloatArray | None,
        obstacles_xy: FloatArray | None,
        notes: list[str],
    ) -> None:
        """Lays what the gripper holds back onto the table, spread out over free table in
        the survey's view (`job_motion.lay_out_paths`), from where it was lifted or, with
        `put_back_away`, from the freest spot within that distance (`free_starts`); if no
        such path is reachable, lowers it while moving away from the view's middle. Lets
        go and rises clear of the laid cloth; the caller goes on from there (no way back
        to the lift pose: the next move is home)."""
        s, table_z = self.settings, self.table.table_z
        above = self.motion.tcp_position()
        path = (
            self._lay_out_joints(survey, model, grasp_point_model, obstacles_xy, above, notes)
            if s.put_back.lay_out
            else None
        )
        start = above[:2].copy()
        if path is not None:
            start, over, laid = path
            if over is not None:  # over the start, at the lift's height
                self.motion.move_to_joints(over)
            for q in laid:
                self.motion.move_to_joints(q, speed=s.put_down_speed)
        else:
            outward = above[:2] - survey.transform_right_camera_to_world[:2, 3]
            outward = outward / max(float(np.linalg.norm(outward)), 1e-9)
            down = above.copy()
            down[:2] += s.put_down_slide * outward
            down[2] = table_z + s.put_down_height
            self.motion.move_tcp(down, speed=s.put_down_speed)
        self.cell.release()
        self.put_back_spots.append(self.motion.tcp_position()[:2])
        self.laid.append((np.asarray(start, dtype=float).copy(), self.put_back_spots[-1].copy()))
        self.motion.hold(self.loop_settings.release_wait)
        self.cell.set_gripper(self.loop_settings.gripper_open)
        self.motion.hold(self.loop_settings.close_time)
        # straight up first: the open fingers leave the laid cloth alone
        up = self.motion.tcp_position()
        up[2] = table_z + s.put_down_height + s.put_back.max_length
        self.motion.move_tcp(up)

    def _lay_out_joints(
        self,
        survey: StereoCapture,
        model: ClothModel,
        grasp_point_model: FloatArray | None,
        obstacles_xy: FloatArray | None,
        above: FloatArray,
        notes: list[str],
    ) -> tuple[FloatArray, FloatArray | None, list[FloatArray]] | None:
        """The lay-out's start (x, y) [m], the joints over it at the lift's height (None: it
        is where the cloth was lifted) and those of the first reachable lay-out path from
        there (most free first), or None."""
        grasp = grasp_point_model if grasp_point_model is not None else model.grasp_point
        reach = hanging_reach(model.points_in, grasp)
        half_width = cloth_half_width(model.points_in)
        width, height = self.camera.image_size
        view = self.table.pixels(survey, [0, width - 1, width - 1, 0], [0, 0, height - 1, height - 1])
        obstacles = obstacles_xy if obstacles_xy is not None else np.empty((0, 2))
        lay_out = self.settings.put_back
        starts = [above[:2]]
        if self.settings.put_back_away > 0:
            away = free_starts(
                above[:2], reach, half_width, obstacles, view, self.table.table_z, self.settings
            )
            starts = [*away[: self.settings.put_back_tries], above[:2]]
        for start in starts:
            over = np.array([start[0], start[1], above[2]])
            paths = lay_out_paths(
                start,
                reach,
                self.table.table_z,
                self.settings.put_down_height,
                obstacles,
                view,
                lay_out,
                half_width,
            )
            moved = float(np.hypot(*(start - above[:2])))
            for path in paths:
                joints: list[FloatArray] = []
                try:
                    first = self.motion.solve_tcp(over) if moved > 0 else None
                    for point in path.waypoints:
                        joints.append(self.motion.solve_tcp(point))
                except IKError:
                    continue
                notes.append(
                    (
                        f"put back {moved * 1000:.0f} mm away from the lift, on the freest table; "
                        if moved > 0
                        else "put back "
                    )
                    + f"laid out over {min(reach, lay_out.max_length) * 1000:.0f} mm "
                    f"towards ({path.direction[0]:+.2f}, {path.direction[1]:+.2f})"
                    + ("" if path.fits else ", the laid cloth partly outside the view")
                )
                return start, first, joints
        return None


def free_starts(
    lifted_xy: FloatArray,
    reach: float,
    half_width: float,
    obstacles_xy: FloatArray,
    view_xy: FloatArray,
    table_z: float,
    settings: ClearTableSettings,
) -> list[FloatArray]:
    """Where to start laying a rejected lift out instead of where it was lifted
    (`lifted_xy`, (2,) [m]): the points of a `put_back_step` grid within `put_back_away`
    of it whose best lay-out path (`lay_out_paths`) keeps the whole laid cloth inside the
    view (`view_xy`, (4, 2) corners [m]) and farther from every other cloth
    (`obstacles_xy`, (M, 2) [m]) than the best path from `lifted_xy` does, by at least
    `put_back_step`: the farthest first (the nearer of equals). A spot's distance is its
    freest fitting strip's (`reach` long, `half_width` to either side [m]) to the nearest
    other cloth, counted up to `put_back.free_distance` beyond the half width; empty if
    no spot is farther. (The put-back then takes the fitting path of most mean freedom
    from there, as from any start.)"""
    s = settings
    obstacles = np.asarray(obstacles_xy, dtype=float).reshape(-1, 2)
    corners = np.asarray(view_xy, dtype=float).reshape(4, 2)
    tree = cKDTree(obstacles) if len(obstacles) else None
    cap = half_width + s.put_back.free_distance
    none = np.empty((0, 2))  # the paths' fit only: their freedom is measured here, once per strip

    def clearance(start: FloatArray) -> float | None:
        """The best fitting path's strip: its nearest other cloth [m] (None: none fits)."""
        paths = lay_out_paths(start, reach, table_z, s.put_down_height, none, corners, s.put_back, half_width)
        ends = [p.waypoints[-1, :2] for p in paths if p.fits]
        if not ends:
            return None
        if tree is None:
            return cap
        strips = start + np.linspace(0.0, 1.0, 11)[None, :, None] * (np.asarray(ends) - start)[:, None, :]
        distances = tree.query(strips.reshape(-1, 2))[0].reshape(len(ends), -1)
        return min(cap, float(distances.min(axis=1).max()))

    lifted = np.asarray(lifted_xy, dtype=float).reshape(2)
    here = clearance(lifted)
    low, high = corners.min(axis=0), corners.max(axis=0)
    grid = np.stack(
        np.meshgrid(*(np.arange(a, b, s.put_back_step) for a, b in zip(low, high, strict=True))), -1
    )
    found: list[tuple[float, float, FloatArray]] = []
    for start in grid.reshape(-1, 2):
        moved = float(np.hypot(*(start - lifted)))
        if moved > s.put_back_away:
            continue
        free = clearance(start)
        if free is not None and free >= (here if here is not None else -np.inf) + s.put_back_step:
            found.append((-free, moved, start))
    found.sort(key=lambda item: (item[0], item[1]))
    return [start for _, _, start in found]


__all__ = ["TableRecovery"]
