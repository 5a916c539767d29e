"""Calibration views in the simulated cell: a checkerboard on the table, the arm over it.

`capture_calibration_views` lays the board on the green sheet, moves the arm through
camera poses that vary distance, tilt, roll and where the board falls in the image,
stops at each, lets it settle and captures the stereo pair through the cell's own
`StereoCamera.render()` (so whatever camera model the cell has, noise and all, is what
the calibration sees) together with the flange pose the robot measures. The folder it
writes is what a real rig would give `robot-app calibrate stereo` and `calibrate
hand-eye`: `left_<n>.png`, `right_<n>.png`, `robot_poses.csv`, `board.yaml` and
`flat_field/` (frames of a uniformly lit card through the same cameras, to measure their
vignetting from, as a real rig would: `robot_app.calibration.flat_field`), plus
`truth/rig.yaml`, the URDF's rig, for benchmarks only.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pybullet as pb
from pydantic import Field

from robot_app.arrays import FloatArray
from robot_app.calibration.board import BoardConfig, save_board
from robot_app.calibration.files import robot_poses_csv
from robot_app.calibration.flat_field import FLAT_FIELD_FOLDER
from robot_app.calibration.rig_file import write_rig
from robot_app.config import StrictModel
from robot_app.errors import IKError, OutputError, SimulationError
from robot_app.geometry import invert_transform, make_transform, rotation_about_z, transform_points
from robot_app.outputs import atomic_write_image, atomic_write_text
from robot_app.robot_description import PA10_FLANGE
from robot_app.sim.cameras import RIGHT_FRAME
from robot_app.sim.config import WorldConfig
from robot_app.sim.world import World
from robot_app.vision.camera import StereoRig

FACE_UP = np.diag([1.0, -1.0, -1.0])  # Σ_B of a board lying face up: z into the table
BLACK, WHITE = (0.04, 0.04, 0.04), (0.92, 0.92, 0.92)
FLAT_FRAME_INTERVAL = 0.1  # [s] between flat-field frames (the auto-exposure settles on the card)
DEFAULT_BOARD = BoardConfig(type="checkerboard", rows=7, cols=10, square_size=0.03)


class CalibrationViewSettings(StrictModel):
    """Where the board lies and how the arm looks at it. Lengths [m], angles [deg]."""

    views: int = Field(40, ge=1, le=500, description="image pairs to capture")
    seed: int = Field(0, ge=0, description="seed of the camera poses")
    board: BoardConfig = DEFAULT_BOARD
    board_centre_xy: tuple[float, float] = Field((0.55, 0.0), description="board centre on the table [m]")
    board_yaw_deg: float = 0.0
    board_margin: float = Field(0.03, ge=0.0, description="white border around the squares [m]")
    distance: tuple[float, float] = Field((0.42, 0.75), description="board centre's depth in a camera [m]")
    max_tilt_deg: float = Field(35.0, ge=0.0, lt=80.0, description="optical axis from vertical [deg]")
    max_roll_deg: float = Field(60.0, ge=0.0, le=180.0, description="turn about the optical axis [deg]")
    image_spread: float = Field(
        0.7, ge=0.0, le=1.0, description="board centre anywhere within this fraction of the half image"
    )
    min_pair_fraction: float = Field(
        0.75, gt=0.0, le=1.0, description="views with the board in both images; the rest in one image"
    )
    edge_margin_px: float = Field(6.0, ge=0.0, description="board corners at least this far inside [px]")
    settle_time: float = Field(0.25, ge=0.0, description="arm standstill before each capture [s]")
    max_tries_per_view: int = Field(60, ge=1)
    flat_field_frames: int = Field(
        8, ge=0, le=100, description="frames of a uniformly lit card per camera, in flat_field/ (0: none)"
    )


@dataclass(frozen=True)
class CalibrationViews:
    """What `capture_calibration_views` wrote.

    Attributes:
        folder: the output folder.
        count: image pairs written.
        tried: camera poses tried (rejected: unreachable, colliding or board not in both images).
        transforms_flange_to_base: (count, 4, 4) measured flange poses [m].
        transform_board_to_world: 4x4 pose of Σ_B (the truth, for tests) [m].
    """

    folder: Path
    count: int
    tried: int
    transforms_flange_to_base: FloatArray
    transform_board_to_world: FloatArray


def board_pose(world_config: WorldConfig, settings: CalibrationViewSettings) -> FloatArray:
    """4x4 pose of Σ_B (first inner corner, z into the table) lying on the table [m]."""
    board = settings.board
    R = rotation_about_z(np.deg2rad(settings.board_yaw_deg)) @ FACE_UP
    half = np.array([board.size[0] / 2 - board.square_size, board.size[1] / 2 - board.square_size, 0.0])
    centre = np.array([*settings.board_centre_xy, world_config.table.top_z + 0.002])
    return make_transform(R, centre - R @ half)


def add_board_body(
    world: World, board: BoardConfig, transform_board_to_world: FloatArray, margin: float
) -> int:
    """A visual-only printed board (black and white squares, white border) in `world`.

    Two meshes, one per colour, side by side in one plane (no overlap, so no depth fight).
    """
    s = board.square_size
    x0, y0 = -s - margin, -s - margin
    x1, y1 = (board.cols - 1) * s + margin, (board.rows - 1) * s + margin
    quads: dict[bool, list[tuple[float, float, float, float]]] = {True: [], False: []}
    for i in range(board.rows):
        for j in range(board.cols):
            quads[bool(board.square_is_black(i, j))].append(((j - 1) * s, j * s, (i - 1) * s, i * s))
    inner = (-s, (board.cols - 1) * s, -s, (board.rows - 1) * s)
    quads[False] += [
        (x0, x1, y0, inner[2]),
        (x0, x1, inner[3], y1),
        (x0, inner[0], inner[2], inner[3]),
        (inner[1], x1, inner[2], inner[3]),
    ]
    body = -1
    for black, rectangles in quads.items():
        rectangles = [r for r in rectangles if r[1] - r[0] > 1e-9 and r[3] - r[2] > 1e-9]
        if not rectangles:
            continue
        corners = [[(a, c), (b, c), (b, d), (a, d)] for a, b, c, d in rectangles]
        local = np.array([[u, v, 0.0] for quad in corners for u, v in quad])
        vertices = transform_points(transform_board_to_world, local).tolist()
        normal = (-transform_board_to_world[:3, 2]).tolist()  # the printed face looks out of the board
        indices = [
            k
            for n in range(len(rectangles))
            for k in (4 * n, 4 * n + 2, 4 * n + 1, 4 * n, 4 * n + 3, 4 * n + 2)
        ]
        visual = pb.createVisualShape(
            pb.GEOM_MESH,
            vertices=vertices,
            indices=indices,
            normals=[normal] * len(vertices),
            rgbaColor=[*(BLACK if black else WHITE), 1.0],
            physicsClientId=world.client,
        )
        body = pb.createMultiBody(0, -1, visual, [0, 0, 0], physicsClientId=world.client)
    return body


def capture_calibration_views(
    world_config: WorldConfig,
    settings: CalibrationViewSettings,
    out: str | Path,
    progress: Callable[[int, int], None] | None = None,
) -> CalibrationViews:
    """Captures `settings.views` stereo pairs of the board with their flange poses into `out`.

    Args:
        world_config: the cell (its cameras, realism, robot); the recogniser's rig file is unused.
        settings: board placement and camera pose ranges.
        out: a new or empty folder.
        progress: called with (views captured, views wanted).

    Raises:
        OutputError: `out` is a file or a folder that is not empty.
        SimulationError: the arm could not reach enough poses that see the board.
    """
    folder = Path(out)
    if folder.exists() and (not folder.is_dir() or any(folder.iterdir())):
        raise OutputError(f"--out {folder} must be a new or empty folder", path=folder, key="--out")
    rng = np.random.default_rng(settings.seed)
    images: list[tuple[np.ndarray, np.ndarray]] = []
    poses: list[FloatArray] = []
    tried = 0
    with World(world_config) as world:
        board_to_world = board_pose(world_config, settings)
        add_board_body(world, settings.board, board_to_world, settings.board_margin)
        b = settings.board
        far = (b.cols - 1) * b.square_size, (b.rows - 1) * b.square_size
        outline = [
            [-b.square_size, -b.square_size, 0.0],
            [far[0], -b.square_size, 0.0],
            [far[0], far[1], 0.0],
        ]
        outline.append([-b.square_size, far[1], 0.0])  # the squares' outer corners: the whole board
        corners_world = transform_points(board_to_world, outline)
        rig = world.stereo.true_rig
        one_sided_allowed = settings.views - int(np.ceil(settings.min_pair_fraction * settings.views))
        one_sided = 0
        # the base's URDF frame from the config (pybullet's base pose is its centre of mass)
        robot = world_config.robot
        base_to_world_inverse = invert_transform(
            make_transform(rotation_about_z(robot.base_yaw), robot.base_xyz)
        )
        q_rest = np.array(world.observation_joints)
        while len(images) < settings.views:
            if tried >= settings.max_tries_per_view * settings.views:
                raise SimulationError(
                    f"only {len(images)} of {settings.views} calibration views found in {tried} camera "
                    "poses: the board is out of reach or out of view (check board_centre_xy, distance)"
                )
            tried += 1
            target = _camera_pose(rng, board_to_world, settings, rig)
            seen = _board_in_view(target, rig, corners_world, settings.edge_margin_px)
            both = seen["right"] and seen["left"]
            if not (seen["right"] or seen["left"]) or (not both and one_sided >= one_sided_allowed):
                continue
            try:
                q = world.robot.solve_frame_ik(RIGHT_FRAME, target, q_rest)
            except IKError:
                continue
            world.robot.reset_joints(q)
            if world.robot.arm_collisions(world.static_obstacles, margin=0.01):
                continue
            one_sided += 0 if both else 1
            world.step(max(1, round(settings.settle_time / world.dt)))
            frame = world.stereo.render()
            images.append((frame.left_bgr, frame.right_bgr))
            poses.append(base_to_world_inverse @ world.robot.frame_pose(PA10_FLANGE))
            q_rest = q
            if progress is not None:
                progress(len(images), settings.views)
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "truth").mkdir(exist_ok=True)
        write_rig(
            rig, folder / "truth" / "rig.yaml", ("the URDF's rig: the truth a calibration is compared with",)
        )
        flat_frames = []
        for _ in range(settings.flat_field_frames):  # a lit card held over the lenses, frame after frame
            world.step(max(1, round(FLAT_FRAME_INTERVAL / world.dt)))
            flat_frames.append(world.stereo.expose_uniform_card())
    for n, (left, right) in enumerate(images):
        atomic_write_image(folder / f"left_{n:03d}.png", left)
        atomic_write_image(folder / f"right_{n:03d}.png", right)
    if flat_frames:
        (folder / FLAT_FIELD_FOLDER).mkdir(exist_ok=True)
    for n, (left, right) in enumerate(flat_frames):
        atomic_write_image(folder / FLAT_FIELD_FOLDER / f"left_{n:03d}.png", left)
        atomic_write_image(folder / FLAT_FIELD_FOLDER / f"right_{n:03d}.png", right)
    atomic_write_text(folder / "robot_poses.csv", robot_poses_csv(dict(enumerate(poses))))
    save_board(settings.board, folder / "board.yaml")
    return CalibrationViews(folder, len(images), tried, np.array(poses), board_to_world)


def _camera_pose(
    rng: np.random.Generator, board_to_world: FloatArray, s: CalibrationViewSettings, rig: StereoRig
) -> FloatArray:
    """A random right-camera pose that puts the board's centre somewhere in one camera's image.

    Tilt (uniform over a spherical cap), roll about the optical axis, depth, where in the
    image the board's centre falls and which camera that is for are all drawn at random.
    """
    board = s.board
    centre = transform_points(
        board_to_world, [[board.size[0] / 2 - board.square_size, board.size[1] / 2 - board.square_size, 0.0]]
    )[0]
    tilt = np.deg2rad(s.max_tilt_deg) * np.sqrt(rng.uniform(0.0, 1.0))
    azimuth = rng.uniform(-np.pi, np.pi)
    up = np.array([np.sin(tilt) * np.cos(azimuth), np.sin(tilt) * np.sin(azimuth), np.cos(tilt)])
    z = -up
    # the observation orientation (image x along world +y), turned about the optical axis
    x = np.array([0.0, 1.0, 0.0]) - z * z[1]
    x /= np.linalg.norm(x)
    roll = np.deg2rad(rng.uniform(-s.max_roll_deg, s.max_roll_deg))
    y = np.cross(z, x)
    x, y = np.cos(roll) * x + np.sin(roll) * y, -np.sin(roll) * x + np.cos(roll) * y
    R = np.column_stack([x, y, z])
    aimed_left = bool(rng.integers(0, 2))
    camera = rig.left if aimed_left else rig.right
    K, (width, height) = camera.camera_matrix, camera.image_size
    spread = rng.uniform(-s.image_spread, s.image_spread, 2)
    direction = np.array([spread[0] * width / 2 / K[0, 0], spread[1] * height / 2 / K[1, 1], 1.0])
    camera_to_world = make_transform(R, centre - R @ (rng.uniform(*s.distance) * direction))
    return camera_to_world @ rig.transform_right_to_left if aimed_left else camera_to_world


def _board_in_view(
    transform_right_camera_to_world: FloatArray, rig: StereoRig, points_world: FloatArray, margin_px: float
) -> dict[str, bool]:
    """For each camera: the given board points are inside its image, `margin_px` from the border."""
    seen = {}
    right = transform_right_camera_to_world
    for side, pose, camera in (
        ("left", right @ rig.transform_left_to_right, rig.left),
        ("right", right, rig.right),
    ):
        in_camera = transform_points(invert_transform(pose), points_world)
        if np.any(in_camera[:, 2] <= 0.05):
            seen[side] = False
            continue
        pixels = camera.project(in_camera)
        width, height = camera.image_size
        seen[side] = bool(
            np.all(
                (pixels[:, 0] >= margin_px)
                & (pixels[:, 0] <= width - 1 - margin_px)
                & (pixels[:, 1] >= margin_px)
                & (pixels[:, 1] <= height - 1 - margin_px)
            )
        )
    return seen


__all__ = [
    "DEFAULT_BOARD",
    "CalibrationViewSettings",
    "CalibrationViews",
    "add_board_body",
    "board_pose",
    "capture_calibration_views",
]
