"""The simulated cell: floor, table, green sheet, PA10, collection box, occluder, cloths.

One `World` owns one pybullet client (DIRECT unless `gui=True`), reset as a deformable
world so cloths are soft bodies. Visual surfaces of the table and the green sheet sit a
few millimetres below the table's collision face, so a cloth resting on the table is
always drawn above them.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from types import TracebackType

import numpy as np
import numpy.typing as npt
import pybullet as pb
from scipy.spatial import cKDTree

from robot_app.arrays import FloatArray
from robot_app.errors import SimulationError
from robot_app.geometry import (
    make_transform,
    quaternion_xyzw_from_matrix,
    rotation_about_z,
)
from robot_app.sim.cameras import RIGHT_FRAME, Lighting
from robot_app.sim.cloth_body import ClothBody
from robot_app.sim.cloth_layers import CHECK_EVERY, LayerKeeper
from robot_app.sim.cloth_mesh import build_cloth_mesh, cache_dir
from robot_app.sim.cloth_visual import ClothLook, build_render_mesh, render_obj_path
from robot_app.sim.cloths import ClothSpec
from robot_app.sim.config import BoxSettings, WorldConfig, load_world_config
from robot_app.sim.conveyor import Conveyor
from robot_app.sim.lighting import draw_lighting
from robot_app.sim.robot import SimRobot
from robot_app.sim.stereo import StereoCamera

HAND_STILL = 0.05  # [m/s] the hand slower than this pushes no cloth along (`World.step`)
HAND_CLEAR = 0.1  # [m] the TCP this far above the table top touches no lying cloth (`World.step`)
HAND_REACH = 0.1  # [m] cloth nodes this close to the TCP may touch the hand (`World.step`)
TOUCH = 0.04  # [m] cloths whose nodes come this close may touch (a pile's layers lie ~16 mm apart)
DRAG_SHARE = 1.25  # a cloth only touching a moved one goes at most this times its speed (+ the bound)
HELD_MEMORY = 0.5  # [s] a cloth held back this recently may not speed up at all (`World.step`)
HELD_DECAY = 0.9  # its speed along the table after a step it tried to speed up again [-]
CREEP = 0.005  # [m/s] ... from this speed (a settling cloth's nodes jitter below it)
SUNK = 0.003  # [m] a cloth node deeper than this in the table top is set back onto it (`World.step`)
FLIP_FACE_UP = np.diag([1.0, -1.0, -1.0])  # Σ_M of a face-up cloth: z into the table
OCCLUDER_RGBA = (0.12, 0.25, 0.85, 1.0)  # the blue paper of Fig. 11 (b)
SETTLE_CHECK_STEPS = 12


@dataclass(frozen=True)
class BoxGeometry:
    """The collection box.

    Attributes:
        centre: (3,) centre of its floor (on the table top) [m].
        inner_size: inner side length [m] (paper: 0.22).
        wall_height: [m].
        name: what sort rules call it (`BoxSettings.name`).
    """

    centre: FloatArray
    inner_size: float
    wall_height: float
    name: str = "box"

    def contains(self, points: npt.ArrayLike) -> npt.NDArray[np.bool_]:
        """True for points inside the walls and below their top."""
        P = np.asarray(points, dtype=float).reshape(-1, 3)
        half = self.inner_size / 2
        d = P - self.centre
        return (np.abs(d[:, 0]) <= half) & (np.abs(d[:, 1]) <= half) & (d[:, 2] <= self.wall_height)

    def over_floor(self, points: npt.ArrayLike) -> npt.NDArray[np.bool_]:
        """True for points inside the walls, at any height: for a cloth nobody holds, what
        rests in the box, heaped over its rim or not (`contains` asks below the rim too)."""
        P = np.asarray(points, dtype=float).reshape(-1, 3)
        half = self.inner_size / 2
        d = P - self.centre
        return (np.abs(d[:, 0]) <= half) & (np.abs(d[:, 1]) <= half)


def _astride(over_floor: npt.NDArray[np.bool_]) -> bool:
    """A cloth with some nodes over a box's floor and some not hangs over its wall: free to
    slide in or off by its own weight (`World._hold_back_slides`)."""
    return bool(np.any(over_floor)) and not bool(np.all(over_floor))


class World:
    """The cell in one pybullet client; a context manager that disconnects on exit.

    Args:
        config: the cell's settings (default: configs/world.yaml or built-in defaults).
        gui: open pybullet's GUI instead of DIRECT mode.
    """

    def __init__(self, config: WorldConfig | None = None, *, gui: bool = False) -> None:
        self.config = config or load_world_config()
        self._client = pb.connect(pb.GUI if gui else pb.DIRECT)
        if self._client < 0:
            raise SimulationError("could not connect to pybullet (is another GUI open?)")
        try:
            self._build()
        except Exception:
            pb.disconnect(self._client)
            raise

    def _build(self) -> None:
        c = self.config
        client = self._client
        pb.resetSimulation(pb.RESET_USE_DEFORMABLE_WORLD, physicsClientId=client)
        pb.setGravity(0, 0, -c.gravity, physicsClientId=client)
        self.dt = 1.0 / c.physics_hz
        pb.setTimeStep(self.dt, physicsClientId=client)
        pb.setPhysicsEngineParameter(sparseSdfVoxelSize=c.cloth.sdf_voxel_size, physicsClientId=client)
        if c.cloth.substeps > 1:  # 1: pybullet's default single step (pick-place's physics unchanged)
            pb.setPhysicsEngineParameter(numSubSteps=c.cloth.substeps, physicsClientId=client)
        self.time = 0.0
        self.table_corrections = 0  # cloth nodes set back onto the solid table (`step`)
        self.slides_held = 0  # steps a lying cloth was kept from speeding up by itself (`step`)
        self.layer_corrections = 0  # cloth nodes set back on their side of another cloth (`step`)
        self._layers = LayerKeeper()
        self._layer_steps = 0
        self._motion: dict[int, tuple[FloatArray, FloatArray | None]] = {}  # centre, velocity
        self._held_at: dict[int, float] = {}  # body id -> when the guard last held it back [s]
        self._cache = cache_dir()
        top = c.table.top_z
        tx, ty = c.table.centre_xy
        sx, sy = c.table.size_xy
        rx, ry = c.range.centre_xy
        m = 2 * c.range.sheet_margin
        sheet = (c.range.size_xy[0] + m, c.range.size_xy[1] + m)
        table_box = ((tx - sx / 2, tx + sx / 2), (ty - sy / 2, ty + sy / 2))
        sheet_box = ((rx - sheet[0] / 2, rx + sheet[0] / 2), (ry - sheet[1] / 2, ry + sheet[1] / 2))
        # pybullet's CPU renderer scans each triangle's whole screen bounding box: big
        # quads cost a full image each even when off screen. Visible surfaces are therefore
        # fine tiled meshes, and nothing is drawn under the green sheet or under the table.
        floor_z = top - c.table.height
        self.floor_id = self._box((tx, ty, floor_z - 0.01), (sx, sy, 0.02), collision=True, rgb=None)
        self._tiles(
            _frame(((tx - 2.0, tx + 2.0), (ty - 2.0, ty + 2.0)), table_box), floor_z, (0.55, 0.55, 0.5), 0.2
        )
        self.table_id = self._box(
            (tx, ty, top - c.table.height / 2), (sx, sy, c.table.height), collision=True, rgb=None
        )
        self._tiles(_frame(table_box, sheet_box), top - 0.003, (0.8, 0.75, 0.65), 0.05)
        self.sheet_id = self._tiles([(*sheet_box[0], *sheet_box[1])], top - 0.0015, c.range.sheet_rgb, 0.04)
        boxes: list[BoxGeometry] = []
        walls: list[int] = []
        for b in c.all_boxes:
            boxes.append(BoxGeometry(np.array([*b.centre_xy, top]), b.inner_size, b.wall_height, b.name))
            walls.extend(self._box_walls(b))
        self.boxes: tuple[BoxGeometry, ...] = tuple(boxes)
        self.box = self.boxes[0]  # the main box (pick-place's)
        self.box_ids = tuple(walls)  # every box's four walls
        self.robot = SimRobot(self._client, c.robot)
        self.transform_observation_camera_to_world = observation_camera_pose(c)
        self.observation_joints = self.robot.solve_frame_ik(
            RIGHT_FRAME, self.transform_observation_camera_to_world, c.robot.home_joints
        )
        self.observation_joints.setflags(write=False)
        self.robot.reset_joints(self.observation_joints)
        self.stereo = StereoCamera(self._client, self.robot, c, self)
        self.cloths: list[ClothBody] = []
        self.conveyor: Conveyor | None = None  # the belt under the range, when a scene runs one

    @property
    def lighting(self) -> Lighting:
        """The cell's light now (the key lamp's direction is drawn per scene by `reseed`)."""
        return self.stereo.lighting

    def reseed(self, seed: int) -> None:
        """Draws the key lamp's direction for a scene and restarts the cameras' generators.

        Same config and seed: same light and same camera noise for the same captures.
        """
        rng = np.random.default_rng((seed, 7))
        self.stereo.lighting = draw_lighting(self.config.lighting, rng)
        self.stereo.reseed(seed)

    @property
    def client(self) -> int:
        """The pybullet client id (for code inside robot_app.sim only)."""
        return self._client

    @property
    def static_obstacles(self) -> tuple[int, ...]:
        """Bodies the arm must not touch: table and box walls."""
        return (self.table_id, *self.box_ids)

    def step(self, n: int = 1) -> None:
        """Advances the simulation by `n` steps of `dt` [s]; a running belt carries its cloths first."""
        if n < 0:
            raise ValueError(f"step count must be >= 0, got {n}")
        if self.conveyor is None or not self.conveyor.running:
            for _ in range(n):
                pb.stepSimulation(physicsClientId=self._client)
                self._keep_cloths_on_table()
                self._keep_layers()
                self._hold_back_slides()
            self.time += n * self.dt
            return
        for _ in range(n):
            self.conveyor.carry(self.cloths, self.time, self.dt)
            pb.stepSimulation(physicsClientId=self._client)
            self._keep_cloths_on_table()
            self._keep_layers()
            self._motion = {}  # a running belt carries its cloths: no slide to hold back
            self.time += self.dt

    def _keep_cloths_on_table(self) -> None:
        """The table is solid (`world.cloth.solid_table`): a free cloth node more than `SUNK`
        inside its top is set back onto it, at the collision margin (where a node resting in
        a pile lies). pybullet's soft-rigid contact lets a node pressed by another cloth sink
        in; trapped there under the other cloth it pushed the pair along the table by itself
        (the heap slide, README "Cloths through the table"). A lone cloth's resting nodes lie
        within 0.3 mm of the top and are never touched."""
        c = self.config
        if not c.cloth.solid_table or not self.cloths:
            return
        top = c.table.top_z
        (tx, ty), (sx, sy) = c.table.centre_xy, c.table.size_xy

        def over_table(nodes: FloatArray) -> npt.NDArray[np.bool_]:
            return np.asarray((np.abs(nodes[:, 0] - tx) < sx / 2) & (np.abs(nodes[:, 1] - ty) < sy / 2))

        for cloth in self.cloths:
            self.table_corrections += cloth.lift_free_nodes(
                top - SUNK, top + c.cloth.collision_margin, over_table
            )

    def _keep_layers(self) -> None:
        """Cloths lying on cloths keep their side of each other (`world.cloth.keep_layers`,
        `cloth_layers.LayerKeeper`), checked every `cloth_layers.CHECK_EVERY` steps."""
        if not self.config.cloth.keep_layers or len(self.cloths) < 2:
            return
        self._layer_steps += 1
        if self._layer_steps % CHECK_EVERY == 0:
            cloth = self.config.cloth
            self.layer_corrections += self._layers.keep(
                self.cloths, self.config.table.top_z, cloth.keep_layers_held, cloth.uncross_layers
            )

    def _hold_back_slides(self) -> None:
        """No cloth speeds up by itself (`world.cloth.free_slide_speed`): a cloth the hand
        cannot be moving (`_moved_by_hand`: not held, not near a hand that pushes, not touching
        a cloth that is; a hand still, well above the table or rising straight up pushes
        nothing: an open hand leaving what it let go lifts nothing sideways), lying free on
        the table or in a box (not over a box's wall: astride it, it slides in or off by its
        own weight; not falling: its mean vertical speed downwards under the bound),
        whose mean speed along
        the table grew in this step beyond the bound gets back the speed it had (or the bound,
        if it had less), in the direction it now has; its nodes keep their velocities relative
        to each other (`ClothBody.set_mean_velocity`). Friction still slows a sliding cloth and
        a landing one; nothing is stopped. A free cloth on a flat table that nothing pushes
        cannot speed up, and two cloths' forces on each other cancel; pybullet's soft-soft
        contact in a heap whose layers crossed speeds the pair up along the table by itself
        (about 3.5 m/s^2, docs/history.md, session 15) until it falls over the edge, and
        threw a put-back heap of four 0.45 m sideways at 1.2 m/s while the open hand rose
        from it straight up (bench episode 44, session 22: the heap landed beyond the
        survey's view, by the whites box, and no cloth of it was seen again). Until session
        22 the guard held only while no cloth was held at all: in bench episode 78 two cloths
        lying 0.25 m from the pair being laid back, touching nothing that moved, sped up to
        1.5 m/s along the table and fell off its end. Once held
        back, a cloth may not speed up at all for `HELD_MEMORY` (from `CREEP`): each step it
        tries, its speed drops to `HELD_DECAY` of what it had (at most the bound), as friction
        would slow it. Until session 23 it kept the bound's speed: in held-out episode 117 two
        cloths a pick had dragged crept on at 0.05 m/s for 6 s, 0.3 m, half out of the survey's
        view, and were never seen again. A cloth that something moving touches (dragged, or
        lying on one that is) may go as fast as that, `DRAG_SHARE` times its speed plus the
        bound, and no faster (`_moved_by_hand`). Until session 28 cloths in a box and cloths
        rising were left alone: in held-out episode 400 two cloths lying in the colours box
        sped up to 0.7 m/s together, rising 2 cm, while the hand was 0.7 m away, climbed
        the wall and fell to the floor. Velocities
        are the nodes' mean displacement over one step (pybullet does not report a soft body's
        velocity)."""
        bound = self.config.cloth.free_slide_speed
        if bound is None or not self.cloths:
            self._motion = {}
            return
        c = self.config
        (tx, ty), (sx, sy) = c.table.centre_xy, c.table.size_xy
        hand = self.robot.frame_velocity("tcp")[0]
        tcp = self.robot.frame_pose("tcp")[:3, 3]
        hand_pushes = not (
            float(tcp[2]) > c.table.top_z + HAND_CLEAR
            or float(np.linalg.norm(hand)) < HAND_STILL
            or (float(hand[2]) > 0.0 and float(np.hypot(hand[0], hand[1])) < HAND_STILL)
        )
        previous, self._motion = self._motion, {}
        speeding: list[tuple[ClothBody, FloatArray, float, float]] = []
        all_nodes: dict[int, FloatArray] = {}
        for cloth in self.cloths:
            nodes = all_nodes[cloth.body_id] = cloth.nodes()
            centre = nodes.mean(axis=0)
            last_centre, last_velocity = previous.get(cloth.body_id, (None, None))
            velocity = None if last_centre is None else (centre - last_centre) / self.dt
            self._motion[cloth.body_id] = (centre, velocity)
            if velocity is None or last_velocity is None:
                continue
            speed, speed_before = float(np.hypot(*velocity[:2])), float(np.hypot(*last_velocity[:2]))
            # held back lately: it may not speed up at all (else the push held it at the bound)
            floor = CREEP if self.time - self._held_at.get(cloth.body_id, -np.inf) <= HELD_MEMORY else bound
            if speed <= floor or speed <= speed_before or float(velocity[2]) < -bound:
                continue  # (a falling cloth falls; one rising with nothing under it is pushed by pybullet)
            on_table = bool(np.all((np.abs(nodes[:, 0] - tx) < sx / 2) & (np.abs(nodes[:, 1] - ty) < sy / 2)))
            if not on_table or any(_astride(box.over_floor(nodes)) for box in self.boxes):
                continue
            speeding.append((cloth, velocity, speed, speed_before))
        if not speeding:
            return
        speeds = {k: 0.0 if v is None else float(np.hypot(*v[:2])) for k, (_, v) in self._motion.items()}
        moved = self._moved_by_hand(all_nodes, tcp, hand_pushes, speeds)
        for cloth, velocity, speed, speed_before in speeding:
            drive = moved.get(cloth.body_id)
            if drive is None:  # nothing moves it: it may not speed up by itself
                again = self.time - self._held_at.get(cloth.body_id, -np.inf) <= HELD_MEMORY
                allowed = HELD_DECAY * min(speed_before, bound) if again else max(speed_before, bound)
            elif speed > (allowed := bound + DRAG_SHARE * drive):
                pass  # dragged faster than what drags it
            else:
                continue
            held_back = velocity.copy()
            held_back[:2] *= allowed / speed
            cloth.set_mean_velocity(held_back)
            self._motion[cloth.body_id] = (self._motion[cloth.body_id][0], held_back)
            self._held_at[cloth.body_id] = self.time
            self.slides_held += 1

    def _moved_by_hand(
        self, nodes: dict[int, FloatArray], tcp: FloatArray, hand_pushes: bool, speeds: dict[int, float]
    ) -> dict[int, float]:
        """The cloths the hand may move this step (`nodes`: body id -> (N, 3) node positions
        [m], as read this step; `speeds`: body id -> speed along the table this step [m/s]),
        each with the speed of what moves it (inf: the hand itself): those it holds, when it
        `hand_pushes` (low over the table and moving, other than straight up) those with a
        node within `HAND_REACH` of the TCP, and every cloth touching one of these (a node
        within `TOUCH`), and so on: a cloth held, pushed or dragged, or lying on one that is.
        A cloth that is only dragged goes no faster than what drags it: its drive is the
        fastest of the cloths it touches (each at most as fast as its own drive allows).
        Held-out episode 383 (session 28): the hand rose straight up with No.4 and a cloth
        it had caught, and the cloth lying under that one shot 0.47 m along the table at
        1.1 m/s, to the table's end, beyond every survey's view, while the held cloth's
        middle moved at 0.3 m/s (pybullet's soft-soft contact; the check for a fling, 5 m/s,
        did not see it)."""
        moved = dict.fromkeys((cloth.body_id for cloth in self.cloths if cloth.is_grasped), np.inf)
        if hand_pushes:
            near = {k for k, n in nodes.items() if np.min(np.linalg.norm(n - tcp, axis=1)) < HAND_REACH}
            moved |= dict.fromkeys(near, np.inf)
        trees: dict[int, cKDTree] = {}
        frontier = list(moved)
        while frontier:
            mover = frontier.pop(0)
            drive = min(speeds.get(mover, 0.0), moved[mover])
            for k, n in nodes.items():
                if k in moved and moved[k] >= drive:
                    continue
                tree = trees.setdefault(k, cKDTree(n))
                if np.any(np.isfinite(tree.query(nodes[mover], distance_upper_bound=TOUCH)[0])):
                    moved[k] = max(moved.get(k, 0.0), drive)
                    frontier.append(k)
        return moved

    def add_cloth(
        self,
        spec: ClothSpec,
        x: float,
        y: float,
        yaw: float,
        drop_height: float = 0.0,
        settle: bool = True,
        look: ClothLook | None = None,
    ) -> ClothBody:
        """Lays a catalogue cloth face up with Σ_M's origin at (x, y) [m], turned by `yaw` [rad].

        The cloth starts `drop_height` [m] (plus its collision margin) above the table;
        with `settle` the simulation runs until it lies still (at most settle_time).
        `look` wrinkles it and may fold a corner over (see `add_cloth_at`).
        """
        z = self.config.table.top_z + self.config.cloth.collision_margin + drop_height
        pose = make_transform(rotation_about_z(yaw) @ FLIP_FACE_UP, [x, y, z])
        return self.add_cloth_at(spec, pose, settle, look)

    def add_cloth_at(
        self,
        spec: ClothSpec,
        transform_model_to_world: npt.ArrayLike,
        settle: bool = False,
        look: ClothLook | None = None,
    ) -> ClothBody:
        """Adds a cloth in its rest shape with Σ_M at the given 4x4 pose [m].

        A fabric cloth (`appearance.fabric`) or one with wrinkles is drawn with a render
        mesh skinned to the physics mesh; `look.fold` folds a corner over right away.

        The gripper holds cloths by anchors only and never touches them: nodes next to
        the anchored ones, pushed by the fingers they are anchored to, make the cloth
        explode as it is lifted, and released nodes stay caught between the closed fingers.
        """
        physics = self.config.cloth
        mesh = build_cloth_mesh(spec, physics.node_spacing, physics.boundary_spacing)
        fabric = self.config.appearance.fabric
        plain = look is None or (not look.ridges and look.fold is None)
        render = None
        if fabric or not plain:
            render_mesh = build_render_mesh(mesh, self.config.appearance.visual_spacing, look)
            render = render_obj_path(render_mesh, self._cache, keep=plain)
        try:
            cloth = ClothBody(
                self._client,
                mesh,
                transform_model_to_world,
                physics,
                self._cache,
                render_obj=render,
                fabric=fabric,
            )
        finally:
            if render is not None and not plain:  # a one-off mesh: pybullet has read it
                render.unlink(missing_ok=True)
        cloth.ignore_collisions_with(self.robot.body_id, self.robot.gripper_links)
        self.cloths.append(cloth)
        if look is not None and look.fold is not None:
            cloth.fold(look.fold)
        if settle:
            self.settle([cloth])
        return cloth

    def settle(self, cloths: list[ClothBody] | None = None, tolerance: float = 2e-4) -> float:
        """Steps until the cloths' nodes move less than `tolerance` [m] on average per check.

        Returns the simulated time spent [s] (at most `cloth.settle_time`).
        """
        bodies = self.cloths if cloths is None else cloths
        spent = 0.0
        previous = [b.nodes() for b in bodies]
        while spent < self.config.cloth.settle_time:
            self.step(SETTLE_CHECK_STEPS)
            spent += SETTLE_CHECK_STEPS * self.dt
            current = [b.nodes() for b in bodies]
            moved = max(
                (np.linalg.norm(a - b, axis=1).mean() for a, b in zip(current, previous, strict=True)),
                default=0.0,
            )
            previous = current
            if moved < tolerance:
                break
        return spent

    def add_occluder(
        self, centre_xy: tuple[float, float], yaw: float, size: tuple[float, float], height: float = 0.004
    ) -> int:
        """A sheet of blue paper (visual only) lying `height` [m] above the table; returns its id."""
        if size[0] <= 0 or size[1] <= 0 or height <= 0:
            raise ValueError(f"occluder size and height must be positive [m], got {size}, {height}")
        z = self.config.table.top_z + height
        return self._box((*centre_xy, z), (*size, 0.0005), OCCLUDER_RGBA[:3], collision=False, yaw=yaw)

    def remove_body(self, body: int | ClothBody) -> None:
        """Removes a cloth or a rigid body from the world."""
        if isinstance(body, ClothBody):
            body.remove()
            self.cloths.remove(body)
        else:
            pb.removeBody(int(body), physicsClientId=self._client)

    def cloth_in_box(self, cloth: ClothBody, box: BoxGeometry | None = None) -> float:
        """Fraction of the cloth's nodes inside a collection box (default: the main box)."""
        return float(np.mean((self.box if box is None else box).contains(cloth.nodes())))

    def transform_model_to_camera(self, cloth: ClothBody, frame: str = RIGHT_FRAME) -> FloatArray:
        """Ground truth ^C T_M of a cloth in a camera frame (default: the right camera)."""
        camera = self.robot.frame_pose(frame)
        return np.asarray(np.linalg.solve(camera, cloth.pose()), dtype=float)

    def save_rig(self, path: str | Path) -> Path:
        """Writes the hand stereo rig file the recogniser reads."""
        return self.stereo.save_rig(path)

    def close(self) -> None:
        """Disconnects the pybullet client (idempotent)."""
        if self._client >= 0:
            pb.disconnect(self._client)
            self._client = -1

    def __enter__(self) -> World:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()

    def _box_walls(self, b: BoxSettings) -> tuple[int, int, int, int]:
        """The four walls of a collection box standing on the table (body ids)."""
        bx, by = b.centre_xy
        wall = (0.85, 0.6, 0.3)
        outer = b.inner_size + 2 * b.wall_thickness
        offset = (b.inner_size + b.wall_thickness) / 2
        zc = self.config.table.top_z + b.wall_height / 2
        return (
            self._box((bx + offset, by, zc), (b.wall_thickness, outer, b.wall_height), wall),
            self._box((bx - offset, by, zc), (b.wall_thickness, outer, b.wall_height), wall),
            self._box((bx, by + offset, zc), (outer, b.wall_thickness, b.wall_height), wall),
            self._box((bx, by - offset, zc), (outer, b.wall_thickness, b.wall_height), wall),
        )

    def _tiles(
        self,
        rectangles: list[tuple[float, float, float, float]],
        z: float,
        rgb: tuple[float, float, float],
        tile: float,
    ) -> int:
        """A visual-only horizontal surface at height `z` [m] made of small tiles."""
        vertices, indices = _tile_mesh(rectangles, z, tile)
        vis = pb.createVisualShape(
            pb.GEOM_MESH,
            vertices=vertices,
            indices=indices,
            normals=[[0.0, 0.0, 1.0]] * len(vertices),
            rgbaColor=[*rgb, 1.0],
            physicsClientId=self._client,
        )
        return pb.createMultiBody(0, -1, vis, [0, 0, 0], physicsClientId=self._client)

    def _box(
        self,
        centre: tuple[float, float, float],
        size: tuple[float, float, float],
        rgb: tuple[float, float, float] | None,
        collision: bool = True,
        yaw: float = 0.0,
    ) -> int:
        """A static box; `rgb=None` makes it invisible, `collision=False` intangible."""
        client = self._client
        half = [s / 2 for s in size]
        col = (
            pb.createCollisionShape(pb.GEOM_BOX, halfExtents=half, physicsClientId=client)
            if collision
            else -1
        )
        vis = -1
        if rgb is not None:
            vis = pb.createVisualShape(
                pb.GEOM_BOX, halfExtents=half, rgbaColor=[*rgb, 1.0], physicsClientId=client
            )
        quat = quaternion_xyzw_from_matrix(rotation_about_z(yaw)).tolist()
        body = pb.createMultiBody(0, col, vis, list(centre), quat, physicsClientId=client)
        if rgb is None:  # pybullet draws the collision shape of a body without a visual
            pb.changeVisualShape(body, -1, rgbaColor=[0, 0, 0, 0], physicsClientId=client)
        return body


def observation_camera_pose(config: WorldConfig) -> FloatArray:
    """(4, 4) pose of the right camera at the observation pose in Σ_W [m]: `observation.height`
    above the range centre, looking straight down, turned by `observation.camera_yaw`."""
    rx, ry = config.range.centre_xy
    turn = rotation_about_z(config.observation.camera_yaw)
    axes = np.column_stack([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
    return make_transform(turn @ axes, [rx, ry, config.table.top_z + config.observation.height])


def _tile_mesh(
    rectangles: list[tuple[float, float, float, float]], z: float, tile: float
) -> tuple[list[list[float]], list[int]]:
    """Vertices and triangle indices of rectangles (x0, x1, y0, y1) cut into `tile` [m] cells."""
    vertices: list[list[float]] = []
    indices: list[int] = []
    for x0, x1, y0, y1 in rectangles:
        xs = np.linspace(x0, x1, max(1, int(np.ceil((x1 - x0) / tile))) + 1)
        ys = np.linspace(y0, y1, max(1, int(np.ceil((y1 - y0) / tile))) + 1)
        base = len(vertices)
        vertices += [[float(x), float(y), z] for y in ys for x in xs]
        n = len(xs)
        for j in range(len(ys) - 1):
            for i in range(n - 1):
                a = base + j * n + i
                indices += [a, a + 1, a + n + 1, a, a + n + 1, a + n]
    return vertices, indices


def _frame(
    outer: tuple[tuple[float, float], tuple[float, float]],
    inner: tuple[tuple[float, float], tuple[float, float]],
) -> list[tuple[float, float, float, float]]:
    """Rectangles (x0, x1, y0, y1) covering `outer` minus `inner` (inner clipped to outer)."""
    (ox0, ox1), (oy0, oy1) = outer
    ix0, ix1 = max(inner[0][0], ox0), min(inner[0][1], ox1)
    iy0, iy1 = max(inner[1][0], oy0), min(inner[1][1], oy1)
    pieces = [(ox0, ix0, oy0, oy1), (ix1, ox1, oy0, oy1), (ix0, ix1, oy0, iy0), (ix0, ix1, iy1, oy1)]
    return [p for p in pieces if p[1] - p[0] > 1e-6 and p[3] - p[2] > 1e-6]


__all__ = ["BoxGeometry", "World", "observation_camera_pose"]
