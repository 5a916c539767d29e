"""Synthetic board views with known truth for the calibration tests (no simulator).

A printed board (`board_image`) is seen by cameras with distortion: every output pixel
is undistorted, its ray cut with the board plane and the board image sampled there, at
twice the resolution and then averaged 2x2 (a pixel integrates light, no aliasing).
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from robot_app.calibration import BoardConfig, board_image, robot_poses_csv, save_board
from robot_app.geometry import invert_transform, make_transform, rotation_about_z
from robot_app.vision.camera import PinholeCamera, StereoRig

PIXELS_PER_SQUARE = 48
BACKGROUND = (40, 110, 50)


def true_rig(size: tuple[int, int] = (320, 240)) -> StereoRig:
    """A rig unlike the ideal one: distortion, unequal cameras, a tilted left camera."""
    width, height = size
    f = 0.5 * width / np.tan(np.deg2rad(24))
    left = PinholeCamera(
        [[f * 1.004, 0, width / 2 - 2.1], [0, f * 1.006, height / 2 + 1.3], [0, 0, 1]],
        size,
        [-0.08, 0.06, 0.0005, -0.0004, 0.0],
    )
    right = PinholeCamera(
        [[f, 0, width / 2 + 1.7], [0, f * 1.002, height / 2 - 0.8], [0, 0, 1]],
        size,
        [-0.06, 0.04, 0.0, 0.0003, 0.0],
    )
    tilt = cv2.Rodrigues(np.deg2rad([0.4, -0.6, 0.3]))[0]
    hand = make_transform(cv2.Rodrigues(np.deg2rad([1.5, -2.0, 1.0]))[0], [0.05, -0.07, 0.06])
    return StereoRig(left, right, make_transform(tilt, [-0.1, 0.0008, -0.0015]), hand)


def render_view(
    board: BoardConfig, camera: PinholeCamera, transform_board_to_camera: np.ndarray, supersample: int = 2
) -> np.ndarray:
    """The board seen by `camera` at the given pose, a BGR image."""
    texture = cv2.cvtColor(board_image(board, PIXELS_PER_SQUARE, 1.0), cv2.COLOR_GRAY2BGR)
    width, height = camera.image_size
    d = _rays(camera, supersample)
    R, t = transform_board_to_camera[:3, :3], transform_board_to_camera[:3, 3]
    n = R[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        depth = (n @ t) / (d @ n)
    points = depth[:, None] * d
    board_xy = (points - t) @ R
    s, p, m = board.square_size, PIXELS_PER_SQUARE, PIXELS_PER_SQUARE
    map_x = (m + p * (1 + board_xy[:, 0] / s) - 0.5).astype(np.float32)
    map_y = (m + p * (1 + board_xy[:, 1] / s) - 0.5).astype(np.float32)
    behind = ~(depth > 0)
    map_x[behind], map_y[behind] = -1e4, -1e4
    shape = (height * supersample, width * supersample)
    big = cv2.remap(
        texture,
        map_x.reshape(shape),
        map_y.reshape(shape),
        cv2.INTER_LINEAR,
        borderMode=cv2.BORDER_CONSTANT,
        borderValue=BACKGROUND,
    )
    return cv2.resize(big, (width, height), interpolation=cv2.INTER_AREA)


_RAYS: dict[tuple[bytes, bytes, tuple[int, int], int], np.ndarray] = {}


def _rays(camera: PinholeCamera, supersample: int) -> np.ndarray:
    """(N, 3) rays (x, y, 1) of every supersampled pixel, undistorted; cached per camera."""
    key = (camera.camera_matrix.tobytes(), camera.dist_coeffs.tobytes(), camera.image_size, supersample)
    if key not in _RAYS:
        width, height = camera.image_size
        u, v = np.meshgrid(np.arange(width * supersample), np.arange(height * supersample))
        pixels = np.stack([(u + 0.5) / supersample - 0.5, (v + 0.5) / supersample - 0.5], axis=-1)
        rays = cv2.undistortPoints(
            pixels.reshape(-1, 1, 2).astype(np.float64), camera.camera_matrix, camera.dist_coeffs
        ).reshape(-1, 2)
        _RAYS[key] = np.column_stack([rays, np.ones(len(rays))])
    return _RAYS[key]


def board_outline_in_view(board: BoardConfig, camera: PinholeCamera, board_in_camera: np.ndarray) -> bool:
    """True when the whole board (its squares) is inside the image with a 4 px margin."""
    s = board.square_size
    far_x, far_y = (board.cols - 1) * s, (board.rows - 1) * s
    outline = np.array([[-s, -s, 0], [far_x, -s, 0], [far_x, far_y, 0], [-s, far_y, 0]], dtype=float)
    in_camera = outline @ board_in_camera[:3, :3].T + board_in_camera[:3, 3]
    if np.any(in_camera[:, 2] < 0.1):
        return False
    px = camera.project(in_camera)
    width, height = camera.image_size
    return bool(np.all((px >= 4) & (px <= [width - 5, height - 5])))


def board_poses(
    board: BoardConfig, rig: StereoRig, count: int, seed: int, both: bool = True
) -> list[np.ndarray]:
    """Board-in-right-camera poses with the board in both images (or the right one)."""
    rng = np.random.default_rng(seed)
    s = board.square_size
    centre = np.array([(board.cols / 2 - 1) * s, (board.rows / 2 - 1) * s, 0.0])
    poses: list[np.ndarray] = []
    while len(poses) < count:
        tilt = cv2.Rodrigues(np.r_[rng.uniform(-0.6, 0.6, 2), 0.0])[0]
        turn = rotation_about_z(rng.uniform(-1.0, 1.0))
        R = tilt @ turn
        depth = rng.uniform(0.42, 0.7)
        offset = np.r_[rng.uniform(-0.08, 0.02), rng.uniform(-0.05, 0.05), depth]
        pose = make_transform(R, offset - R @ centre)
        in_left = rig.transform_right_to_left @ pose
        if board_outline_in_view(board, rig.right, pose) and (
            not both or board_outline_in_view(board, rig.left, in_left)
        ):
            poses.append(pose)
    return poses


def write_views(
    folder: Path,
    board: BoardConfig,
    rig: StereoRig,
    count: int,
    seed: int = 0,
    board_to_base: np.ndarray | None = None,
) -> list[np.ndarray]:
    """Writes left_/right_ images, board.yaml and robot_poses.csv; returns the hand poses.

    The robot poses are the flange poses that put the right camera where each view was
    taken, the board fixed at `board_to_base` (default: on a table 0.55 m in front).
    """
    assert rig.transform_right_camera_to_hand is not None
    folder.mkdir(parents=True, exist_ok=True)
    W = (
        board_to_base
        if board_to_base is not None
        else make_transform(np.diag([1.0, -1.0, -1.0]), [0.45, 0.1, 0.0])
    )
    hands = []
    for n, board_in_right in enumerate(board_poses(board, rig, count, seed)):
        left = render_view(board, rig.left, rig.transform_right_to_left @ board_in_right)
        right = render_view(board, rig.right, board_in_right)
        cv2.imwrite(str(folder / f"left_{n:03d}.png"), left)
        cv2.imwrite(str(folder / f"right_{n:03d}.png"), right)
        hands.append(
            W @ invert_transform(board_in_right) @ invert_transform(rig.transform_right_camera_to_hand)
        )
    save_board(board, folder / "board.yaml")
    (folder / "robot_poses.csv").write_text(robot_poses_csv(dict(enumerate(hands))))
    return hands
