"""MP4 of an episode: the whole cell and arm, the hand cameras with what the recogniser concluded.

Each frame (960 x 480) is the overview camera's render of the cell (640 x 480, the whole
arm in view from the observation pose to the box), with the phase and the cell time
written on it, beside a column with the two hand-camera images of the latest vision
cycle (320 x 240 each). On those the S_in outline is drawn where the recogniser put it
(yellow) and, in simulation, where the cloth really is (magenta), with the fitness and
confidence. Frames are rendered at `fps` per second of cell time and play back at that
rate, so the video runs in real (simulated) time.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
import numpy.typing as npt

from robot_app.errors import InputError
from robot_app.sim.cell import SimCell
from robot_app.sim.pictures import look_at, overview_image
from robot_app.sim.world import World
from robot_app.vision import PinholeCamera, ProjectedOutline, draw_outline

OVERVIEW_SIZE = (640, 480)  # width, height [px]
OVERVIEW_FOV_DEG = 50.0
OVERVIEW_EYE = (1.7, -1.5, 1.2)  # [m] in Σ_W, looking at OVERVIEW_TARGET
OVERVIEW_TARGET = (0.3, -0.2, 0.35)
INSET_SIZE = (320, 240)  # each hand camera in the side column [px]
RECOGNISED_BGR, TRUE_BGR = (0, 215, 255), (255, 0, 255)
WHITE, BLACK = (255, 255, 255), (0, 0, 0)
FONT = cv2.FONT_HERSHEY_SIMPLEX


@dataclass(frozen=True)
class VisionOverlay:
    """What the insets show for one vision cycle.

    Attributes:
        left_bgr, right_bgr: the images the recogniser looked at.
        recognised: S_in's outline under the recognised pose [px, in those images].
        true: the outline under the true pose, or None.
        caption: a few short lines (~35 characters), e.g. ("track 1.21 s: accepted",
            "fitness 0.97  confidence 0.93").
        good: draw the caption as a success (green) rather than a rejection (orange).
    """

    left_bgr: npt.NDArray[np.uint8]
    right_bgr: npt.NDArray[np.uint8]
    recognised: ProjectedOutline
    true: ProjectedOutline | None
    caption: tuple[str, ...]
    good: bool


class EpisodeVideo:
    """Records `fps` frames per simulated second while the loop runs.

    Args:
        world: the simulated cell (its client renders the overview).
        cell: the loop's cell adapter (its last stereo capture is shown until an overlay is given).
        path: output .mp4 file.
        fps: frames per simulated second (also the playback rate: real time).
    """

    def __init__(self, world: World, cell: SimCell, path: str | Path, fps: float = 20.0) -> None:
        import imageio.v2 as imageio

        self.path = Path(path)
        if self.path.suffix.lower() != ".mp4":
            raise InputError(f"video file must end in .mp4, got {self.path.name}")
        if fps <= 0:
            raise ValueError(f"fps must be positive, got {fps}")
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.world, self.cell = world, cell
        self.period = 1.0 / fps
        self.next_time = world.time
        self.camera = PinholeCamera.from_fov(OVERVIEW_SIZE, np.deg2rad(OVERVIEW_FOV_DEG))
        self.pose = look_at(OVERVIEW_EYE, OVERVIEW_TARGET)
        self.writer = imageio.get_writer(str(self.path), fps=fps, codec="libx264", macro_block_size=8)
        self.frames = 0
        self._column: npt.NDArray[np.uint8] | None = None

    def show_vision(self, overlay: VisionOverlay) -> None:
        """Uses this vision cycle's images, outlines and caption for the next frames."""
        insets = []
        for image, name, index in ((overlay.left_bgr, "left", 0), (overlay.right_bgr, "right", 1)):
            inset = _inset(image)
            scale = INSET_SIZE[0] / image.shape[1]
            if overlay.true is not None:
                draw_outline(inset, (overlay.true.left, overlay.true.right)[index], TRUE_BGR, 1, scale)
            draw_outline(
                inset, (overlay.recognised.left, overlay.recognised.right)[index], RECOGNISED_BGR, 2, scale
            )
            _label(inset, name, (6, 18), 0.5)
            insets.append(inset)
        column = np.vstack(insets)
        colour = (80, 220, 80) if overlay.good else (0, 140, 255)
        for row, line in enumerate(reversed(overlay.caption)):
            _label(column, line, (6, 2 * INSET_SIZE[1] - 10 - 20 * row), 0.45, colour)
        self._column = column

    def tick(self, phase: str = "") -> None:
        """Adds a frame if one is due at the current simulated time.

        Args:
            phase: name of the loop's current phase, written on the frame.
        """
        if self.world.time + 1e-9 < self.next_time:
            return
        self.next_time += self.period
        overview = overview_image(self.world, self.camera, self.pose)  # the cell's light and shadows
        _label(overview, f"t = {self.world.time:5.2f} s", (10, OVERVIEW_SIZE[1] - 14), 0.7)
        if phase:
            _label(overview, phase.upper(), (10, 30), 0.9)
        column = self._column
        if column is None:
            column = self._raw_column()
        self.writer.append_data(np.hstack([overview, column])[:, :, ::-1])
        self.frames += 1

    def close(self) -> None:
        self.writer.close()

    def _raw_column(self) -> npt.NDArray[np.uint8]:
        capture = self.cell.last_capture
        if capture is None:
            column = np.zeros((2 * INSET_SIZE[1], INSET_SIZE[0], 3), np.uint8)
            _label(column, "cameras: no capture yet", (10, INSET_SIZE[1]), 0.5)
            return column
        return np.vstack([_inset(capture.left_bgr), _inset(capture.right_bgr)])


def _inset(image: npt.NDArray[np.uint8]) -> npt.NDArray[np.uint8]:
    small = cv2.resize(image, INSET_SIZE, interpolation=cv2.INTER_AREA)
    cv2.rectangle(small, (0, 0), (INSET_SIZE[0] - 1, INSET_SIZE[1] - 1), WHITE, 1)
    return np.ascontiguousarray(small, dtype=np.uint8)


def _label(
    image: npt.NDArray[np.uint8],
    text: str,
    origin: tuple[int, int],
    scale: float,
    colour: tuple[int, int, int] = WHITE,
) -> None:
    """Text on a dark box, readable on any background (`origin`: the text's bottom left)."""
    (width, height), baseline = cv2.getTextSize(text, FONT, scale, 1)
    x, y = origin
    cv2.rectangle(image, (x - 3, y - height - 3), (x + width + 3, y + baseline + 1), BLACK, cv2.FILLED)
    cv2.putText(image, text, origin, FONT, scale, colour, 1, cv2.LINE_AA)


__all__ = ["EpisodeVideo", "VisionOverlay"]
