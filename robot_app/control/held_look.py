"""What hangs from the hand: the lifted cloth's colours, seen against table the survey saw free.

The wrist's load cell says how much was lifted, not what: two cloths of about one weight
(most catalogue cloths weigh 18-32 g, the check's tolerance is 30 % + 3 g) weigh the same.
The hand cameras do see the lifted cloth: it hangs 0.05-0.4 m under the fingers, in the
lower part of both images (the cameras sit behind the TCP). Over the pile it was lifted
from, its colours cannot be read apart from the pile's (session 22: stereo gives no usable
depth there). Over table the survey saw *free*, they can: the table is a plane, so the
survey's image of it, mapped onto the hand's view by the plane's homography
(`table_homography`), says which pixels would show the green sheet if nothing hung
there. A pixel that the survey predicts sheet and that is not sheet now is the lifted
cloth (`held_mask`); a cloth moved since the survey onto that table would count too,
which is why the hand goes where the survey saw the most free sheet (`hover_offsets`).

The job uses it where the weight cannot tell two cloths apart (`table_lost`: a blind lift
at a lost cloth's region where a cloth of another box may lie hidden under it): the lift
goes on only if what hangs shows the meant cloth's colours and hardly any of the other
cloth's own (`held_verdict`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt
from pydantic import Field

from robot_app.arrays import FloatArray
from robot_app.config import StrictModel

Mask = npt.NDArray[np.bool_]
GRID_PX = 8  # hover candidates are scored on every GRID_PX-th pixel of the hand's view


class HeldLookSettings(StrictModel):
    """The look at a lifted cloth (the `clear.lost.held_look` section). Lengths [m].

    Attributes:
        enabled: look where the weight cannot tell (else such a region is not picked).
        reach: the hand moves at most this far from the lift point to look [m].
        step: hover points on a grid of this spacing [m].
        min_free: share of the hand's view the survey saw as free sheet (what the look can
            read against) needed at the hover point [-].
        min_pixels: held pixels (against predicted sheet) needed to read its colours.
        meant_share: share of them in the meant cloth's main colours needed [-].
        doubt_share: share of them in another cloth's own colours (none of the meant
            cloth's) from which the lift is taken for that cloth too [-].
        opening: the held mask is opened by this square [px] (the plane mapping's
            misfit at cloth edges, noise).
    """

    enabled: bool = True
    reach: float = Field(0.3, gt=0.0, le=0.6)
    step: float = Field(0.05, gt=0.0)
    min_free: float = Field(0.5, ge=0.0, le=1.0)
    min_pixels: int = Field(300, ge=1)
    meant_share: float = Field(0.4, ge=0.0, le=1.0)
    doubt_share: float = Field(0.08, ge=0.0, le=1.0)
    opening: int = Field(5, ge=1, le=31)


@dataclass(frozen=True)
class HeldColours:
    """What the look saw hang.

    Attributes:
        pixels: held pixels read (against predicted free sheet).
        meant: share of them in the meant cloth's main colours.
        own: other cloth -> share of them in its main colours and none of the meant cloth's.
    """

    pixels: int
    meant: float
    own: Mapping[str, float]


def project_to_image(
    camera_matrix: FloatArray, camera_to_world: FloatArray, points_world: FloatArray
) -> FloatArray:
    """(N, 2) pixels of world points (N, 3) [m] in an ideal pinhole camera at `camera_to_world`."""
    T = np.asarray(camera_to_world, dtype=float)
    local = (np.asarray(points_world, dtype=float) - T[:3, 3]) @ T[:3, :3]
    uvw = local @ np.asarray(camera_matrix, dtype=float).T
    return np.asarray(uvw[:, :2] / uvw[:, 2:3], dtype=float)


def table_points(
    camera_matrix: FloatArray, camera_to_world: FloatArray, pixels: FloatArray, table_z: float
) -> FloatArray:
    """(N, 3) where the rays through (N, 2) pixels meet the plane z = `table_z` [m]."""
    T = np.asarray(camera_to_world, dtype=float)
    px = np.asarray(pixels, dtype=float)
    rays = np.linalg.solve(np.asarray(camera_matrix, dtype=float), np.vstack([px.T, np.ones(len(px))]))
    directions = T[:3, :3] @ rays
    scale = (table_z - T[2, 3]) / directions[2]
    return np.asarray((T[:3, 3:4] + scale * directions).T, dtype=float)


def table_homography(
    camera_matrix: FloatArray,
    from_camera_to_world: FloatArray,
    to_camera_to_world: FloatArray,
    table_z: float,
    image_size: tuple[int, int],
) -> FloatArray:
    """(3, 3) the mapping of the table plane's pixels from one view of a camera to another
    (both looking down at it; `image_size` (width, height) [px] of the second)."""
    width, height = image_size
    corners = np.array([[0.0, 0.0], [width - 1.0, 0.0], [width - 1.0, height - 1.0], [0.0, height - 1.0]])
    world = table_points(camera_matrix, to_camera_to_world, corners, table_z)
    seen = project_to_image(camera_matrix, from_camera_to_world, world)
    return np.asarray(
        cv2.getPerspectiveTransform(seen.astype(np.float32), corners.astype(np.float32)), dtype=float
    )


def free_in_view(survey_sheet: Mask, homography: FloatArray, image_size: tuple[int, int]) -> Mask:
    """(H, W) pixels of the second view where the survey saw free sheet (`table_homography`
    from the survey's view); False where it saw anything else or saw nothing."""
    width, height = image_size
    mapped = cv2.warpPerspective(
        np.asarray(survey_sheet, dtype=np.uint8),
        np.asarray(homography, dtype=np.float64),
        (width, height),
        flags=cv2.INTER_NEAREST,
        borderMode=cv2.BORDER_CONSTANT,
        borderValue=0,
    )
    return np.asarray(mapped > 0, dtype=bool)


def held_mask(sheet_now: Mask, free_before: Mask, opening: int) -> Mask:
    """Pixels that are not sheet now where the survey saw free sheet, opened by an
    `opening`-pixel square: what hangs between the cameras and that table."""
    seen = np.asarray(~np.asarray(sheet_now, dtype=bool) & np.asarray(free_before, dtype=bool), np.uint8)
    opened = cv2.morphologyEx(seen, cv2.MORPH_OPEN, np.ones((opening, opening), np.uint8))
    return np.asarray(opened > 0, dtype=bool)


def hover_offsets(
    survey_sheet: Mask,
    camera_matrix: FloatArray,
    survey_camera_to_world: FloatArray,
    camera_to_world: FloatArray,
    table_z: float,
    settings: HeldLookSettings,
) -> list[tuple[FloatArray, float]]:
    """Horizontal moves ((2,) [m], within `reach`) of the hand, each with the share of the
    moved view the survey saw as free sheet, those of at least `min_free` only, the freest
    first (nearer first among equals)."""
    height, width = survey_sheet.shape
    v, u = np.mgrid[GRID_PX // 2 : height : GRID_PX, GRID_PX // 2 : width : GRID_PX]
    pixels = np.column_stack([u.ravel(), v.ravel()]).astype(float)
    n = int(np.floor(settings.reach / settings.step))
    steps = np.arange(-n, n + 1) * settings.step
    scored: list[tuple[FloatArray, float]] = []
    for dx in steps:
        for dy in steps:
            shift = np.array([dx, dy])
            if float(np.hypot(dx, dy)) > settings.reach + 1e-9:
                continue
            moved = np.array(camera_to_world, dtype=float)
            moved[:2, 3] += shift
            seen = project_to_image(
                camera_matrix, survey_camera_to_world, table_points(camera_matrix, moved, pixels, table_z)
            )
            iu, iv = np.rint(seen[:, 0]).astype(int), np.rint(seen[:, 1]).astype(int)
            inside = (iu >= 0) & (iu < width) & (iv >= 0) & (iv < height)
            free = np.zeros(len(pixels), dtype=bool)
            free[inside] = survey_sheet[iv[inside], iu[inside]]
            share = float(free.mean())
            if share >= settings.min_free:
                scored.append((shift, share))
    scored.sort(key=lambda item: (-round(item[1], 2), float(np.hypot(*item[0]))))
    return scored


def held_colours(
    codes: npt.ArrayLike,
    held: Mask,
    meant: npt.ArrayLike,
    others: Mapping[str, npt.ArrayLike],
) -> HeldColours:
    """The held pixels' shares: in the meant cloth's palette (`meant`, (H, W) bools of the
    image's pixels in it) and, per other cloth (the same, in its palette), in its palette
    and not the meant one's."""
    held = np.asarray(held, dtype=bool)
    count = int(held.sum())
    mine = np.asarray(meant, dtype=bool)[held]
    if count == 0:
        return HeldColours(0, 0.0, {name: 0.0 for name in others})
    own = {
        name: float(np.mean(np.asarray(theirs, dtype=bool)[held] & ~mine)) for name, theirs in others.items()
    }
    return HeldColours(count, float(np.mean(mine)), own)


def held_verdict(seen: HeldColours, settings: HeldLookSettings) -> tuple[bool, str]:
    """(the lift holds the meant cloth alone as far as its colours tell, what was seen)."""
    if seen.pixels < settings.min_pixels:
        return False, f"too little of it seen against free table ({seen.pixels} px)"
    others = ", ".join(f"{name}'s own {share:.0%}" for name, share in seen.own.items())
    what = f"{seen.pixels} px seen hanging: {seen.meant:.0%} in its colours" + (
        f", {others}" if others else ""
    )
    if seen.meant < settings.meant_share:
        return False, what
    if any(share >= settings.doubt_share for share in seen.own.values()):
        return False, what
    return True, what


__all__ = [
    "HeldColours",
    "HeldLookSettings",
    "free_in_view",
    "held_colours",
    "held_mask",
    "held_verdict",
    "hover_offsets",
    "project_to_image",
    "table_homography",
    "table_points",
]
