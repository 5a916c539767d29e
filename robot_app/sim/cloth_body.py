"""A catalogue cloth as a pybullet mass-spring soft body, with its ground-truth pose.

Ground truth of Σ_M is the Kabsch fit of the rest-mesh nodes (in Σ_M) to the current
nodes (in Σ_W). A cloth lying face up has Σ_M's z pointing down into the table, so a
camera looking straight down with its image axes along the texture's sees ^CR R_M = I.

A fabric cloth is drawn with a finer two-sided render mesh skinned to the physics mesh
(`cloth_visual`); its texture is then an atlas of front and back.

Every node of every cloth weighs NODE_MASS; a cloth's simulated mass is its node count
times NODE_MASS, not the catalogue's `mass`. pybullet keeps one mass-spring force per
world, with the constants of the first soft body loaded, so springs scaled per cloth held
for the first cloth only (a light cloth loaded after a heavy one got springs 2.5x too
stiff for its nodes). With one node mass, one set of constants suits every cloth in any
order, and a cloth alone moves as it did with scaled springs: only the ratios of the
spring constants to the node mass matter.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt
import pybullet as pb
from scipy.spatial import cKDTree

from robot_app.arrays import FloatArray
from robot_app.errors import GraspError, SimulationError
from robot_app.geometry import (
    kabsch,
    quaternion_xyzw_from_matrix,
    transform_points,
)
from robot_app.sim.cloth_mesh import ClothMesh, mesh_obj_path
from robot_app.sim.cloth_visual import Fold
from robot_app.sim.cloths import ClothSpec, texture_path
from robot_app.sim.config import ClothPhysicsSettings

if TYPE_CHECKING:
    from robot_app.sim.robot import SimRobot


NODE_MASS = 0.0005  # [kg] of each node of every cloth; the config's spring constants are for it


class ClothBody:
    """One soft-body cloth in a pybullet client (owned by a `World` or `ModelStation`).

    Args:
        client: pybullet client id (the world must have been reset with
            RESET_USE_DEFORMABLE_WORLD).
        mesh: the cloth's rest mesh in Σ_M.
        transform_model_to_world: 4x4 initial pose of Σ_M [m].
        physics: spring constants, friction and collision margin.
        cache: folder for the .obj mesh and the texture PNG.
        render_obj: a render mesh (`cloth_visual.RenderMesh`) skinned to the physics
            mesh; None draws the physics mesh with the flat texture.
        fabric: with a render mesh, texture it with the fabric atlas (else the flat
            texture on both sides).
    """

    def __init__(
        self,
        client: int,
        mesh: ClothMesh,
        transform_model_to_world: npt.ArrayLike,
        physics: ClothPhysicsSettings,
        cache: str | Path,
        render_obj: str | Path | None = None,
        fabric: bool = False,
    ) -> None:
        T = np.asarray(transform_model_to_world, dtype=float)
        self._client = client
        self.mesh = mesh
        self._margin = physics.collision_margin
        self._drawn = render_obj is not None
        obj = mesh_obj_path(mesh, cache)
        files = (
            {"fileName": str(obj)}
            if render_obj is None
            else {"fileName": str(render_obj), "simFileName": str(obj)}
        )
        self.body_id = pb.loadSoftBody(
            **files,
            basePosition=T[:3, 3].tolist(),
            baseOrientation=quaternion_xyzw_from_matrix(T[:3, :3]).tolist(),
            mass=len(mesh.vertices) * NODE_MASS,
            useNeoHookean=0,
            useMassSpring=1,
            useBendingSprings=1,
            springElasticStiffness=physics.elastic_stiffness,
            springDampingStiffness=physics.damping_stiffness,
            springBendingStiffness=physics.bending_stiffness,
            useSelfCollision=0,
            frictionCoeff=physics.friction,
            useFaceContact=0,
            collisionMargin=physics.collision_margin,
            physicsClientId=client,
        )
        if self.body_id < 0:
            raise SimulationError(f"pybullet could not load the soft body {obj}")
        self._order = self._node_order(transform_points(T, mesh.vertices))
        self._simulation_mesh: tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]] | None = None
        kind = "flat" if render_obj is None else ("fabric" if fabric else "flat_atlas")
        texture = pb.loadTexture(str(texture_path(mesh.spec, cache, kind)), physicsClientId=client)
        pb.changeVisualShape(
            self.body_id,
            -1,
            textureUniqueId=texture,
            rgbaColor=[1, 1, 1, 1],
            flags=pb.VISUAL_SHAPE_DOUBLE_SIDED,
            physicsClientId=client,
        )
        self._anchors: list[int] = []
        self._held = np.zeros(len(mesh.vertices), dtype=bool)  # anchored, in pybullet's node order

    @property
    def spec(self) -> ClothSpec:
        return self.mesh.spec

    def nodes(self) -> FloatArray:
        """(N, 3) current node positions in Σ_W [m], in the rest mesh's vertex order."""
        nodes = self._simulation_nodes()[self._order]
        nodes.setflags(write=False)
        return nodes

    def pose(self) -> FloatArray:
        """4x4 ground-truth pose of Σ_M in Σ_W: Kabsch fit of the rest nodes to the nodes."""
        return kabsch(self.mesh.vertices, self.nodes())

    def drawn_nodes(self) -> FloatArray:
        """(N, 3) nodes lifted to the drawn cloth around them [m] (= nodes without a render
        mesh): each moves along the cloth's normal by the mean height, above it, of the
        render vertices nearest to it."""
        nodes = self.nodes()
        if not self._drawn:
            return nodes
        _, positions = pb.getMeshData(self.body_id, -1, physicsClientId=self._client)
        drawn = np.asarray(positions, dtype=float)
        nearest = np.asarray(cKDTree(nodes).query(drawn)[1], dtype=np.int64)
        offset = np.zeros_like(nodes)
        np.add.at(offset, nearest, drawn - nodes[nearest])
        count = np.bincount(nearest, minlength=len(nodes))[:, None]
        normal = self.pose()[:3, 2]
        lift = (offset / np.maximum(count, 1)) @ normal
        return nodes + lift[:, None] * normal

    def max_edge_stretch(self) -> float:
        """Largest ratio of a mesh edge's current length to its rest length."""
        nodes = self.nodes()
        edges = self.mesh.edges
        lengths = np.linalg.norm(nodes[edges[:, 0]] - nodes[edges[:, 1]], axis=1)
        return float(np.max(lengths / self.mesh.rest_edge_lengths))

    def outline_world(self) -> FloatArray:
        """(K, 3) outline polygon placed with the current ground-truth pose [m]."""
        outline = np.column_stack([self.mesh.outline, np.zeros(len(self.mesh.outline))])
        return transform_points(self.pose(), outline)

    @property
    def is_grasped(self) -> bool:
        return bool(self._anchors)

    def grasp(
        self, robot: SimRobot, radius: float = 0.02, link: str = "gripper_palm", at: str = "tcp"
    ) -> int:
        """Anchors the nodes within `radius` [m] of frame `at` to the robot's `link`.

        A cloth drawn with a render mesh is held where it is drawn: its wrinkles stand up
        to about a centimetre above the physics nodes (which cannot hold them), and fingers
        closing on a drawn ridge hold the nodes under it. So each node is taken at the height
        of the drawn cloth around it (`drawn_nodes`).

        Returns:
            The number of anchored nodes.

        Raises:
            GraspError: no node is within reach, or the cloth is already grasped.
        """
        if self._anchors:
            raise GraspError(f"cloth No.{self.spec.number} is already grasped; release() it first")
        if radius <= 0:
            raise GraspError(f"grasp radius must be positive [m], got {radius}")
        centre = robot.frame_pose(at)[:3, 3]
        link_index = robot.link_index(link)
        nodes = self.drawn_nodes() if self._drawn else self.nodes()
        distances = np.linalg.norm(nodes - centre, axis=1)
        chosen = np.flatnonzero(distances <= radius)
        if chosen.size == 0:
            raise GraspError(
                f"no node of cloth No.{self.spec.number} within {radius * 1000:.0f} mm of '{at}' "
                f"(nearest {distances.min() * 1000:.0f} mm)"
            )
        for k in chosen:
            node = int(self._order[k])
            anchor = pb.createSoftBodyAnchor(
                self.body_id, node, robot.body_id, link_index, physicsClientId=self._client
            )
            self._anchors.append(anchor)
            self._held[node] = True
        return int(chosen.size)

    def release(self) -> int:
        """Removes all grasp anchors; returns how many were removed."""
        count = len(self._anchors)
        for anchor in self._anchors:
            pb.removeConstraint(anchor, physicsClientId=self._client)
        self._anchors.clear()
        self._held[:] = False
        return count

    def ignore_collisions_with(self, body: int, links: tuple[int, ...]) -> None:
        """The cloth passes through these links of a rigid or multi-body (-1 = its base)."""
        for link in links:
            pb.setCollisionFilterPair(body, self.body_id, link, -1, 0, physicsClientId=self._client)

    def set_nodes(self, nodes: npt.ArrayLike) -> None:
        """Puts the nodes at `nodes` ((N, 3) in Σ_W [m], the rest mesh's vertex order, as
        `nodes()` returns them), e.g. a traced cloth reloaded (scripts/heap_replay.py)."""
        placed = np.asarray(nodes, dtype=float)
        if placed.shape != (len(self._order), 3):
            raise ValueError(f"nodes must be ({len(self._order)}, 3), got {placed.shape}")
        ordered = np.empty_like(placed)
        ordered[self._order] = placed
        self._write_nodes(ordered)

    def fold(self, fold: Fold, lift: float | None = None) -> int:
        """Folds the nodes beyond the fold line over onto the cloth, `lift` [m] above it.

        The cloth should be flat; the flap's nodes are mirrored about the fold line in
        the cloth's plane and lifted off it (default: twice the collision margin).
        Returns how many nodes were moved.
        """
        rest = self.mesh.vertices
        flap = fold.along(rest) > fold.line(rest)
        if not np.any(flap):
            return 0
        pose = self.pose()
        direction = pose[:3, :2] @ np.array([np.cos(fold.angle), np.sin(fold.angle)])
        nodes = self.nodes().copy()
        along = (nodes - pose[:3, 3]) @ direction
        nodes[flap] -= np.outer(2.0 * (along[flap] - fold.line(rest)), direction)
        up = -pose[:3, 2]  # Σ_M z points into the table on a face-up cloth
        nodes[flap] += (2.0 * self._margin if lift is None else lift) * up
        ordered = np.empty_like(nodes)
        ordered[self._order] = nodes
        self._write_nodes(ordered)
        return int(np.count_nonzero(flap))

    def translate(self, dx: float, dy: float) -> None:
        """Shifts the whole cloth by (dx, dy) [m] on the table, as a push would (tests)."""
        position, orientation = pb.getBasePositionAndOrientation(self.body_id, physicsClientId=self._client)
        moved = [position[0] + dx, position[1] + dy, position[2]]
        pb.resetBasePositionAndOrientation(self.body_id, moved, orientation, physicsClientId=self._client)

    def pin(self, node_indices: npt.ArrayLike) -> None:
        """Anchors the given rest-mesh nodes to their current place in the world (tests)."""
        for k in np.asarray(node_indices, dtype=int).reshape(-1):
            anchor = pb.createSoftBodyAnchor(
                self.body_id, int(self._order[k]), -1, -1, physicsClientId=self._client
            )
            self._anchors.append(anchor)
            self._held[int(self._order[k])] = True

    def move_free_nodes(
        self, displacement: npt.ArrayLike, where: Callable[[FloatArray], npt.NDArray[np.bool_]]
    ) -> int:
        """Moves the nodes that are not anchored and for which `where(nodes)` holds (a belt).

        Only positions change: a node's velocity is what the physics gave it, so a cloth at
        rest on a moving belt rides along without slipping (sim/conveyor.py).

        Args:
            displacement: (3,) shift [m] in Σ_W.
            where: (N, 3) node positions -> (N,) mask of the nodes to move.

        Returns:
            The number of nodes moved.
        """
        shift = np.asarray(displacement, dtype=float).reshape(3)
        nodes = self._simulation_nodes()
        moving = np.asarray(where(nodes), dtype=bool) & ~self._held
        count = int(np.count_nonzero(moving))
        if count:
            nodes[moving] += shift
            self._write_nodes(nodes)
        return count

    def set_mean_velocity(self, velocity: npt.ArrayLike) -> None:
        """Sets the mean of the nodes' velocities to `velocity` ((3,) in Σ_W [m/s]), each node
        keeping its velocity relative to that mean: pybullet's `resetBaseVelocity` of a soft
        body given a linear velocity alone (bullet's `btSoftBody::setLinearVelocity` adds the
        difference to the mass-weighted mean to every node; the nodes weigh the same). Positions
        stay. No angular velocity is passed: that would give every node the same velocity."""
        v = np.asarray(velocity, dtype=float).reshape(3)
        pb.resetBaseVelocity(self.body_id, linearVelocity=v.tolist(), physicsClientId=self._client)

    def lift_free_nodes(
        self, below: float, to: float, where: Callable[[FloatArray], npt.NDArray[np.bool_]]
    ) -> int:
        """Puts the free nodes lower than `below` [m] for which `where(nodes)` holds at height
        `to` [m] (Σ_W z): a solid surface that pybullet's soft contact let them into
        (`World.step`'s solid table). Only positions change, as in `move_free_nodes`.

        Returns:
            The number of nodes moved.
        """
        nodes = self._simulation_nodes()
        sunk = nodes[:, 2] < below
        if not np.any(sunk):
            return 0
        sunk &= np.asarray(where(nodes), dtype=bool) & ~self._held
        count = int(np.count_nonzero(sunk))
        if count:
            nodes[sunk, 2] = to
            self._write_nodes(nodes)
        return count

    def simulation_nodes(self) -> FloatArray:
        """(N, 3) node positions in Σ_W [m], in pybullet's node order (a copy): for the
        per-step corrections of `robot_app.sim` (`cloth_layers`), with `set_free_heights`."""
        return self._simulation_nodes()

    def simulation_mesh(self) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]:
        """The mesh's edges (E, 2) and triangles (T, 3) as indices into `simulation_nodes`
        (pybullet's node order), for `sim.mesh_crossing` in the per-step corrections."""
        if self._simulation_mesh is None:
            self._simulation_mesh = (self._order[self.mesh.edges], self._order[self.mesh.triangles])
        return self._simulation_mesh

    def set_free_heights(self, heights: npt.ArrayLike) -> int:
        """Sets the heights (Σ_W z [m], pybullet's node order) of the nodes that are not
        anchored; returns how many changed. Only positions change, as in `move_free_nodes`."""
        z = np.asarray(heights, dtype=float).reshape(-1)
        nodes = self._simulation_nodes()
        if z.shape != (len(nodes),):
            raise ValueError(f"heights must be ({len(nodes)},), got {z.shape}")
        change = (z != nodes[:, 2]) & ~self._held
        count = int(np.count_nonzero(change))
        if count:
            nodes[change, 2] = z[change]
            self._write_nodes(nodes)
        return count

    def remove(self) -> None:
        """Deletes the soft body from its client."""
        self.release()
        pb.removeBody(self.body_id, physicsClientId=self._client)

    def _simulation_nodes(self) -> FloatArray:
        """(N, 3) node positions in Σ_W [m], in pybullet's node order."""
        _, positions = pb.getMeshData(
            self.body_id, -1, flags=pb.MESH_DATA_SIMULATION_MESH, physicsClientId=self._client
        )
        return np.asarray(positions, dtype=float)

    def _write_nodes(self, nodes: FloatArray) -> None:
        """Puts the nodes at `nodes` ((N, 3) in Σ_W [m], pybullet's node order)."""
        pb.resetMeshData(self.body_id, vertices=nodes.tolist(), physicsClientId=self._client)

    def _node_order(self, expected: FloatArray) -> npt.NDArray[np.int64]:
        loaded = self._simulation_nodes()
        if len(loaded) != len(expected):
            raise SimulationError(
                f"soft body has {len(loaded)} nodes but the mesh has {len(expected)} vertices"
            )
        distance, order = cKDTree(loaded).query(expected)
        if np.max(distance) > 1e-4 or len(np.unique(order)) != len(order):
            raise SimulationError("soft body nodes do not match the mesh vertices after loading")
        return np.asarray(order, dtype=np.int64)


__all__ = ["ClothBody"]
