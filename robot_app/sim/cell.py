"""The simulated cell as the pick-and-place loop sees it (`robot_app.control.Cell`).

The loop never calls pybullet: it drives the arm, reads the cameras and works the
gripper through this adapter. Grasping anchors the cloth nodes near the closed
fingers (any cloth: picking the wrong one is possible and counted as a failure);
`holding` reports whether a grasped cloth hangs off the table, as a gripper's
sensing would.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray
from robot_app.errors import GraspError
from robot_app.sim.cameras import StereoFrame
from robot_app.sim.cloth_body import NODE_MASS, ClothBody
from robot_app.sim.world import World

HOLD_HEIGHT = 0.05  # a held cloth's median node is at least this far above the table [m]


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
        """What a load cell in the wrist would weigh [kg]: every cloth node off the table by
        more than HOLD_HEIGHT within `reach` [m] (horizontally) of the TCP, anchored or
        lying on what is (the simulated cloth's mass is its node count times NODE_MASS)."""
        tcp = self.world.robot.frame_pose("tcp")[:3, 3]
        table = self.world.config.table.top_z
        count = 0
        for cloth in self.world.cloths:
            nodes = cloth.nodes()
            near = np.hypot(nodes[:, 0] - tcp[0], nodes[:, 1] - tcp[1]) <= reach
            count += int(np.count_nonzero(near & (nodes[:, 2] > table + HOLD_HEIGHT)))
        return count * NODE_MASS

    def collisions(self) -> int:
        contacts = self.world.robot.arm_collisions(self.world.static_obstacles)
        return 1 if contacts else 0


__all__ = ["SimCell"]
