"""Mishaps made to happen in the simulated cell, and what really happened at each pick.

The simulator's grasp holds a cloth by anchors that never slip, and stacked cloths lie
about 16 mm apart, so on their own cloths are seldom dropped or lifted two at a time.
`FaultSettings` makes it happen at chosen picks, to test the job's checks: a cloth falls
out of the gripper during the transfer (`drop_transfers`), or the nearest other cloth is
caught by the fingers too (`double_grasps`: its nodes near the fingers are anchored, as
if pinched or entangled). `PickWitness` notes, from the simulator's ground truth, which
cloths each lift really took and which transfer really lost its cloth: the judge compares
that with what the robot noticed. It also watches the simulator itself: a cloth node
faster than `BLOW_UP_SPEED` above the table was flung by pybullet's soft-body contact (a blow-up, see
`scripts/pile_physics.py`), not moved by the robot (`PickWitness.flung`), so that a cloth
that ends on the floor after one is reported as such. Neither tells the robot anything.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from pydantic import Field

from robot_app.arrays import FloatArray
from robot_app.config import StrictModel
from robot_app.control.episode import PhaseRecord
from robot_app.sim import ClothBody, SimCell, World, build_cloth_mesh, cloth_spec
from robot_app.sim.cell import HOLD_HEIGHT
from robot_app.sim.checks import BLOW_UP_DEPTH, BLOW_UP_SPEED
from robot_app.sim.cloth_body import NODE_MASS
from robot_app.sim.mesh_crossing import crossed_edges
from robot_app.sim.pile import Pile

CATCH_REACH = 0.12  # the other cloth must come this close to the fingers to be caught [m]
WATCH_EVERY = 5  # control steps between two looks at every cloth's node speeds
LIFT_RISE = 0.02  # a lifted cloth's nodes above HOLD_HEIGHT by the TCP rose this much since the grasp [m]


class ScaleSettings(StrictModel):
    """The wrist's load cell (and the scale the cloths were weighed on at the model station).

    Attributes:
        relative_noise: standard deviation of the reading's error, as a share of it [-].
        noise: standard deviation of the reading's offset error [kg].
    """

    relative_noise: float = Field(0.03, ge=0.0, le=0.5)
    noise: float = Field(0.001, ge=0.0, le=0.05)


class WristScale:
    """The load cell between the flange and the gripper, in the simulated cell.

    It weighs what hangs from the gripper (`SimCell.held_mass`) with a gain and an offset
    error drawn per reading; `weigh_model` is the same cloth weighed flat at the model
    station (its whole simulated mass, with the station scale's error).

    Args:
        cell: the simulated cell; settings: its noise; seed: of the errors.
    """

    def __init__(self, cell: SimCell, settings: ScaleSettings, seed: int) -> None:
        self.cell, self.settings = cell, settings
        self.rng = np.random.default_rng((seed, 31))

    def read(self) -> float:
        """The gripper's load now [kg]."""
        return self._noisy(self.cell.held_mass())

    def weigh_model(self, number: int) -> float:
        """Cloth No.`number` weighed at the model station [kg]."""
        spec = cloth_spec(number)
        mesh = build_cloth_mesh(
            spec, self.cell.world.config.cloth.node_spacing, self.cell.world.config.cloth.boundary_spacing
        )
        return self._noisy(len(mesh.vertices) * NODE_MASS)

    def _noisy(self, mass: float) -> float:
        s = self.settings
        return float(
            mass * (1.0 + s.relative_noise * self.rng.standard_normal())
            + s.noise * self.rng.standard_normal()
        )


class FaultSettings(StrictModel):
    """Mishaps at chosen picks (counted from 1 over the whole job).

    Attributes:
        drop_transfers: the cloth falls out of the gripper during these transfers.
        drop_after: ... this long after the transfer started [s].
        double_grasps: at these grasps the nearest other cloth on the table is caught too.
    """

    drop_transfers: tuple[int, ...] = ()
    drop_after: float = Field(0.3, ge=0.0, le=5.0)
    double_grasps: tuple[int, ...] = ()


@dataclass
class LiftTruth:
    """What one lift really took, and whether its transfer really lost it.

    Attributes:
        grasp: the grasp's number (1 = the job's first).
        time: cell time when the fingers had closed [s].
        meant: the cloth the robot meant (model name).
        lifted: catalogue numbers of the cloths that left the table with the gripper
            (anchored or dragged along), after the lift.
        held: ... of those anchored to the gripper (the fingers took them; the others of
            `lifted` came along lying on or caught in what is held).
        injected_double: a second cloth was caught on purpose.
        dropped: the cloth fell during the transfer (injected).
        crossed: after the lift, the edges crossed (`sim.mesh_crossing`) between the held
            cloths and those of `lifted` not held; crossed_before: between the same cloths
            when the fingers closed. No real cloth goes through another: a dragged cloth
            crossed with the held one hangs from it in the simulator only.
    """

    grasp: int
    time: float
    meant: str
    lifted: tuple[int, ...] = ()
    held: tuple[int, ...] = ()
    injected_double: bool = False
    dropped: bool = False
    crossed: int = 0
    crossed_before: int = 0


def _rise(nodes: np.ndarray, before: np.ndarray, which: np.ndarray) -> float:
    """The mean height gained by the nodes `which` from `before` to `nodes` [m]."""
    return float(np.mean(nodes[which, 2] - before[which, 2]))


@dataclass(frozen=True)
class Flung:
    """A cloth the simulator flung: one of its nodes moved faster than `BLOW_UP_SPEED`.

    Attributes:
        time: cell time of the first look that saw it [s]; phase: the job's phase then.
        speed: the node's speed, averaged since the look before [m/s].
    """

    time: float
    phase: str
    speed: float


@dataclass
class PickWitness:
    """Follows the job's phases in the simulated cell: makes the faults, notes the truth.

    Args:
        world: the cell; pile: its cloths; faults: what to make happen (None: nothing).
    """

    world: World
    pile: Pile
    faults: FaultSettings | None = None
    lifts: list[LiftTruth] = field(default_factory=list)
    flung: dict[int, Flung] = field(default_factory=dict)  # catalogue number -> the first fling seen
    _steps: int = 0
    _last_look: tuple[float, list[np.ndarray]] | None = None
    _grasps: int = 0
    _transfers: int = 0
    _transfer_start: float | None = None
    _dropped_this_transfer: bool = False
    _nodes_at_grasp: dict[int, FloatArray] = field(default_factory=dict)  # number -> nodes [m]

    def on_phase(self, record: PhaseRecord, meant: str) -> None:
        """After each loop phase (the job's `on_phase`)."""
        if record.phase == "grasp":
            self._grasps += 1
            self.lifts.append(LiftTruth(self._grasps, self.world.time, meant))
            self._nodes_at_grasp = {c.number: c.body.nodes().copy() for c in self.pile.cloths}
            if self.faults is not None and self._grasps in self.faults.double_grasps:
                self.lifts[-1].injected_double = self._catch_another()
        elif record.phase == "lift" and self.lifts:
            lift = self.lifts[-1]
            lift.lifted = self._hanging()
            lift.held = tuple(c.number for c in self.pile.cloths if c.body.is_grasped)
            pairs = [(h, o) for h in lift.held for o in lift.lifted if o not in lift.held]
            now = {c.number: c.body.nodes() for c in self.pile.cloths}
            lift.crossed = sum(self._crossed(pair, now) for pair in pairs)
            lift.crossed_before = sum(self._crossed(pair, self._nodes_at_grasp) for pair in pairs)

    def _crossed(self, pair: tuple[int, int], nodes: dict[int, FloatArray]) -> int:
        """Crossed edges (`mesh_crossing.crossed_edges`) between two cloths (catalogue
        numbers) at `nodes` (number -> (N, 3) [m]; 0 where one is missing)."""
        meshes = {c.number: c.body.mesh for c in self.pile.cloths}
        (a, b) = pair
        if a not in nodes or b not in nodes:
            return 0
        ma, mb = meshes[a], meshes[b]
        return crossed_edges(nodes[a], ma.edges, ma.triangles, nodes[b], mb.edges, mb.triangles)

    def on_step(self, phase: str, _meant: str | None) -> None:
        """After each control step (the job's `on_step`)."""
        self._steps += 1
        if self._steps % WATCH_EVERY == 0:
            self._watch_speeds(phase)
        if phase != "transfer":
            self._transfer_start = None
            return
        if self._transfer_start is None:
            self._transfer_start = self.world.time
            self._transfers += 1
            self._dropped_this_transfer = False
        if (
            self.faults is not None
            and self._transfers in self.faults.drop_transfers
            and not self._dropped_this_transfer
            and self.world.time - self._transfer_start >= self.faults.drop_after
        ):
            self._dropped_this_transfer = True
            if any(c.body.is_grasped for c in self.pile.cloths) and self.lifts:
                self.lifts[-1].dropped = True
            for cloth in self.pile.cloths:
                cloth.body.release()

    def _watch_speeds(self, phase: str) -> None:
        """Notes every cloth a node of which moved faster than BLOW_UP_SPEED since the last
        look while above the table top (at both looks): one carried by the arm moves at
        ~2 m/s; a cloth sliding off the table whips its edge past 5 m/s as it falls to the
        floor, below the top, which is a fall, not a blow-up."""
        now = self.world.time
        nodes = [c.body.nodes() for c in self.pile.cloths]
        floor = self.world.config.table.top_z - BLOW_UP_DEPTH
        if self._last_look is not None and now > self._last_look[0]:
            dt = now - self._last_look[0]
            for cloth, before, after in zip(self.pile.cloths, self._last_look[1], nodes, strict=True):
                if cloth.number in self.flung or before.shape != after.shape:
                    continue
                above = (before[:, 2] > floor) & (after[:, 2] > floor)
                if not np.any(above):
                    continue
                speed = float(np.max(np.linalg.norm(after[above] - before[above], axis=1))) / dt
                if speed > BLOW_UP_SPEED:
                    self.flung[cloth.number] = Flung(now, phase, speed)
        self._last_look = (now, nodes)

    def _hanging(self) -> tuple[int, ...]:
        """Cloths that left the table with the gripper: held, or dragged along (a third of
        their nodes above HOLD_HEIGHT within reach of the TCP, and those nodes risen by
        `LIFT_RISE` on average since the fingers closed). Not a cloth that lay that high
        already: held-out 1350 (session 42): blind grasps by the colours box's wall that
        closed on nothing counted the cloths heaped in the box beside them as lifted."""
        table = self.world.config.table.top_z
        tcp = self.world.robot.frame_pose("tcp")[:3, 3]
        lifted = []
        for c in self.pile.cloths:
            nodes = c.body.nodes()
            near = np.hypot(nodes[:, 0] - tcp[0], nodes[:, 1] - tcp[1]) <= 0.3
            up = near & (nodes[:, 2] > table + HOLD_HEIGHT)
            if np.mean(up) <= 1 / 3:
                continue
            before = self._nodes_at_grasp.get(c.number)
            if before is None or before.shape != nodes.shape or _rise(nodes, before, up) >= LIFT_RISE:
                lifted.append(c.number)
        return tuple(lifted)

    def _catch_another(self) -> bool:
        """Anchors the nodes of the nearest cloth not held within reach of the fingers."""
        free = [
            cloth.body
            for cloth in self.pile.cloths
            if not cloth.body.is_grasped
            and not any(box.contains(cloth.body.nodes()).mean() > 0.5 for box in self.world.boxes)
        ]
        return catch_nearest(self.world, free, CATCH_REACH)


def catch_nearest(world: World, bodies: Sequence[ClothBody], reach: float = np.inf) -> bool:
    """Anchors the nodes of the one of `bodies` nearest the fingers, if it comes within
    `reach` [m] of them, out to its distance plus 2 cm (as if pinched or entangled): the
    injected double pick (`PickWitness`), and `release_trial`'s pairs. Whether one was."""
    tcp = world.robot.frame_pose("tcp")[:3, 3]
    gaps = [float(np.min(np.linalg.norm(body.nodes() - tcp, axis=1))) for body in bodies]
    if not gaps or min(gaps) > reach:
        return False
    k = int(np.argmin(gaps))
    bodies[k].grasp(world.robot, radius=gaps[k] + 0.02)
    return True


__all__ = [
    "FaultSettings",
    "Flung",
    "LiftTruth",
    "PickWitness",
    "ScaleSettings",
    "WristScale",
    "catch_nearest",
]
