"""Pictures of the recognition core: the model preview (Fig. 4) and fitness maps (Fig. 13).

matplotlib is imported lazily with the Agg backend, so importing this module is cheap
and nothing here ever needs a display.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import cv2
import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray
from robot_app.errors import InputError, ModelError
from robot_app.vision.camera import PinholeCamera
from robot_app.vision.cloth_model import ClothModel
from robot_app.vision.full_search import FullSearchResult
from robot_app.vision.hue import DARK, HUE_RANGE

S_IN_BGR = (0, 230, 255)  # yellow dots
S_OUT_BGR = (255, 0, 255)  # magenta dots


def model_points_in_photo(model: ClothModel) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Pixels of S_in, S_out and the grasp point in the model's photo, each (N, 2) [px].

    Raises:
        ModelError: the model does not record the photo's camera (not made by make_model).
    """
    try:
        data = model.metadata["model_camera"]
        camera = PinholeCamera(data["camera_matrix"], tuple(data["image_size"]), data["dist_coeffs"])
        distance = float(data["distance"])
        origin = np.array([*model.metadata["origin_in_photo_plane"], distance])
    except (KeyError, TypeError, ValueError) as err:
        raise ModelError(f"model '{model.name}' does not record its photo's camera: {err}") from err
    return tuple(  # type: ignore[return-value]
        camera.project(np.atleast_2d(points) + origin)
        for points in (model.points_in, model.points_out, model.grasp_point)
    )


def _code_bgr(code: int) -> tuple[int, int, int]:
    """The BGR colour a model colour code is drawn in: its hue at full saturation, or the tone."""
    if code >= HUE_RANGE:
        return (60, 60, 60) if code == DARK else (255, 255, 255)
    hsv = np.array([[[code, 255, 255]]], dtype=np.uint8)
    b, g, r = (int(c) for c in cv2.cvtColor(hsv, cv2.COLOR_HSV2BGR_FULL)[0, 0])
    return (b, g, r)


def save_preview(model: ClothModel, photo_bgr: npt.NDArray[np.uint8], path: str | Path) -> None:
    """Writes a Fig. 4 style PNG: (a) the photo, (b) S_in, (c) S_in and S_out over the photo.

    Args:
        model: a model made from `photo_bgr` by `make_model`.
        photo_bgr: (H, W, 3) uint8, the photo it was made from.
        path: output image file (PNG).
    """
    photo = np.asarray(photo_bgr)
    if photo.ndim != 3 or photo.shape[2] != 3 or photo.dtype != np.uint8:
        raise ValueError(f"photo must be an (H, W, 3) uint8 image, got {photo.shape} {photo.dtype}")
    pix_in, pix_out, pix_grasp = model_points_in_photo(model)
    radius = max(1, round(min(photo.shape[:2]) / 240))
    s_in = np.zeros_like(photo)
    overlay = (photo * 0.6).astype(np.uint8)
    for (u, v), hue in zip(np.rint(pix_in).astype(int), model.hues_in, strict=True):
        colour = _code_bgr(int(hue))
        cv2.circle(s_in, (u, v), radius, colour, -1)
        cv2.circle(overlay, (u, v), radius, S_IN_BGR, -1)
    for u, v in np.rint(pix_out).astype(int):
        cv2.circle(overlay, (u, v), radius, S_OUT_BGR, -1)
    gu, gv = np.rint(pix_grasp[0]).astype(int)
    cv2.drawMarker(overlay, (gu, gv), (255, 255, 255), cv2.MARKER_CROSS, 6 * radius, max(1, radius))
    panels = []
    for label, panel in (("(a) photo", photo), ("(b) S_in (model hue)", s_in), ("(c) S_in + S_out", overlay)):
        panel = panel.copy()
        cv2.putText(panel, label, (8, 24), cv2.FONT_HERSHEY_SIMPLEX, 0.7, (255, 255, 255), 2, cv2.LINE_AA)
        panels.append(panel)
    caption = f"{model.name}: N_in={model.n_in} N_out={model.n_out} H_B={model.background_hue:.0f}"
    canvas = np.hstack(panels)
    cv2.putText(canvas, caption, (8, canvas.shape[0] - 10), cv2.FONT_HERSHEY_SIMPLEX, 0.6, (255, 255, 255), 1)
    if not cv2.imwrite(str(path), canvas):
        raise InputError(f"could not write the preview image {path} (folder missing or not an image name)")


def plot_full_search(
    result: FullSearchResult,
    path_2d: str | Path,
    path_3d: str | Path,
    individuals: npt.ArrayLike | None = None,
    title: str = "",
    individual_fitness: npt.ArrayLike | None = None,
) -> None:
    """Fig. 13: the fitness distribution as a 2D map and a 3D surface, GA individuals on top.

    Args:
        result: a full search.
        path_2d: output PNG of the map.
        path_3d: output PNG of the surface.
        individuals: (P, 4, 4) GA poses ^CR T_M drawn as black points at their (x, y).
        title: figure title.
        individual_fitness: (P,) their fitness (height in the 3D view); default: the
            distribution's value under each point.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    xs_mm, ys_mm = result.xs * 1e3, result.ys * 1e3
    points = _individual_points(result, individuals, individual_fitness)
    fig, ax = plt.subplots(figsize=(7, 5.2))
    extent = (xs_mm[0], xs_mm[-1], ys_mm[-1], ys_mm[0])  # y down, as in the camera image
    image = ax.imshow(result.fitness, extent=extent, cmap="viridis", aspect="equal", interpolation="nearest")
    fig.colorbar(image, ax=ax, label="fitness")
    if points is not None:
        ax.scatter(points[:, 0], points[:, 1], s=8, c="black", label="GA individuals")
        ax.legend(loc="upper right")
    _label(ax, title or "fitness distribution", f"depth {result.depth * 1e3:.0f} mm")
    fig.savefig(path_2d, dpi=120, bbox_inches="tight")
    plt.close(fig)

    stride = max(1, int(np.ceil(max(result.fitness.shape) / 200)))  # at most ~200 x 200 facets
    gx, gy = np.meshgrid(xs_mm[::stride], ys_mm[::stride])
    fig = plt.figure(figsize=(7, 5.5))
    ax3: Any = fig.add_subplot(projection="3d")
    fitness = result.fitness[::stride, ::stride]
    ax3.plot_surface(gx, gy, fitness, cmap="viridis", linewidth=0, antialiased=False, alpha=0.85)
    if points is not None:
        ax3.scatter(points[:, 0], points[:, 1], points[:, 2], s=8, c="black", depthshade=False)
    ax3.set_zlabel("fitness")
    ax3.invert_yaxis()
    _label(ax3, title or "fitness distribution", f"depth {result.depth * 1e3:.0f} mm")
    fig.savefig(path_3d, dpi=120, bbox_inches="tight")
    plt.close(fig)


def _individual_points(
    result: FullSearchResult, individuals: npt.ArrayLike | None, fitness: npt.ArrayLike | None
) -> FloatArray | None:
    """(P, 3) x [mm], y [mm], fitness of the individuals, or None."""
    if individuals is None:
        return None
    T = np.asarray(individuals, dtype=float).reshape(-1, 4, 4)
    x, y = T[:, 0, 3], T[:, 1, 3]
    if fitness is None:
        col = np.clip(np.rint((x - result.xs[0]) / max(result.step, 1e-12)), 0, len(result.xs) - 1)
        row = np.clip(np.rint((y - result.ys[0]) / max(result.step, 1e-12)), 0, len(result.ys) - 1)
        z = result.fitness[row.astype(int), col.astype(int)]
    else:
        z = np.asarray(fitness, dtype=float).reshape(-1)
        if z.shape != x.shape:
            raise ValueError(f"individual_fitness needs one value per individual ({len(x)}), got {z.shape}")
    return np.column_stack([x * 1e3, y * 1e3, z])


def _label(ax: Any, title: str, subtitle: str) -> None:
    ax.set_xlabel("x [mm] (right camera)")
    ax.set_ylabel("y [mm] (right camera)")
    ax.set_title(f"{title}\n{subtitle}")


__all__ = ["model_points_in_photo", "plot_full_search", "save_preview"]
