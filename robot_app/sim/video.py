"""MP4 of an episode: an overview camera of the cell with the hand stereo pair inset."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import numpy.typing as npt

from robot_app.errors import InputError
from robot_app.sim.cell import SimCell
from robot_app.sim.pictures import look_at, overview_image
from robot_app.sim.world import World
from robot_app.vision import PinholeCamera

OVERVIEW_SIZE = (480, 360)
INSET_WIDTH = 160


class EpisodeVideo:
    """Records `fps` frames per simulated second while the loop runs.

    Args:
        world: the simulated cell (its client renders the overview).
        cell: the loop's cell adapter (its last stereo capture is inset).
        path: output .mp4 file.
        fps: frames per simulated second (also the playback rate: real time).
    """

    def __init__(self, world: World, cell: SimCell, path: str | Path, fps: float = 10.0) -> None:
        import imageio.v2 as imageio

        self.path = Path(path)
        if self.path.suffix.lower() != ".mp4":
            raise InputError(f"video file must end in .mp4, got {self.path.name}")
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.world, self.cell = world, cell
        self.period = 1.0 / fps
        self.next_time = world.time
        self.camera = PinholeCamera.from_fov(OVERVIEW_SIZE, np.deg2rad(60.0))
        centre = np.array([*world.config.range.centre_xy, world.config.table.top_z])
        box = np.asarray(world.box.centre)
        focus = (centre + box) / 2 + np.array([0.0, 0.0, 0.25])
        self.pose = look_at(focus + np.array([1.3, -0.6, 0.9]), focus)
        self.writer = imageio.get_writer(str(self.path), fps=fps, codec="libx264", macro_block_size=8)
        self.frames = 0

    def tick(self) -> None:
        """Adds a frame if one is due at the current simulated time."""
        if self.world.time + 1e-9 < self.next_time:
            return
        self.next_time += self.period
        frame = overview_image(self.world, self.camera, self.pose)
        capture = self.cell.last_capture
        if capture is not None:
            left = _inset(capture.left_bgr)
            right = _inset(capture.right_bgr)
            h = left.shape[0]
            frame[:h, : left.shape[1]] = left
            frame[:h, left.shape[1] : left.shape[1] + right.shape[1]] = right
        cv2.putText(
            frame,
            f"t = {self.world.time:5.2f} s",
            (8, frame.shape[0] - 10),
            cv2.FONT_HERSHEY_SIMPLEX,
            0.5,
            (255, 255, 255),
            1,
            cv2.LINE_AA,
        )
        self.writer.append_data(frame[:, :, ::-1])
        self.frames += 1

    def close(self) -> None:
        self.writer.close()


def _inset(image: npt.NDArray[np.uint8]) -> npt.NDArray[np.uint8]:
    h, w = image.shape[:2]
    small = cv2.resize(image, (INSET_WIDTH, round(h * INSET_WIDTH / w)), interpolation=cv2.INTER_AREA)
    return np.asarray(
        cv2.copyMakeBorder(small, 1, 1, 1, 1, cv2.BORDER_CONSTANT, value=(255, 255, 255)), dtype=np.uint8
    )


__all__ = ["EpisodeVideo"]
