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

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import cv2
import numpy as np
import numpy.typing as npt
from pydantic import Field

from robot_app.arrays import FloatArray
from robot_app.config import StrictModel
from robot_app.control.colour_fit import ColourFit, colour_shares
from robot_app.errors import IKError
from robot_app.vision import ClothModel
from robot_app.vision.identify import codes_and_sheet
from robot_app.vision.regions import dilated, in_palette, main_codes

if TYPE_CHECKING:
    from robot_app.control.cell import StereoCapture
    from robot_app.control.table_clearer import TableClearer

Mask = npt.NDArray[np.bool_]
GRID_PX = 8  # hover candidates are scored on every GRID_PX-th pixel of the hand's view
BEYOND_INSET = 0.02  # [m] table points the survey did not see count as free this far inside the sheet
ALL_COLOURS = 0.98  # a cloth's colours that cover this share of its S_in: "any of its colours"


class HeldLookSettings(StrictModel):
    """The look at a lifted cloth (the `clear.held_look` section). Lengths [m].

    Attributes:
        enabled: look at a blind lift where the weight cannot tell it from a hidden cloth
            of another box (`table_lost`; off: such a region is not picked).
        name_companion: look at a double pick whose other cloth neither the survey nor
            memory names, and name it by its own colours seen hanging (two looks from
            points `confirm_shift` apart, so that a cloth lying on the table, dragged by
            the lift where the survey saw sheet, is not taken for it).
        reach: the hand moves at most this far from the lift point to look [m].
        step: hover points on a grid of this spacing [m].
        min_free: share of the hand's view behind the held cloth (`hanging_region`) the
            survey saw as free sheet (what the look can read against) needed at the hover
            point [-].
        min_pixels: held pixels (against predicted sheet) needed to read its colours.
        meant_share: share of them in the meant cloth's main colours needed [-].
        doubt_share: share of them in another cloth's own colours (none of the meant
            cloth's) from which the lift is taken for that cloth too [-].
        margin: the meant cloth's colour fit of them (`colour_fit.ColourFit.score`: share
            x mix x lightness, as a lost cloth's region is named) must be ahead of every
            doubted cloth's by this, else the lift may be that one [-]. Two cloths of shared
            colours, one's own too few to show (a white print's red motifs, 11 % of it), are
            told apart by their mix (held-out episode 315, session 26: No.6, 73 % white and
            16 % purple, held for No.7, 77 % purple and 23 % white, showed 93 % in No.7's
            colours and 6 % in No.6's own, and went into the colours box).
        opening: the held mask is opened by this square [px] (the plane mapping's
            misfit at cloth edges, noise).
        name_share: share of the held pixels in a cloth's own colours (none of the meant
            cloth's) from which it is named as hanging too [-].
        name_margin: ... at least this much more than any other cloth's share [-].
        name_instead: a wrong lift (the meant cloth still in its place) is looked at and
            named by the best colour fit among the cloths whose weight is the reading, if
            the fit reaches this and no cloth of another box comes within `margin` of it
            or shows `doubt_share` of its own colours; it then goes into the meant cloth's
            box as that cloth (`TableClearer._held_instead`); None: put back unlooked [-].
        confirm_shift: the second look's point this far at least from the first [m].
        persist_px: what hangs is taken where both looks see it within this [px] (it
            swings a little; a cloth lying on the table moves some 35 px per 5 cm).
        hang_radius, hang_depth: where a held cloth can hang: within this of the TCP's
            vertical, down to this under it [m] (`hanging_region`); the hover points are
            scored by the free table behind that part of the view.
    """

    enabled: bool = True
    reach: float = Field(0.3, gt=0.0, le=0.6)
    step: float = Field(0.05, gt=0.0)
    min_free: float = Field(0.5, ge=0.0, le=1.0)
    min_pixels: int = Field(300, ge=1)
    meant_share: float = Field(0.4, ge=0.0, le=1.0)
    doubt_share: float = Field(0.08, ge=0.0, le=1.0)
    margin: float = Field(0.2, ge=0.0, le=1.0)
    opening: int = Field(5, ge=1, le=31)
    name_companion: bool = True
    name_share: float = Field(0.1, gt=0.0, le=1.0)
    name_margin: float = Field(0.1, ge=0.0, le=1.0)
    name_instead: float | None = Field(0.5, gt=0.0, le=1.0)
    confirm_shift: float = Field(0.05, gt=0.0)
    persist_px: int = Field(9, ge=1, le=41)
    hang_radius: float = Field(0.12, gt=0.0)
    hang_depth: float = Field(0.35, gt=0.05)


@dataclass(frozen=True)
class HeldColours:
    """What the look saw hang.

    Attributes:
        pixels: held pixels read (against predicted free sheet).
        meant: share of them in the meant cloth's main colours.
        own: other cloth -> share of them in its main colours and none of the meant cloth's.
        meant_fit: how they fit the meant cloth's colours, mix and lightness (`colour_fit`);
            None where not measured.
        fits: other cloth -> the same for it.
        shaded: other cloth -> share of them in its main colours or its folds' shade
            (`regions.with_folds`: DARK for a white cloth) and none of the meant cloth's:
            what it may show hanging where the light does not reach it.
    """

    pixels: int
    meant: float
    own: Mapping[str, float]
    meant_fit: ColourFit | None = None
    fits: Mapping[str, ColourFit] = field(default_factory=dict)
    shaded: Mapping[str, float] = field(default_factory=dict)


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


def free_in_view(
    survey_sheet: Mask,
    homography: FloatArray,
    image_size: tuple[int, int],
    beyond: Mask | None = None,
) -> Mask:
    """(H, W) pixels of the second view where the survey saw free sheet (`table_homography`
    from the survey's view); False where it saw anything else; where it saw nothing, the
    second view's `beyond` (None: False)."""
    width, height = image_size

    def mapped(mask: npt.ArrayLike) -> Mask:
        warped = cv2.warpPerspective(
            np.asarray(mask, dtype=np.uint8),
            np.asarray(homography, dtype=np.float64),
            (width, height),
            flags=cv2.INTER_NEAREST,
            borderMode=cv2.BORDER_CONSTANT,
            borderValue=0,
        )
        return np.asarray(warped > 0, dtype=bool)

    free = mapped(survey_sheet)
    if beyond is not None:
        free |= ~mapped(np.ones_like(survey_sheet)) & np.asarray(beyond, dtype=bool)
    return free


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
    hanging: Mask | None = None,
    beyond: Callable[[FloatArray], Mask] | None = None,
) -> list[tuple[FloatArray, float]]:
    """Horizontal moves ((2,) [m], within `reach`) of the hand, each with the share of the
    moved view the survey saw as free sheet (of the view's `hanging` pixels, where what the
    hand holds can be seen: `hanging_region`; None: all; table points the survey did not
    see count as free where `beyond` ((N, 2) [m] -> (N,) bools) says so), those of at
    least `min_free` only, the freest first (nearer first among equals)."""
    height, width = survey_sheet.shape
    v, u = np.mgrid[GRID_PX // 2 : height : GRID_PX, GRID_PX // 2 : width : GRID_PX]
    behind = None if hanging is None else np.asarray(hanging, dtype=bool)[v, u]
    if behind is not None and behind.any():
        u, v = u[behind], v[behind]
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
            on_table = table_points(camera_matrix, moved, pixels, table_z)
            seen = project_to_image(camera_matrix, survey_camera_to_world, on_table)
            iu, iv = np.rint(seen[:, 0]).astype(int), np.rint(seen[:, 1]).astype(int)
            inside = (iu >= 0) & (iu < width) & (iv >= 0) & (iv < height)
            free = np.zeros(len(pixels), dtype=bool)
            free[inside] = survey_sheet[iv[inside], iu[inside]]
            if beyond is not None and not inside.all():
                free[~inside] = beyond(on_table[~inside, :2])
            share = float(free.mean())
            if share >= settings.min_free:
                scored.append((shift, share))
    scored.sort(key=lambda item: (-round(item[1], 2), float(np.hypot(*item[0]))))
    return scored


def hanging_region(
    camera_matrix: FloatArray,
    camera_to_world: FloatArray,
    tcp: FloatArray,
    image_size: tuple[int, int],
    settings: HeldLookSettings,
) -> Mask:
    """(H, W) the pixels of the hand's view where a cloth hanging from the TCP (`tcp`, (3,)
    [m]) can show: the convex hull of a vertical cylinder of `hang_radius` from 0.05 m to
    `hang_depth` under it, in front of the camera."""
    width, height = image_size
    angles = np.linspace(0.0, 2.0 * np.pi, 16, endpoint=False)
    ring = np.column_stack([np.cos(angles), np.sin(angles)]) * settings.hang_radius
    points = [
        np.column_stack([tcp[0] + ring[:, 0], tcp[1] + ring[:, 1], np.full(len(ring), tcp[2] - depth)])
        for depth in (0.05, settings.hang_depth)
    ]
    world = np.vstack(points)
    T = np.asarray(camera_to_world, dtype=float)
    ahead = (world - T[:3, 3]) @ T[:3, :3][:, 2] > 0.02
    mask = np.zeros((height, width), np.uint8)
    if np.count_nonzero(ahead) >= 3:
        pixels = project_to_image(camera_matrix, camera_to_world, world[ahead])
        hull = cv2.convexHull(np.clip(pixels, -1e4, 1e4).astype(np.float32)).astype(np.int32)
        cv2.fillConvexPoly(mask, hull, 1)
    return np.asarray(mask > 0, dtype=bool)


def held_colours(
    held: Mask,
    meant: npt.ArrayLike,
    meant_any: npt.ArrayLike,
    others: Mapping[str, npt.ArrayLike],
) -> HeldColours:
    """The held pixels' shares: in the meant cloth's main colours (`meant`, (H, W) bools of
    the image's pixels in them) and, per other cloth (the same, in its main colours), in
    its colours and in none of the meant cloth's (`meant_any`: nearly all its colours,
    so that a print's small patches do not count as another cloth's)."""
    held = np.asarray(held, dtype=bool)
    count = int(held.sum())
    if count == 0:
        return HeldColours(0, 0.0, {name: 0.0 for name in others})
    mine = np.asarray(meant, dtype=bool)[held]
    any_mine = np.asarray(meant_any, dtype=bool)[held]
    own = {
        name: float(np.mean(np.asarray(theirs, dtype=bool)[held] & ~any_mine))
        for name, theirs in others.items()
    }
    return HeldColours(count, float(np.mean(mine)), own)


def palette_masks(
    codes: npt.ArrayLike, palettes: Mapping[str, npt.ArrayLike], meant: str, hue_threshold: int
) -> dict[str, Mask]:
    """Per cloth, which pixels (`codes`, colour codes) are in its main colours (`palettes`):
    the `meant` cloth's with its folds' shade (`regions.with_folds`: a white cloth hanging
    shows DARK where it turns from the light), every other cloth's without it. A hanging
    cloth's shaded side reads DARK whatever its colour: held-out episode 463 (session 29),
    No.13 and No.15 (violet, colours) came up together, 20-27 % of the held pixels DARK and
    none LIGHT, and every white cloth showed them as its own folds (15-20 %, over
    `doubt_share`), so the pair went back at four lifts. Another cloth's DARK counts only
    where DARK is one of its own main colours (a dark cloth)."""
    return {
        name: in_palette(codes, palette, hue_threshold, folds=name == meant)
        for name, palette in palettes.items()
    }


def hidden_in(cloth: ClothModel, holders: Sequence[ClothModel]) -> bool:
    """Is every main colour of `cloth` among the colours of the `holders` (`ALL_COLOURS` of
    each)? Then a look at what hangs, which counts another cloth only by its own colours
    (`held_colours`), cannot see it hanging with them: the white towel No.17 and linen
    No.18 (main colour LIGHT alone) hide in seven prints of colours that have white in
    them."""
    mine = main_codes(cloth)
    if not len(mine) or not holders:
        return False
    theirs = np.concatenate([main_codes(model, ALL_COLOURS) for model in holders])
    return bool(np.all(np.isin(mine, theirs)))


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
    if seen.meant_fit is not None:
        ahead = seen.meant_fit.score - settings.margin
        fits = ", ".join(f"{name}'s {fit.score:.2f}" for name, fit in seen.fits.items())
        what += f"; its colour fit {seen.meant_fit.score:.2f}" + (f", {fits}" if fits else "")
        if any(fit.score > ahead for fit in seen.fits.values()):
            return False, f"{what} (within {settings.margin:.2f})"
    return True, what


def look_at_held(
    job: TableClearer,
    meant: str,
    others: Sequence[str],
    looks: int = 1,
    fit: bool = False,
    along: Sequence[str] = (),
) -> tuple[HeldColours | None, str]:
    """Moves the lifted cloth over the freest table within reach (`hover_offsets`), looks
    (`looks` = 2: once more from a point `confirm_shift` away, keeping only what both see
    within `persist_px`: what hangs moves with the hand, what lies does not) and returns
    what hangs (`held_colours` for `meant` and `others`) and a note; None where no such
    point is free and reachable. The hand stays at the last look (the transfer or the
    put-back goes on from there); the arm holds for the computation. `fit`: also score what
    hangs by each cloth's colour fit (`HeldColours.meant_fit`, `fits`; `held_verdict` uses them).
    `along`: cloths taken to hang with the meant one (a lift named as several, a double
    pick's named other cloth): their main colours count as the meant cloth's (`meant`,
    and never another cloth's own). Rerun of held-out 807 (session 35): No.10 came up with
    No.2 (turquoise and white stripes, colours); the look for whites that could hang in
    their stead read No.2's white stripes as the never-seen No.6's and No.17's own (9-11 %),
    and the pair went back at every lift. (`meant_fit` stays the meant cloth's alone.)"""
    # table_furniture imports clear_table_records, which imports this module's settings
    from robot_app.control.table_furniture import clear_of_walls

    s = job.settings.held_look
    camera = job.rig.right
    K, size = camera.camera_matrix, (camera.width, camera.height)
    recognizer = job.recognizers[meant]
    threshold = recognizer.settings.fitness.hue_threshold_in
    survey = job.survey_capture
    survey_pose = survey.transform_right_camera_to_world
    _, survey_sheet = codes_and_sheet(recognizer, survey.right_bgr, job.identify_settings)
    here = job.cell.capture()
    cpu = time.process_time()
    tcp = job.motion.tcp_position()
    pose = here.transform_right_camera_to_world
    hanging = hanging_region(K, pose, tcp, size, s)

    def beyond(xy: FloatArray) -> Mask:
        """Table points the survey did not see, taken for free sheet: on the green sheet,
        clear of the boxes (what lies there shows in neither look at the same pixels)."""
        if job.sheet is None:
            return np.zeros(len(xy), dtype=bool)
        return job.sheet.contains(xy, BEYOND_INSET) & clear_of_walls(xy, job.boxes.values(), BEYOND_INSET)

    offsets = hover_offsets(
        survey_sheet, K, survey_pose, pose, job.table_z, s, hanging, beyond if looks > 1 else None
    )
    job.motion.hold(time.process_time() - cpu)
    palettes = {n: main_codes(job.recognizers[n].model) for n in (meant, *others)}
    wide = main_codes(recognizer.model, ALL_COLOURS)
    for name in along:
        palettes[meant] = np.union1d(palettes[meant], main_codes(job.recognizers[name].model))
        wide = np.union1d(wide, main_codes(job.recognizers[name].model, ALL_COLOURS))
    seen_at: list[FloatArray] = []
    views: list[tuple[Mask, dict[str, Mask], Mask, dict[str, Mask]]] = []
    first: StereoCapture | None = None
    for shift, _ in offsets:
        if seen_at and min(float(np.hypot(*(shift - at))) for at in seen_at) < s.confirm_shift:
            continue
        try:
            job.motion.move_tcp([tcp[0] + shift[0], tcp[1] + shift[1], tcp[2]])
        except IKError:
            continue
        job.motion.hold(job.loop_settings.settle_time)
        capture = job.cell.capture()
        first = capture if first is None else first
        cpu = time.process_time()
        codes, sheet = codes_and_sheet(recognizer, capture.right_bgr, job.identify_settings)
        homography = table_homography(
            K, survey_pose, capture.transform_right_camera_to_world, job.table_z, size
        )
        unseen = None
        if looks > 1:  # what lies beyond the survey's view drops out between the two looks
            grid = np.mgrid[0 : size[1], 0 : size[0]]
            pixels = np.column_stack([grid[1].ravel(), grid[0].ravel()]).astype(float)
            on_table = table_points(K, capture.transform_right_camera_to_world, pixels, job.table_z)
            unseen = beyond(on_table[:, :2]).reshape(size[1], size[0])
        held = held_mask(sheet, free_in_view(survey_sheet, homography, size, unseen), s.opening)
        views.append(
            (
                held,
                palette_masks(codes, palettes, meant, threshold),
                in_palette(codes, wide, threshold),
                {n: in_palette(codes, palettes[n], threshold) for n in others},
            )
        )
        job.motion.hold(time.process_time() - cpu)
        seen_at.append(shift)
        if len(views) == looks:
            break
    if len(views) < looks or first is None:
        return None, "no free table within reach to look against"
    held, colours, any_meant, shade = views[0]
    for later_held, later_colours, _, later_shade in views[1:]:
        held = held & dilated(later_held, s.persist_px)
        colours = {n: colours[n] & dilated(later_colours[n] & later_held, s.persist_px) for n in colours}
        shade = {n: shade[n] & dilated(later_shade[n] & later_held, s.persist_px) for n in shade}
    seen = held_colours(held, colours[meant], any_meant, {n: colours[n] for n in others})
    shaded = held_colours(held, colours[meant], any_meant, shade).own
    seen = replace(seen, shaded=shaded)
    if fit:
        cpu = time.process_time()
        fits = colour_shares(first, held, {n: job.recognizers[n] for n in (meant, *others)})
        seen = replace(seen, meant_fit=fits.pop(meant), fits=fits)
        job.motion.hold(time.process_time() - cpu)
    where = ", ".join(f"{float(np.hypot(*at)) * 100:.0f} cm aside" for at in seen_at)
    return seen, f"looked from {where}"


__all__ = [
    "HeldColours",
    "HeldLookSettings",
    "free_in_view",
    "hanging_region",
    "held_colours",
    "held_mask",
    "held_verdict",
    "hidden_in",
    "hover_offsets",
    "look_at_held",
    "palette_masks",
    "project_to_image",
    "table_homography",
    "table_points",
]
