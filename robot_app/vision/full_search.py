"""Full search (paper Sec. IV, Fig. 13): the fitness over an x-y grid of model positions.

The paper verifies the GA against "scanning all possible pixels in the entire searching
area": the fitness of the model placed at every point of an x-y grid (1 mm step) in the
right camera frame, at a fixed depth and orientation. The result is the mountain range
of Fig. 13 on which the GA's individuals should sit at the peaks. Optionally every grid
point is also tried at several yaws and the best kept.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import NamedTuple, Protocol

import cv2
import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray
from robot_app.geometry import (
    is_rotation,
    make_transform,
    rotation_about_z,
)


class PoseEvaluator(Protocol):
    """Anything that scores poses ^CR T_M, like `FitnessEvaluator`."""

    def evaluate(self, transforms_model_to_right: npt.ArrayLike) -> FloatArray: ...


@dataclass(frozen=True)
class FullSearchResult:
    """The fitness distribution over the x-y plane of the right camera.

    Attributes:
        xs: (nx,) grid x positions [m] in Σ_CR.
        ys: (ny,) grid y positions [m] in Σ_CR.
        fitness: (ny, nx) fitness at each grid point (best over yaws if yaws were searched).
        depth: the z of every pose [m].
        rotation: (3, 3) the orientation searched (the best yaw's, if yaws were searched).
        best_transform: (4, 4) the pose ^CR T_M with the highest fitness.
        best_fitness: its fitness.
        evaluations: number of poses evaluated.
        best_yaws: (ny, nx) the best yaw [rad] at each grid point, or None without yaws.
    """

    xs: FloatArray
    ys: FloatArray
    fitness: FloatArray
    depth: float
    rotation: FloatArray
    best_transform: FloatArray
    best_fitness: float
    evaluations: int
    best_yaws: FloatArray | None = None

    @property
    def step(self) -> float:
        """Grid step [m] (x)."""
        return float(self.xs[1] - self.xs[0]) if len(self.xs) > 1 else 0.0


class FitnessPeak(NamedTuple):
    """A local maximum of the fitness distribution: position [m] in Σ_CR and its fitness."""

    x: float
    y: float
    fitness: float


def full_search(
    evaluator: PoseEvaluator,
    x_range: tuple[float, float] = (-0.255, 0.255),
    y_range: tuple[float, float] = (-0.195, 0.195),
    step: float = 0.001,
    depth: float = 0.58,
    rotation: npt.ArrayLike | None = None,
    yaws: Sequence[float] | None = None,
    batch: int = 8192,
    progress: Callable[[int, int], None] | None = None,
) -> FullSearchResult:
    """Evaluates the fitness of the model at every point of an x-y grid.

    Args:
        evaluator: scores (P, 4, 4) poses, e.g. a `FitnessEvaluator` after `update`.
        x_range, y_range: grid bounds in the right camera frame [m], both included.
        step: grid step [m] (paper: 1 mm).
        depth: z of the model origin in the right camera frame [m].
        rotation: (3, 3) orientation of Σ_M in Σ_CR (default identity: the photo's
            orientation seen from straight above).
        yaws: if given, each grid point is also tried rotated by each of these yaws
            [rad] about the camera z axis (Rz(yaw) @ rotation) and the best is kept.
        batch: poses per call to the evaluator.
        progress: called as progress(done, total) after each batch.

    Returns:
        The distribution and its best pose.

    Raises:
        ValueError: a bad argument (not a rotation, a step or depth <= 0, an empty yaw
            list, a range with high < low); the commands check the user's values first.
    """
    R = np.eye(3) if rotation is None else np.asarray(rotation, dtype=float)
    if R.shape != (3, 3) or not is_rotation(R, tol=1e-6):
        raise ValueError("rotation must be a 3x3 rotation matrix (R^T R = I, det = +1)")
    if not step > 0 or not depth > 0 or batch < 1:
        raise ValueError(f"step and depth must be > 0 [m] and batch >= 1, got {step}, {depth}, {batch}")
    xs, ys = _axis(x_range, step, "x_range"), _axis(y_range, step, "y_range")
    yaw_list = [0.0] if yaws is None else [float(a) for a in yaws]
    if not yaw_list:
        raise ValueError("yaws must hold at least one angle [rad] (or be None)")
    gx, gy = np.meshgrid(xs, ys)
    translations = np.column_stack([gx.ravel(), gy.ravel(), np.full(gx.size, depth)])
    best = np.full(gx.size, -np.inf)
    best_yaw = np.zeros(gx.size)
    total, done = gx.size * len(yaw_list), 0
    poses = np.zeros((min(batch, gx.size), 4, 4))
    poses[:, 3, 3] = 1.0
    for yaw in yaw_list:
        poses[:, :3, :3] = rotation_about_z(yaw) @ R if yaws is not None else R
        for start in range(0, gx.size, batch):
            stop = min(start + batch, gx.size)
            chunk = poses[: stop - start]
            chunk[:, :3, 3] = translations[start:stop]
            values = np.asarray(evaluator.evaluate(chunk), dtype=float)
            better = values > best[start:stop]
            best[start:stop][better] = values[better]
            best_yaw[start:stop][better] = yaw
            done += stop - start
            if progress is not None:
                progress(done, total)
    k = int(np.argmax(best))
    best_rotation = rotation_about_z(best_yaw[k]) @ R if yaws is not None else R
    return FullSearchResult(
        xs=xs,
        ys=ys,
        fitness=best.reshape(gx.shape),
        depth=float(depth),
        rotation=best_rotation,
        best_transform=make_transform(best_rotation, translations[k]),
        best_fitness=float(best[k]),
        evaluations=total,
        best_yaws=best_yaw.reshape(gx.shape) if yaws is not None else None,
    )


def find_peaks(result: FullSearchResult, min_separation: float, min_fitness: float) -> list[FitnessPeak]:
    """Local maxima of the distribution, highest first, at least `min_separation` apart.

    Args:
        result: a full search.
        min_separation: smallest distance between two reported peaks [m].
        min_fitness: peaks below this fitness are ignored.

    Returns:
        The peaks (paper Fig. 13 e-f: one per cloth in a two-cloth scene).

    Raises:
        ValueError: `min_separation` <= 0 (the settings' `peak_separation` is validated > 0).
    """
    if not min_separation > 0:
        raise ValueError(f"min_separation must be > 0 [m], got {min_separation}")
    radius = max(1, int(np.ceil(min_separation / max(result.step, 1e-12))))
    fitness = np.nan_to_num(result.fitness.astype(np.float32), nan=-np.inf)
    kernel = np.ones((2 * radius + 1, 2 * radius + 1), np.uint8)
    dilated = cv2.dilate(fitness, kernel, borderType=cv2.BORDER_REPLICATE)
    rows, cols = np.nonzero((fitness >= dilated) & (fitness >= min_fitness))
    order = np.argsort(-fitness[rows, cols], kind="stable")
    peaks: list[FitnessPeak] = []
    for i in order:
        x, y = float(result.xs[cols[i]]), float(result.ys[rows[i]])
        if all(np.hypot(x - p.x, y - p.y) >= min_separation for p in peaks):
            peaks.append(FitnessPeak(x, y, float(result.fitness[rows[i], cols[i]])))
    return peaks


def _axis(bounds: tuple[float, float], step: float, name: str) -> FloatArray:
    lo, hi = (float(v) for v in bounds)
    if not hi >= lo:
        raise ValueError(f"{name} must be (low, high) with low <= high [m], got {bounds}")
    return np.asarray(lo + step * np.arange(int(np.floor((hi - lo) / step + 1e-9)) + 1), dtype=float)


__all__ = ["FitnessPeak", "FullSearchResult", "PoseEvaluator", "find_peaks", "full_search"]
