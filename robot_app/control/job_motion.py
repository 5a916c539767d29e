"""Arm motions between pick-and-place episodes: the jerk-limited moves a job makes itself.

A job that runs `PickPlaceLoop` once per cloth also moves the arm on its own: it holds
still while it looks, lowers a cloth it should not have lifted back onto the table, goes
to another observation pose. `JobMotion` does that with the loop's means (ruckig
point-to-point plans within `JointLimits`, Pinocchio IK with the cameras looking
straight down, one command per control period, contact checks), starting from the last
commanded state of the cell (a `LoggedCell`), so the hand-over to and from the loop is
seamless; every motion ends at rest.

**Putting a lift back** (`lay_out_paths`): a lift that took two cloths (or the wrong
one) goes back onto the table. Lowered on the spot, the hanging cloths fold onto
themselves into a heap that no photo model explains, and the next survey finds no known
cloth there. Laid out instead, the way one lays a towel down: lower until the hanging
cloth's lowest point touches the table, then move on over the table while lowering
further, so that the cloth lies down along the path, `reach` long (its hanging length),
before the fingers let go. The direction: among `directions` evenly spread ones, those
whose laid strip stays inside the survey's view of the table (by `view_margin`), those
whose laid cloth does too first, then by how free the strip is (the mean distance of its
points to the other cloths the survey saw, each counted up to `free_distance`; the start
is common to all; strips within `FREEDOM_STEP` of one another are equally free, and the one
whose laid cloth lies deepest inside the view comes first: with the first angle winning
ties, every free strip ran along +x, towards the view's far edge, where put-back heaps
ended unseen or seen in part in bench episodes 8, 9 and 64), then the others, the least
outside first. The job tries them in that
order until one is reachable. The laid
cloth is wider than the strip: it reaches `half_width` to either side of it (half the
cloth's width; a double lift is wider still), and the part of a cloth longer than
`max_length` that is not laid falls around the strip's end. A path whose strip alone
stays in the view can lay the cloth half outside it, where no survey finds it again (and
whence it may slide off the sheet), so such paths come only after those whose whole laid
cloth stays inside.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from pydantic import Field
from scipy.spatial import cKDTree

from robot_app.arrays import FloatArray
from robot_app.config import StrictModel
from robot_app.control.kinematics import Kinematics
from robot_app.control.limits import JointLimits
from robot_app.control.logged_cell import LoggedCell
from robot_app.control.trajectory import (
    JoinedTrajectory,
    JointTrajectory,
    plan_point_to_point,
    plan_slowing_down,
)
from robot_app.errors import IKError
from robot_app.geometry import make_transform

StepCallback = Callable[[], None]

FREEDOM_STEP = 0.01  # [m] lay-out strips this close in freedom are equally free


class JobMotion:
    """Moves the arm of a `LoggedCell` between episodes (inside one, the loop's `ArmMotion` does).

    Args:
        cell: the logged cell (its last command is where motions start).
        kinematics: the arm with its `tcp` frame.
        limits: joint limits of every commanded sample.
        observation_joints: the observation pose [rad]; its hand orientation is kept.
        on_step: called after every control step (video frames, stop requests).
        ik_time_budget: per IK solve [s]; ik_tolerance: [m] and [rad].
        collision_check_period: [s] between contact checks.
    """

    def __init__(
        self,
        cell: LoggedCell,
        kinematics: Kinematics,
        limits: JointLimits,
        observation_joints: npt.ArrayLike,
        *,
        on_step: StepCallback | None = None,
        ik_time_budget: float = 0.1,
        ik_tolerance: float = 1e-4,
        collision_check_period: float = 0.05,
    ) -> None:
        self.cell = cell
        self.kinematics = kinematics
        self.limits = limits
        self.observation_joints = np.array(observation_joints, dtype=float)
        self.tcp_rotation = kinematics.frame_pose(self.observation_joints, "tcp")[:3, :3].copy()
        self.on_step = on_step
        self.ik_time_budget = ik_time_budget
        self.ik_tolerance = ik_tolerance
        self.collision_check_period = collision_check_period
        self.collisions = 0
        self._next_check = cell.time

    @property
    def q(self) -> FloatArray:
        """Where motions start: the last commanded joints (measured before any command)."""
        last = self.cell.last_command
        return last if last is not None else np.array(self.cell.joint_positions(), dtype=float)

    def tcp_position(self, q: npt.ArrayLike | None = None) -> FloatArray:
        """TCP position [m] in Σ_W at `q` (default: the last command)."""
        return self.kinematics.frame_pose(self.q if q is None else np.asarray(q, dtype=float), "tcp")[
            :3, 3
        ].copy()

    def solve_tcp(self, position: npt.ArrayLike) -> FloatArray:
        """Joints putting the TCP at `position` [m] with the observation pose's orientation.

        Raises:
            IKError: no solution within the joint limits.
        """
        target = make_transform(self.tcp_rotation, np.asarray(position, dtype=float))
        result = None
        for budget in (self.ik_time_budget, 5 * self.ik_time_budget):
            result = self.kinematics.solve_ik(
                target,
                self.q,
                frame="tcp",
                time_budget=budget,
                position_tolerance=self.ik_tolerance,
                orientation_tolerance=self.ik_tolerance,
                preferred_posture=self.observation_joints,
            )
            if result.success and self.limits.contains(result.q):
                return np.array(result.q, dtype=float)
        where = ", ".join(f"{v:.3f}" for v in np.asarray(position, dtype=float))
        residual = float("nan") if result is None else result.position_error * 1e3
        raise IKError(
            f"no IK solution within the joint limits for the TCP at ({where}) m: residual {residual:.1f} mm"
        )

    def move_to_joints(self, q_goal: npt.ArrayLike, speed: float = 1.0) -> None:
        """Jerk-limited move from rest to rest at `q_goal` [rad], limits scaled by `speed` (0, 1]."""
        limits = self.limits if speed >= 1.0 else self.limits.scaled(speed)
        start = self.q
        trajectory = plan_point_to_point(start, np.asarray(q_goal, dtype=float), limits, dt=self.cell.dt)
        self._follow(trajectory)

    def move_slowing_down(self, q_goal: npt.ArrayLike, speed: float, below: float) -> None:
        """Jerk-limited move from rest to rest at `q_goal` [rad], the limits scaled by `speed`
        once the TCP is at or below the height `below` [m] (Σ_W z), full limits above it,
        without a stop in between (`trajectory.plan_slowing_down`)."""
        trajectory = plan_slowing_down(
            self.q,
            np.asarray(q_goal, dtype=float),
            self.limits,
            self.limits.scaled(speed),
            lambda q: bool(self.tcp_position(q)[2] <= below),
            dt=self.cell.dt,
        )
        self._follow(trajectory)

    def _follow(self, trajectory: JointTrajectory | JoinedTrajectory) -> None:
        """Send every control sample of `trajectory` after its start."""
        steps = round(trajectory.duration / self.cell.dt)
        for k in range(1, steps + 1):
            sample = trajectory.sample(k * self.cell.dt)
            self._send(sample.q, sample.v)

    def reaches(self, position: npt.ArrayLike) -> bool:
        """Does `solve_tcp(position)` have a solution (from the joints now)?"""
        try:
            self.solve_tcp(position)
        except IKError:
            return False
        return True

    def move_tcp(self, position: npt.ArrayLike, speed: float = 1.0) -> None:
        """Moves the TCP to `position` [m] (cameras looking down)."""
        self.move_to_joints(self.solve_tcp(position), speed)

    def hold(self, duration: float) -> None:
        """Holds the last command for `duration` [s] (rounded to control periods)."""
        q = self.q
        for _ in range(max(0, round(duration / self.cell.dt))):
            self._send(q, np.zeros_like(q))

    def _send(self, q: FloatArray, v: FloatArray) -> None:
        self.cell.command_joints(q, v)
        self.cell.step()
        if self.cell.time >= self._next_check:
            self._next_check += self.collision_check_period
            self.collisions += self.cell.collisions()
        if self.on_step is not None:
            self.on_step()


class PutBackSettings(StrictModel):
    """How a rejected lift is put back (the `clear.put_back` section). Lengths [m].

    Attributes:
        lay_out: lay the cloth out along a path (False: lower it on the spot, sliding
            `clear.put_down_slide` outwards).
        directions: directions tried, evenly spread over the circle.
        max_length: the laid strip is the cloth's hanging reach long, at most this.
        view_margin: the strip stays this far inside the survey's view of the table.
        waypoints: the lay-out path's rest-to-rest moves.
        free_distance: a strip point this far from every other cloth counts as free.
        shed: before a double pick is put back, lay it down along such a path without
            letting go and lift it again (`TableClearer._shed`): a cloth that came along
            held by nothing (dragged, lying on the lifted one) may stay on the table, and
            the meant cloth, weighed alone then, goes on to its box. Off: in the simulated
            cell no shed of 6 left its other cloth behind (bench episodes 29-32 and 43,
            session 20; 3 of them dragged cloths), and each cost about 4 s.
        reach_margin: a blind grasp must reach the laid cloth this far past the strip's
            end too (`TableRecovery._graspable_along`): a double pick's heap spreads past
            it. Replay of held-out episode 519 (session 30): four cloths laid out 207 mm
            towards the arm's base from a lift at x = 0.47 m, the strip's end graspable at
            x = 0.29 m; the heap lay to x = 0.18 m and its blind grasps had no IK solution.
        on_sheet: lay the cloth out on the green sheet (`view_margin` inside its edge) where
            a path's laid cloth fits there in the view, before anywhere else in it; where
            none fits in the view, on the sheet beyond it before the bare table
            (`TableRecovery._lay_out_joints`): a survey reads cloths against the sheet, and
            one laid on the bare table beside it may not be found again. Held-out 1703
            (session 48): a lift at the view's edge laid No.9 out towards the box, to the
            sheet's edge, the next put-back off it; no rule took it again.
    """

    lay_out: bool = True
    shed: bool = False
    directions: int = Field(12, ge=1, le=72)
    max_length: float = Field(0.25, gt=0.0, le=0.5)
    view_margin: float = Field(0.04, ge=0.0, le=0.2)
    waypoints: int = Field(3, ge=1, le=10)
    free_distance: float = Field(0.1, gt=0.0, le=0.5)
    reach_margin: float = Field(0.1, ge=0.0, le=0.5)
    on_sheet: bool = False


@dataclass(frozen=True)
class LayOutPath:
    """One way to lay the held cloth down.

    Attributes:
        direction: (2,) unit vector in Σ_W (x, y) the hand moves along.
        waypoints: (K, 3) TCP positions [m] in Σ_W: the first above the start where the
            cloth touches, the last where the fingers let go.
        freedom: the strip points' mean distance to the nearest other cloth, each up to
            `free_distance` [m].
        fits: the whole laid cloth (the strip widened by `half_width`, its end by the part
            not laid) stays inside the view by `view_margin`.
        slack: by how much it does [m] (negative: how far it lies past the margin).
    """

    direction: FloatArray
    waypoints: FloatArray
    freedom: float
    fits: bool = True
    slack: float = float("inf")


def lay_out_paths(
    start_xy: npt.ArrayLike,
    reach: float,
    table_z: float,
    release_height: float,
    obstacles_xy: npt.ArrayLike,
    view_xy: npt.ArrayLike,
    settings: PutBackSettings | None = None,
    half_width: float = 0.0,
    table_xy: npt.ArrayLike | None = None,
    keep_out: Sequence[tuple[npt.ArrayLike, float]] = (),
) -> tuple[LayOutPath, ...]:
    """The lay-out paths inside the view, those whose laid cloth fits first, then most free
    first (module docstring). "Inside the view" is inside the view and the table top
    (`table_xy`) and outside every `keep_out` square.

    Args:
        start_xy: (2,) where the hand is now, (x, y) in Σ_W [m].
        reach: the held cloth's hanging length below the TCP [m].
        table_z: the table top [m].
        release_height: TCP above the table where the fingers let go [m].
        obstacles_xy: (M, 2) points of the other cloths on the table [m].
        view_xy: (4, 2) the view's corners on the table, in order around it [m].
        settings: see `PutBackSettings`.
        half_width: how far the laid cloth reaches to either side of the strip [m].
        table_xy: (4, 2) the table top's corners, in order around it [m] (None: the view
            lies on the table).
        keep_out: ((2,) centre, half side) of squares on the table no strip and no laid
            cloth may enter (the collection boxes' outer walls) [m].

    Raises:
        ValueError: a negative reach, half width or release height, or not 4 view corners.
    """
    s = settings or PutBackSettings()
    if reach < 0 or release_height <= 0 or half_width < 0:
        raise ValueError(
            "reach and half_width must be >= 0 and release_height > 0 [m], "
            f"got {reach}, {half_width}, {release_height}"
        )
    corners = np.asarray(view_xy, dtype=float)
    table = None if table_xy is None else np.asarray(table_xy, dtype=float)
    for name, quad in (("view_xy", corners), ("table_xy", table)):
        if quad is not None and quad.shape != (4, 2):
            raise ValueError(f"{name} must be (4, 2) corners, got {quad.shape}")
    squares = [(np.asarray(c, dtype=float).reshape(2), float(half)) for c, half in keep_out]

    def depth(points: FloatArray) -> FloatArray:
        return _room_depth(points, corners, table, squares)

    start = np.asarray(start_xy, dtype=float).reshape(2)
    length = min(reach, s.max_length)
    rest = reach - length  # not laid: falls around the strip's end
    touch = table_z + max(release_height, reach)
    obstacles = np.asarray(obstacles_xy, dtype=float).reshape(-1, 2)
    tree = cKDTree(obstacles) if len(obstacles) else None
    paths = []
    for angle in np.arange(s.directions) * 2 * np.pi / s.directions:
        direction = np.array([np.cos(angle), np.sin(angle)])
        strip = start + np.linspace(0.0, 1.0, 11)[:, None] * length * direction
        if not np.all(depth(strip) >= s.view_margin):
            continue
        # the laid cloth: beside the strip (past the start, where it lay before) and round its end
        slack = (
            min(
                float(depth(strip[1:]).min()) - half_width,
                float(depth(strip[-1:])[0]) - max(half_width, rest),
            )
            - s.view_margin
        )
        distances = tree.query(strip)[0] if tree is not None else np.full(len(strip), np.inf)
        freedom = float(np.mean(np.minimum(distances, s.free_distance)))
        t = np.linspace(0.0, 1.0, s.waypoints + 1)[:, None]
        xy = start + t * length * direction
        z = touch + t[:, 0] * (table_z + release_height - touch)
        paths.append(LayOutPath(direction, np.column_stack([xy, z]), freedom, slack >= 0, slack))
    # those that fit, most free first (a centimetre apart counts as equally free: then the one
    # whose laid cloth lies deepest inside, not the first angle, +x, to the view's far edge);
    # then the others, the least outside first
    return tuple(
        sorted(
            paths,
            key=lambda p: (not p.fits, -np.floor(p.freedom / FREEDOM_STEP) if p.fits else 0.0, -p.slack),
        )
    )


def cloth_half_width(points_model: npt.ArrayLike) -> float:
    """Half a cloth's width [m]: half its extent across its longer principal axis, from
    the model's points (N, 2 or 3) in its own plane."""
    xy = np.asarray(points_model, dtype=float)[:, :2]
    if len(xy) < 2:
        return 0.0
    centred = xy - xy.mean(axis=0)
    axes = np.linalg.svd(centred, full_matrices=False)[2]
    extents = np.ptp(centred @ axes.T, axis=0)
    return float(extents.min()) / 2


def _room_depth(
    points: FloatArray, view: FloatArray, table: FloatArray | None, squares: list[tuple[FloatArray, float]]
) -> FloatArray:
    """How far each point lies inside the view and the table top and outside every square
    ((2,) centre, half side) [m] (negative: outside, or in a square); a square's outside
    measured along x or y, whichever is farther (no nearer than it is)."""
    depth = _depth(points, view)
    if table is not None:
        depth = np.minimum(depth, _depth(points, table))
    for centre, half in squares:
        depth = np.minimum(depth, np.max(np.abs(points - centre), axis=1) - half)
    return depth


def _depth(points: FloatArray, corners: FloatArray) -> FloatArray:
    """How far each point lies inside the convex quadrilateral [m] (negative: outside)."""
    centre = corners.mean(axis=0)
    depth = np.full(len(points), np.inf)
    for k in range(4):
        a, b = corners[k], corners[(k + 1) % 4]
        edge = b - a
        normal = np.array([-edge[1], edge[0]]) / max(float(np.linalg.norm(edge)), 1e-12)
        if normal @ (centre - a) < 0:
            normal = -normal  # pointing inwards whatever the corners' turning sense
        depth = np.minimum(depth, (points - a) @ normal)
    return depth


__all__ = ["JobMotion", "LayOutPath", "PutBackSettings", "cloth_half_width", "lay_out_paths"]
