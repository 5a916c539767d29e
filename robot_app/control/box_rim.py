"""A cloth that hangs over its box's wall after the release: seen on the rim, laid again.

The check after a release (`TableClearer.check_box`) reads the walls' tops in both images
of its look (`box_check.rim_view`) and compares them with the look before the release
(`box_check.rim_covered`): a run of a wall's rim that changed is a cloth lying over it.
Single cloths released onto a heap of three or four (16 mm thick each in the simulator)
slid over a wall and ended partly in (held-out 1330, 1384: the fourth into colours; 1268:
the fifth; 1340: the second into whites), the commonest failure of sessions 37-42.

Then the job lays the cloth again (`lay_again`): the released cloth's grasped part landed
last, on top, under where the hand let go (the box's middle); the hand goes down there to
the top the check's pair measures at that point (`top_at`; the heap's highest point,
`box_contents.contents_top`, where it measures none: in the first held-out run with the
check, 1405, one cloth over an empty box's wall, the heap's top was read at the draped wall,
0.10 m, and the fingers closed four times on nothing over it), closes (lower again while it
closes on nothing, as a blind grasp: `table_lost.close_lowering`), lifts straight up to the
transfer height, which draws the hanging part back over the rim, and releases it again
`clear.rim_shift` away from that wall. What it takes is whatever lies on top there: the
cloth just released or one under it, all of that box (the rim decides, not the name)."""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray
from robot_app.control.box_check import WALL_NORMALS, look_tcp
from robot_app.control.box_contents import inside_mask
from robot_app.control.cell import StereoCapture
from robot_app.control.intercept import hanging_reach
from robot_app.control.pick_checks import AttemptState
from robot_app.control.pick_place import carry_over_box, release_into_box
from robot_app.control.table_lost import close_lowering
from robot_app.control.table_surface import surface_height
from robot_app.errors import IKError

if TYPE_CHECKING:
    from robot_app.control.table_clearer import TableClearer

WALL_NAMES = ("+x", "-x", "+y", "-y")  # `WALL_NORMALS` order: the wall's outward side in Σ_W


def lay_again(
    job: TableClearer,
    attempt: AttemptState,
    wall: int,
    capture: StereoCapture,
    along: float = 0.0,
    inset: float | None = None,
) -> StereoCapture | None:
    """Takes what lies on top at the grasp point of `attempt.box` (`lay_again_point`: its
    middle, or with `inset` [m] that far inside the wall where the cloth crosses it,
    `along` [m] from the wall's middle as `box_check.rim_runs` measures; its height
    measured on the check's `capture`, `top_at`) and releases it again
    `clear.rim_shift` from the box's middle away from its wall `wall` (`WALL_NORMALS`
    index), then looks into the box from the check's pose: that look's capture, or None
    where the hand closed on nothing or the arm could not reach (noted; the arm is back at
    the look)."""
    s, loop, table_z = job.settings, job.loop_settings, job.table_z
    box = attempt.box
    middle = np.asarray(box.centre, dtype=float)
    at = lay_again_point(box.centre, box.inner_size, wall, along, inset)
    top = top_at(job, attempt, capture, at)
    heap = job.box_heap(box.name) if top is None else top
    where = "in its middle" if inset is None else "inside the wall where it crosses"
    source = "its heap's top" if top is None else f"the top measured {where}"
    attempt.notes.append(f"laid again from {heap * 1000:.0f} mm over the box's floor ({source})")
    grasp_z = table_z + max(s.lost.grasp_height, heap + loop.grasp_height)
    job.set_phase("lay again", attempt.name)
    look = look_tcp(box.centre, s.box_view_height, job.camera_offset())
    try:
        here = job.motion.tcp_position()
        job.motion.move_tcp([at[0], at[1], here[2]])
        job.motion.move_tcp([at[0], at[1], grasp_z + loop.pregrasp_height])
        job.motion.move_tcp([at[0], at[1], grasp_z], speed=s.put_down_speed)
        held, _ = close_lowering(job, (float(at[0]), float(at[1])), grasp_z, attempt.notes)
        if not held:
            job.cell.release()
            job.cell.set_gripper(loop.gripper_open)
            attempt.notes.append("laid again: the fingers closed on nothing in the box")
            job.motion.move_tcp(look)
            return None
        job.motion.move_tcp([at[0], at[1], table_z + loop.transfer_height])
        to = middle.copy()
        to[:2] -= s.rim_shift * WALL_NORMALS[wall]
        carry_over_box(job.motion, to, table_z, loop)
        model = job.recognizers[attempt.name].model
        reach = hanging_reach(model.points_in, np.mean(model.points_in, axis=0))
        release_into_box(job.motion, job.cell, to, table_z, loop, reach, heap)
        job.motion.move_tcp(look)
    except IKError as err:
        job.cell.release()
        job.cell.set_gripper(loop.gripper_open)
        attempt.notes.append(f"laid again: out of reach ({err})")
        return None
    return job.cell.capture()


def lay_again_point(
    centre: npt.ArrayLike, inner_size: float, wall: int, along: float, inset: float | None
) -> FloatArray:
    """Where `lay_again` grasps in the box of `centre` ((3,) its floor's middle, Σ_W) and
    `inner_size` [m]: the middle where `inset` is None; else `inset` [m] inside the wall
    `wall` (`WALL_NORMALS` index), at `along` [m] from its middle (kept as far inside the
    two walls across), where a cloth that crossed that wall's rim lies inside. (3,) [m]."""
    point = np.array(centre, dtype=float)
    if inset is None:
        return point
    reach = max(inner_size / 2 - inset, 0.0)
    normal = WALL_NORMALS[wall]
    tangent = np.array([abs(normal[1]), abs(normal[0])])
    point[:2] += reach * normal + float(np.clip(along, -reach, reach)) * tangent
    return point


def top_at(
    job: TableClearer, attempt: AttemptState, capture: StereoCapture, at: FloatArray | None = None
) -> float | None:
    """How high [m] over its floor the top of what lies at `at` ((3,) Σ_W; None: the
    middle) of `attempt.box` lies, measured on the pair of `capture`
    (`table_surface.surface_height` inside the box's walls, with the cloth's model's sweep
    settings); None where not trusted. The arm holds for the computation time."""
    cpu = time.process_time()
    box, recognizer = attempt.box, job.recognizers[attempt.name]
    shape = (capture.right_bgr.shape[0], capture.right_bgr.shape[1])
    inside = inside_mask(capture, job.rig.right, box, shape)
    floor = float(box.centre[2])
    found = surface_height(
        capture,
        job.rig,
        recognizer.model,
        recognizer.settings.depth,
        inside,
        box.centre if at is None else at,
        floor,
        job.settings.surface,
    )
    job.motion.hold(time.process_time() - cpu)
    return found.z - floor if found.trusted else None


def over_wall_note(covered: FloatArray, box: str) -> str:
    """Names the wall of `box` whose rim the longest changed run `covered` ((4,) [m]) crosses."""
    wall = int(np.argmax(covered))
    return f"a cloth over the {WALL_NAMES[wall]} wall of {box} ({covered[wall] * 100:.0f} cm of its rim)"


__all__ = ["WALL_NAMES", "lay_again", "lay_again_point", "over_wall_note", "top_at"]
