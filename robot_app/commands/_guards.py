"""Checks the commands make before the work: images, model size, search grids, simulated cameras.

Each turns an input that would fail late, run for hours or exhaust memory into a one-line
error (or a warning for an input that is usable but suspicious) before anything is
allocated or written. The limits and estimates are in `robot_app.resources`.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from robot_app.console import warn_input
from robot_app.errors import InputError
from robot_app.input_files import read_image
from robot_app.resources import (
    BYTES_PER_IMAGE_PIXEL,
    BYTES_PER_INDIVIDUAL,
    BYTES_PER_RENDERED_PIXEL,
    MAX_FULL_SEARCH_EVALUATIONS,
    MAX_MODEL_POINTS,
    ResourceLimits,
    format_duration,
    full_search_estimate,
    grid_cells,
    model_make_estimate,
)

if TYPE_CHECKING:
    from robot_app.sim import WorldConfig
    from robot_app.vision.camera import ModelCamera
    from robot_app.vision.photo_model import ClothModel, ModelSettings
    from robot_app.vision.recognizer import RecognitionSettings

POINT_EVALUATIONS_PER_S = 3.2e8
"""Model points scored per second by the fitness kernel on one core (measured: a full
search of 7.2 M poses of a 748-point model took 17 s)."""
TYPICAL_MODEL_POINTS = 750
"""S_in + S_out of cloth No.3 photographed at 0.4 m with the default settings."""


def check_stereo_images(left: Path, right: Path, limits: ResourceLimits) -> None:
    """Both images readable and within the memory limit; a warning if they have no colour.

    Raises:
        InputError: a file missing, a folder, or not an image.
        ResourceError: an image too large for the memory limit.
    """
    images = [
        read_image(path, key=key, limits=limits) for path, key in ((left, "--left"), (right, "--right"))
    ]
    gray = [str(image.info.path) for image in images if image.grayscale]
    if gray:
        warn_input(
            f"{' and '.join(gray)} {'is' if len(gray) == 1 else 'are'} grayscale: the hue fitness has "
            "no hue to match there, so the cloth will probably not be found; use the cameras' colour images",
            path=gray[0],
        )


def read_colour_photo(path: Path, what: str, key: str, limits: ResourceLimits) -> npt.NDArray[np.uint8]:
    """Reads a model photo (or background photo), which must have colour: its hue is the model.

    Returns:
        The photo, (H, W, 3) uint8 BGR.

    Raises:
        InputError: the photo is grayscale, unreadable or missing.
        ResourceError: too large for the memory limit.
    """
    image = read_image(path, key=key, limits=limits)
    if image.grayscale:
        raise InputError(
            f"{what} {path} is a grayscale image: a cloth model needs a colour photo "
            "(the cloth's hues against the green sheet)",
            path=path,
            key=key,
            expected="a colour photo",
        )
    return image.bgr


def check_model_size(model: ClothModel, source: str, limits: ResourceLimits) -> None:
    """A model's point count, which sets the time of every fitness evaluation, within the limit.

    Raises:
        ResourceError: more than `MAX_MODEL_POINTS` points without --allow-large.
    """
    points = model.n_in + model.n_out
    limits.check_count(
        points,
        MAX_MODEL_POINTS,
        key=source,
        value=f"'{model.name}'",
        what="model points",
        cost=f"each fitness evaluation ~{points / TYPICAL_MODEL_POINTS:.0f}x slower than with a "
        f"{TYPICAL_MODEL_POINTS}-point cloth",
    )


def check_recognition_settings(settings: RecognitionSettings, limits: ResourceLimits) -> None:
    """The GA's population within the memory limit."""
    limits.check_memory(
        settings.propose.ga.population * BYTES_PER_INDIVIDUAL,
        key="propose.ga.population",
        value=settings.propose.ga.population,
        what="a GA population of that size",
    )


def check_full_search(
    settings: RecognitionSettings, step: float, yaws: int, model_points: int, limits: ResourceLimits
) -> None:
    """The full-search grid within the memory limit and the pose count limit.

    Args:
        settings: its bounds give the grid's extent.
        step: the grid step [m].
        yaws: the yaws tried at each grid point.
        model_points: the model's S_in + S_out points (time per pose).
        limits: the limits.
    """
    bounds = settings.propose.bounds
    _cells, evaluations, memory = full_search_estimate(bounds.x, bounds.y, step, yaws)
    nx, ny = grid_cells(*bounds.x, step), grid_cells(*bounds.y, step)
    limits.check_memory(memory, key="--step", value=step, what=f"a {nx:,} x {ny:,} grid")
    seconds = evaluations * model_points / POINT_EVALUATIONS_PER_S
    limits.check_count(
        evaluations,
        MAX_FULL_SEARCH_EVALUATIONS,
        key="--step",
        value=f"{step} ({yaws} yaws)",
        what="poses to evaluate",
        cost=f"about {format_duration(seconds)}",
    )


def check_model_making(
    model_camera: ModelCamera, camera_path: Path, settings: ModelSettings, limits: ResourceLimits
) -> None:
    """The sampling of the photo plane (set by the camera's distance) within the memory limit."""
    camera = model_camera.camera
    fx, fy = float(camera.camera_matrix[0, 0]), float(camera.camera_matrix[1, 1])
    reach = settings.band_gap + settings.band_width + 2 * settings.point_spacing
    memory, _ = model_make_estimate(
        camera.image_size, (fx, fy), model_camera.distance, settings.point_spacing, reach
    )
    width = camera.width * model_camera.distance / fx
    height = camera.height * model_camera.distance / fy
    limits.check_memory(
        memory,
        key=f"{camera_path}: distance",
        value=f"{model_camera.distance:g} m",
        what=f"sampling a {width:.3g} x {height:.3g} m photo plane every {settings.point_spacing} m "
        "(is the distance in metres?)",
    )


def check_made_model(
    model: ClothModel, model_camera: ModelCamera, camera_path: Path, limits: ResourceLimits
) -> None:
    """A freshly made model's size within the point limit; a warning if its size is implausible."""
    points = model.n_in + model.n_out
    limits.check_count(
        points,
        MAX_MODEL_POINTS,
        key=f"{camera_path}: distance",
        value=f"{model_camera.distance:g} m",
        what="model points",
        cost=f"a cloth of {model.extent[0]:.2f} x {model.extent[1]:.2f} m; each fitness evaluation "
        f"~{points / TYPICAL_MODEL_POINTS:.0f}x slower than with a {TYPICAL_MODEL_POINTS}-point cloth; "
        "is the distance in metres?",
    )
    largest, smallest = max(model.extent), min(model.extent)
    if largest > 2.0 or smallest < 0.01:
        warn_input(
            f"the cloth measures {model.extent[0] * 1e3:.0f} x {model.extent[1] * 1e3:.0f} mm at the "
            f"camera file's distance {model_camera.distance:g} m; is the distance right (in metres)?",
            path=camera_path,
            key="distance",
        )


def check_world_cameras(world: WorldConfig, limits: ResourceLimits, prefix: str = "world") -> None:
    """The simulated cameras' image sizes within the memory limit (hand pair and station)."""
    for key, size, images in (
        (f"{prefix}.cameras.image_size", world.cameras.image_size, 2),
        (f"{prefix}.station.image_size", world.station.image_size, 1),
    ):
        pixels = int(size[0]) * int(size[1])
        limits.check_memory(
            images * pixels * (BYTES_PER_RENDERED_PIXEL + BYTES_PER_IMAGE_PIXEL),
            key=key,
            value=list(size),
            what=f"rendering and recognising {images} image(s) of that size",
        )


def check_display(gui: bool) -> None:
    """pybullet's GUI needs a display; without one it would print and end the process."""
    if gui and sys.platform.startswith("linux") and not os.environ.get("DISPLAY"):
        raise InputError("--gui needs a display (DISPLAY is not set); run without --gui", key="--gui")


__all__ = [
    "check_display",
    "check_full_search",
    "check_made_model",
    "check_model_making",
    "check_model_size",
    "check_recognition_settings",
    "check_stereo_images",
    "check_world_cameras",
    "read_colour_photo",
]
