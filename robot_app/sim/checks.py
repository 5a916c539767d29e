"""Measured checks of the simulator: lift a cloth with the gripper, recognise a cloth
from its station photo in the hand stereo pair against ground truth, and lift from a pile
and put back without a soft-body blow-up.

The pile check (`pile_trial`): the clear-table job lifts cloths off piles, sometimes two
layers at once, and puts a double pick back down (control/table_clearer.py). The trial
does the same with the arm driven directly: it grips the top cloth of a pile where it
lies on another (as `SimCell.grasp` does: every cloth's nodes within the grasp radius are
anchored, so the one under it may come along), lifts, lowers the lift again beside the
grasp point, lets go, opens, moves away and lets the pile settle. Every simulation step
it measures what a blow-up shows: node speeds, edge stretch, nodes pressed into the
table, and at the end which cloths left the table.

Used by the slow tests, tests/test_pile_physics.py, `scripts/bench_sim.py` and
`scripts/pile_physics.py`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from itertools import combinations

import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray
from robot_app.geometry import make_transform, pose_error
from robot_app.sim.cell import SimCell
from robot_app.sim.cloth_body import ClothBody
from robot_app.sim.cloth_visual import ClothLook
from robot_app.sim.cloths import ClothSpec
from robot_app.sim.config import WorldConfig
from robot_app.sim.mesh_crossing import crossed_edges
from robot_app.sim.pile import Pile
from robot_app.sim.realism import scene_defaults
from robot_app.sim.station import ModelStation
from robot_app.sim.world import World

DRAGGED = 0.05  # [m] a cloth not held whose median node rose this far came up with a held one
TOOL_DOWN = np.diag([1.0, -1.0, -1.0])  # tcp z (tool axis) pointing down
FINGERTIP_CLEARANCE = 0.012  # tcp height above the cloth so the fingertips clear the table [m]


@dataclass(frozen=True)
class LiftResult:
    """Outcome of lifting a cloth by one gripped point.

    Attributes:
        anchored: number of nodes anchored to the gripper.
        max_stretch: largest edge length / rest length seen during the lift.
        lifted: height of the highest node above the table at the end [m].
        finite: no node position became NaN/inf.
    """

    anchored: int
    max_stretch: float
    lifted: float
    finite: bool


def lift_check(world: World, cloth: ClothBody, height: float = 0.3, duration: float = 1.0) -> LiftResult:
    """Grips the cloth at its node of largest world x and lifts it by `height` [m] in `duration` [s].

    The arm starts from the observation joints; it holds the top for 0.5 s before the end.
    """
    nodes = cloth.nodes()
    grip = nodes[np.argmax(nodes[:, 0])] + np.array([-0.01, 0.0, FINGERTIP_CLEARANCE])
    robot = world.robot
    q_grip = robot.solve_frame_ik("tcp", make_transform(TOOL_DOWN, grip), world.observation_joints)
    top = grip + np.array([0.0, 0.0, height])
    q_top = robot.solve_frame_ik("tcp", make_transform(TOOL_DOWN, top), q_grip)
    robot.reset_joints(q_grip)
    robot.set_gripper(0.0)
    anchored = cloth.grasp(robot, radius=0.025)
    ramp = max(1, round(duration / world.dt))
    stretch = 0.0
    for k in range(1, ramp + round(0.5 / world.dt) + 1):
        robot.command_joints(q_grip + (q_top - q_grip) * min(1.0, k / ramp))
        world.step()
        if k % 6 == 0:
            stretch = max(stretch, cloth.max_edge_stretch())
    final = cloth.nodes()
    return LiftResult(
        anchored,
        stretch,
        float(final[:, 2].max() - world.config.table.top_z),
        bool(np.all(np.isfinite(final))),
    )


@dataclass(frozen=True)
class RecognitionCheck:
    """Recognition of one cloth at the observation pose, against ground truth.

    The cloth lies as the world's realism preset lays it (flat in `clean`, wrinkled in
    `realistic`, maybe with a folded corner in `harsh`).

    Errors are in the right-camera frame; yaw errors are taken modulo the model's
    symmetry angles (a plain rectangle looks the same turned by 180°).
    """

    number: int
    found: bool
    fitness: float
    error_x_mm: float
    error_y_mm: float
    error_z_mm: float
    error_yaw_deg: float
    error_tilt_deg: float
    time_s: float


def recognition_check(
    spec: ClothSpec, config: WorldConfig, seed: int = 0, station: ModelStation | None = None
) -> RecognitionCheck:
    """Makes the cloth's model from the station photo, lays the cloth at a seeded random pose
    in the range (wrinkled and folded as the realism preset says), captures the stereo
    pair at the observation pose and recognises it."""
    from robot_app.vision.photo_model import make_model  # vision is optional for the sim
    from robot_app.vision.recognizer import Recognizer

    own_station = station is None
    station = station or ModelStation.for_world(config)
    try:
        photo = station.photograph(spec)
    finally:
        if own_station:
            station.close()
    model = make_model(photo.photo_bgr, photo.model_camera, photo.background_bgr, name=spec.name)
    rng = np.random.default_rng(seed)
    defaults = scene_defaults(config.realism)
    look_rng = np.random.default_rng((seed, 11))
    look = ClothLook.draw(look_rng, spec.size, defaults["wrinkle_amplitude"], defaults["fold_probability"])
    with World(config) as world:
        world.reseed(seed)
        # within 50 mm of the range centre, so that the cloth is whole in both cameras
        # (the left camera's view is shifted by the 0.1 m baseline)
        x, y = np.asarray(config.range.centre_xy) + rng.uniform(-0.05, 0.05, size=2)
        cloth = world.add_cloth(spec, float(x), float(y), float(rng.uniform(-np.pi, np.pi)), look=look)
        frame = world.stereo.render()
        truth = world.transform_model_to_camera(cloth)
        recognizer = Recognizer(model, world.stereo.rig)
        start = time.perf_counter()
        result = recognizer.recognize(frame.left_bgr, frame.right_bgr, seed=seed)
        elapsed = time.perf_counter() - start
    error = pose_error(result.transform_model_to_camera, truth, tuple(model.symmetry_angles))
    return RecognitionCheck(
        spec.number,
        bool(result.found),
        float(result.fitness),
        error.x_mm,
        error.y_mm,
        error.z_mm,
        error.yaw_deg,
        error.tilt_deg,
        elapsed,
    )


BLOW_UP_SPEED = 5.0  # [m/s] a node this fast was flung (a cloth dropped from 0.4 m lands at 2.8 m/s)
BLOW_UP_DEPTH = 0.02  # [m] a node this far below the table top is inside the table
TANGLED_STRETCH = 1.5  # an edge this much longer than at rest after the pile settled: torn or caught
ON_PILE = 0.01  # [m] a top-cloth node within this (horizontally) of another cloth's node lies on it


@dataclass(frozen=True)
class PileTrialSettings:
    """The scripted motion (durations of smooth joint-space moves [s], heights [m]).

    Defaults follow the clear-table job: grasp 22 mm above the cloth (loop.grasp_height),
    35 mm grasp radius, lift to 0.40 m in about the loop's time, put back down to 0.05 m
    (clear.put_down_height) 0.06 m outward (clear.put_down_slide) at 0.3 of the speed.
    With `lay_out` > 0 the put-down is the job's laid-out one (`control.put_back`): straight
    down until the TCP is `lay_out` above the table (the hanging cloth touches it), then
    `lay_out` outward while lowering to `put_down_height`, before letting go.
    """

    grasp_height: float = 0.022
    grasp_radius: float = 0.035
    lift_height: float = 0.40
    put_down_height: float = 0.05
    put_down_slide: float = 0.06
    approach_time: float = 1.5
    descend_time: float = 0.8
    close_time: float = 0.3
    lift_time: float = 1.1
    hold_time: float = 0.5
    put_down_time: float = 2.5
    release_wait: float = 1.0
    away_time: float = 1.1
    settle_time: float = 1.0
    lay_out: float = 0.0


@dataclass(frozen=True)
class PileTrialResult:
    """What the trial measured.

    Attributes:
        pile: catalogue numbers in drop order.
        held: the cloths whose nodes were anchored (two: a double pick).
        anchored: anchored nodes.
        lifted: lowest median node height above the table of a held cloth at the top of the
            lift [m] (0 if none was held).
        max_speed: fastest node of any cloth in any step [m/s], and `max_speed_phase` when.
        max_stretch: largest edge length over rest length in any step, `max_stretch_phase` when.
        depth: deepest a node went below the table top [m] (negative: all stayed above).
        final_stretch: largest edge stretch after the pile settled.
        fell: cloths with a node off the table top's extent or below it by BLOW_UP_DEPTH at the end.
        sim_time: simulated time of the trial [s].
        crossed_at_grasp: edges of a held cloth through another cloth's triangles or the
            other's through the held one's, summed over the pairs, as the fingers closed
            (`sim.mesh_crossing`: no real cloth passes through another).
        crossed_lifted: the same at the top of the lift.
        dragged: cloths not held whose median node rose more than DRAGGED above the table
            by the top of the lift (they hang from a held cloth).
    """

    pile: tuple[int, ...]
    held: tuple[int, ...]
    anchored: int
    lifted: float
    max_speed: float
    max_speed_phase: str
    max_stretch: float
    max_stretch_phase: str
    depth: float
    final_stretch: float
    fell: tuple[int, ...]
    sim_time: float
    crossed_at_grasp: int = 0
    crossed_lifted: int = 0
    dragged: tuple[int, ...] = ()

    @property
    def blew_up(self) -> bool:
        """A node was flung, went into the table, a cloth stayed torn, or one left the table."""
        return (
            self.max_speed > BLOW_UP_SPEED
            or self.depth > BLOW_UP_DEPTH
            or self.final_stretch > TANGLED_STRETCH
            or bool(self.fell)
        )

    def line(self) -> str:
        """One line for a report."""
        return (
            f"pile {list(self.pile)} held {list(self.held)} ({self.anchored} nodes, lifted "
            f"{self.lifted * 1000:.0f} mm): "
            f"max speed {self.max_speed:.1f} m/s ({self.max_speed_phase}), "
            f"stretch {self.max_stretch:.2f} ({self.max_stretch_phase}), final {self.final_stretch:.2f}, "
            f"depth {self.depth * 1000:+.0f} mm, fell {list(self.fell)}, "
            f"crossed {self.crossed_at_grasp} at grasp / {self.crossed_lifted} lifted, "
            f"dragged {list(self.dragged)}"
            f"{'  BLOW-UP' if self.blew_up else ''}"
        )


class _Monitor:
    """Steps the world and keeps the worst node speed, stretch and depth per phase."""

    def __init__(self, world: World, pile: Pile) -> None:
        self.world = world
        self.bodies = [c.body for c in pile.cloths]
        self.phase = "start"
        self.speed = (0.0, "")
        self.stretch = (0.0, "")
        self.depth = -np.inf
        self._previous = [b.nodes() for b in self.bodies]

    def step(self, n: int = 1) -> None:
        top = self.world.config.table.top_z
        for _ in range(n):
            self.world.step()
            current = [b.nodes() for b in self.bodies]
            for body, now, before in zip(self.bodies, current, self._previous, strict=True):
                speed = float(np.max(np.linalg.norm(now - before, axis=1))) / self.world.dt
                stretch = body.max_edge_stretch()
                if speed > self.speed[0]:
                    self.speed = (speed, self.phase)
                if stretch > self.stretch[0]:
                    self.stretch = (stretch, self.phase)
                self.depth = max(self.depth, top - float(np.min(now[:, 2])))
            self._previous = current

    def hold(self, seconds: float) -> None:
        self.step(max(1, round(seconds / self.world.dt)))

    def move(self, q_from: FloatArray, q_to: FloatArray, seconds: float) -> None:
        """Smooth (smoothstep) joint-space move, one command per step."""
        robot = self.world.robot
        steps = max(1, round(seconds / self.world.dt))
        for k in range(1, steps + 1):
            s = k / steps
            s = s * s * (3.0 - 2.0 * s)
            robot.command_joints(q_from + s * (q_to - q_from), np.zeros(len(q_from)))
            self.step()


def grasp_point_on_pile(pile: Pile) -> FloatArray:
    """(3,) the top cloth's node lying on another cloth nearest its middle [m] (any of its
    nodes nearest the middle if it lies on none)."""
    top = pile.cloths[-1].body.nodes()
    others = [c.body.nodes() for c in pile.cloths[:-1]]
    if others:
        below = np.concatenate(others)
        gaps = np.hypot(top[:, None, 0] - below[None, :, 0], top[:, None, 1] - below[None, :, 1]).min(axis=1)
        on_pile = np.flatnonzero(gaps < ON_PILE)
    else:
        on_pile = np.zeros(0, dtype=np.int64)
    candidates = on_pile if on_pile.size else np.arange(len(top))
    middle = top.mean(axis=0)
    nearest = candidates[np.argmin(np.linalg.norm(top[candidates] - middle, axis=1))]
    return np.asarray(top[nearest], dtype=float)


def pile_trial(
    world: World,
    pile: Pile,
    settings: PileTrialSettings | None = None,
    grasp_point: npt.ArrayLike | None = None,
) -> PileTrialResult:
    """Lifts from the pile at `grasp_point` (default `grasp_point_on_pile`), puts it back, measures.

    The arm starts at the world's observation joints; the pile should have settled.
    """
    s = settings or PileTrialSettings()
    start = world.time
    point = grasp_point_on_pile(pile) if grasp_point is None else np.asarray(grasp_point, dtype=float)
    robot = world.robot
    top_z = world.config.table.top_z
    monitor = _Monitor(world, pile)

    def solve(position: npt.ArrayLike, q_seed: FloatArray) -> FloatArray:
        return robot.solve_frame_ik("tcp", make_transform(TOOL_DOWN, position), q_seed)

    q_start = robot.q()
    q_above = solve([point[0], point[1], point[2] + 0.08], world.observation_joints)
    q_grasp = solve([point[0], point[1], point[2] + s.grasp_height], q_above)
    monitor.phase = "approach"
    monitor.move(q_start, q_above, s.approach_time)
    monitor.phase = "descend"
    monitor.move(q_above, q_grasp, s.descend_time)
    monitor.phase = "close"
    robot.set_gripper(0.0)
    monitor.hold(s.close_time)
    cell = SimCell(world, grasp_radius=s.grasp_radius)
    anchored = cell.grasp()
    held = tuple(c.number for c in pile.cloths if c.body.is_grasped)
    crossed_at_grasp = _crossed_with_held(pile)
    q_lifted = solve([point[0], point[1], top_z + s.lift_height], q_grasp)
    monitor.phase = "lift"
    monitor.move(q_grasp, q_lifted, s.lift_time)
    monitor.hold(s.hold_time)
    lifted = min(
        (float(np.median(c.body.nodes()[:, 2])) - top_z for c in pile.cloths if c.body.is_grasped),
        default=0.0,
    )
    crossed_lifted = _crossed_with_held(pile)
    dragged = tuple(
        c.number
        for c in pile.cloths
        if not c.body.is_grasped and float(np.median(c.body.nodes()[:, 2])) - top_z > DRAGGED
    )
    centre = np.asarray(world.config.range.centre_xy, dtype=float)
    outward = point[:2] - centre
    outward = outward / max(float(np.linalg.norm(outward)), 1e-9)
    monitor.phase = "put down"
    if s.lay_out > 0:
        touch = [point[0], point[1], top_z + max(s.put_down_height, s.lay_out)]
        q_touch = solve(touch, q_lifted)
        monitor.move(q_lifted, q_touch, s.put_down_time)
        down = [*(point[:2] + s.lay_out * outward), top_z + s.put_down_height]
        q_down = solve(down, q_touch)
        monitor.move(q_touch, q_down, s.put_down_time)
    else:
        down = [*(point[:2] + s.put_down_slide * outward), top_z + s.put_down_height]
        q_down = solve(down, q_lifted)
        monitor.move(q_lifted, q_down, s.put_down_time)
    monitor.phase = "release"
    cell.release()
    monitor.hold(s.release_wait)
    robot.set_gripper(0.08)
    monitor.hold(s.close_time)
    monitor.phase = "away"
    monitor.move(q_down, q_lifted, s.away_time)
    monitor.phase = "settle"
    monitor.hold(s.settle_time)
    return PileTrialResult(
        pile=tuple(c.number for c in pile.cloths),
        held=held,
        anchored=anchored,
        lifted=lifted,
        max_speed=monitor.speed[0],
        max_speed_phase=monitor.speed[1],
        max_stretch=monitor.stretch[0],
        max_stretch_phase=monitor.stretch[1],
        depth=float(monitor.depth),
        final_stretch=max(c.body.max_edge_stretch() for c in pile.cloths),
        fell=tuple(c.number for c in pile.cloths if _off_table(world, c.body.nodes())),
        sim_time=world.time - start,
        crossed_at_grasp=crossed_at_grasp,
        crossed_lifted=crossed_lifted,
        dragged=dragged,
    )


def _crossed_with_held(pile: Pile) -> int:
    """Crossed edges between each held cloth and each other cloth, summed (`crossed_edges`)."""
    meshes = [(c.body.nodes(), c.body.mesh, c.body.is_grasped) for c in pile.cloths]
    return sum(
        crossed_edges(na, ma.edges, ma.triangles, nb, mb.edges, mb.triangles)
        for (na, ma, held_a), (nb, mb, held_b) in combinations(meshes, 2)
        if held_a or held_b
    )


def _off_table(world: World, nodes: FloatArray) -> bool:
    table = world.config.table
    half = np.asarray(table.size_xy) / 2
    outside = np.any(np.abs(nodes[:, :2] - np.asarray(table.centre_xy)) > half, axis=1)
    below = nodes[:, 2] < table.top_z - BLOW_UP_DEPTH
    return bool(np.any(outside | below))


__all__ = [
    "BLOW_UP_DEPTH",
    "BLOW_UP_SPEED",
    "TANGLED_STRETCH",
    "LiftResult",
    "PileTrialResult",
    "PileTrialSettings",
    "RecognitionCheck",
    "grasp_point_on_pile",
    "lift_check",
    "pile_trial",
    "recognition_check",
]
