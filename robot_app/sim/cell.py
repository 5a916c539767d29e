"""The simulated cell as the pick-and-place loop sees it (`robot_app.control.Cell`).

The loop never calls pybullet: it drives the arm, reads the cameras and works the
gripper through this adapter. Grasping anchors the cloth nodes near the closed
fingers (any cloth: picking the wrong one is possible and counted as a failure);
`holding` reports whether a grasped cloth hangs off the table, as a gripper's
sensing would.
"""

from __future__ import annotations

import itertools

import numpy as np
import numpy.typing as npt
from scipy.spatial import cKDTree

from robot_app.arrays import FloatArray
from robot_app.errors import GraspError
from robot_app.sim.cameras import StereoFrame
from robot_app.sim.cloth_body import NODE_MASS, ClothBody
from robot_app.sim.world import World

HOLD_HEIGHT = 0.05  # a held cloth's median node is at least this far above the table [m]
REST_CONTACT = (
    0.025  # a node rests on what lies at most this far under it [m] (layers of a pile ~16 mm apart)
)
# ... and at most this far aside [m]: the nearest node of a 35 mm lattice lies within 25 mm (at
# 15 mm, layers kept apart (`world.cloth.keep_layers`) over 25 mm up rested on nothing: weighed)
REST_UNDER = 0.025


class SimCell:
    """Adapter of a `World` to the loop's `Cell` protocol.

    Args:
        world: the pybullet cell.
        grasp_radius: nodes within this distance of the TCP are anchored [m].
    """

    def __init__(self, world: World, grasp_radius: float = 0.02) -> None:
        if grasp_radius <= 0:
            raise GraspError(f"grasp_radius must be positive [m], got {grasp_radius}")
        self.world = world
        self.dt = world.dt
        self.grasp_radius = grasp_radius
        self.last_capture: StereoFrame | None = None

    @property
    def time(self) -> float:
        return self.world.time

    def step(self) -> None:
        self.world.step(1)

    def joint_positions(self) -> FloatArray:
        return self.world.robot.q()

    def command_joints(self, q: npt.ArrayLike, dq: npt.ArrayLike) -> None:
        self.world.robot.command_joints(q, dq)

    def capture(self) -> StereoFrame:
        self.last_capture = self.world.stereo.render()
        return self.last_capture

    def set_gripper(self, opening: float) -> None:
        self.world.robot.set_gripper(opening)

    def grasp(self) -> int:
        held = 0
        for cloth in self.world.cloths:
            if cloth.is_grasped:
                continue
            try:
                held += cloth.grasp(self.world.robot, radius=self.grasp_radius)
            except GraspError:
                continue
        return held

    def release(self) -> None:
        for cloth in self.world.cloths:
            cloth.release()

    def held_cloths(self) -> list[ClothBody]:
        return [cloth for cloth in self.world.cloths if cloth.is_grasped]

    def holding(self) -> bool:
        table = self.world.config.table.top_z
        return any(float(np.median(c.nodes()[:, 2])) > table + HOLD_HEIGHT for c in self.held_cloths())

    def held_mass(self, reach: float = 0.3) -> float:
        """What a load cell in the wrist would weigh [kg]: the cloth nodes within `reach` [m]
        (horizontally) of the TCP, more than HOLD_HEIGHT above the table, that nothing
        holds up but the gripper (`hanging_nodes`): a grasped cloth's part still lying on
        the pile, or a cloth lying on the pile under the tool, weighs nothing; a cloth that
        came along, anchored or lying on the one lifted, weighs (the simulated cloth's
        mass is its node count times NODE_MASS)."""
        tcp = self.world.robot.frame_pose("tcp")[:3, 3]
        table = self.world.config.table.top_z
        cloths = self.world.cloths
        nodes = [c.nodes() for c in cloths]
        hanging = hanging_nodes(nodes, [c.is_grasped for c in cloths], table)
        count = 0
        for points, free in zip(nodes, hanging, strict=True):
            near = np.hypot(points[:, 0] - tcp[0], points[:, 1] - tcp[1]) <= reach
            count += int(np.count_nonzero(near & free & (points[:, 2] > table + HOLD_HEIGHT)))
        return count * NODE_MASS

    def collisions(self) -> int:
        contacts = self.world.robot.arm_collisions(self.world.static_obstacles)
        return 1 if contacts else 0


def hanging_nodes(
    nodes: list[FloatArray], grasped: list[bool], table_z: float, contact: float = REST_CONTACT,
    under: float = REST_UNDER,
) -> list[npt.NDArray[np.bool_]]:  # fmt: skip
    """Per cloth, which of its nodes ((N, 3) [m] each) hang rather than rest: a node rests
    when it lies within `contact` [m] above the table top `table_z`, or within `contact`
    above a resting node of a cloth the gripper does not hold, at most `under` [m] aside
    (any cloth may rest so, on itself too: a fold). A held cloth's nodes rest on what lies
    under them but hold nothing up: what lies on a hanging cloth hangs with it."""
    if not nodes:
        return []
    points = np.concatenate(nodes)
    owner = np.concatenate([np.full(len(n), i) for i, n in enumerate(nodes)])
    held = np.asarray(grasped, dtype=bool)[owner]
    rest = points[:, 2] <= table_z + contact
    while True:  # each pass rests the nodes on those found resting so far: a pile, layer by layer
        support = np.nonzero(rest & ~held)[0]
        open_ = np.nonzero(~rest)[0]
        if not len(support) or not len(open_):
            break
        tree = cKDTree(points[support, :2])
        found = []
        for i, near in zip(open_, tree.query_ball_point(points[open_, :2], under), strict=True):
            if near:
                dz = points[i, 2] - points[support[near], 2]
                if np.any((dz >= 0.0) & (dz <= contact)):
                    found.append(i)
        if not found:
            break
        rest[found] = True
    hanging = ~rest
    bounds = np.cumsum([0, *(len(n) for n in nodes)])
    return [hanging[a:b] for a, b in itertools.pairwise(bounds)]


__all__ = ["SimCell", "hanging_nodes"]
