"""A cloth that hangs over its box's wall after the release: seen on the rim, laid again.

The check after a release (`TableClearer.check_box`) reads the walls' tops in both images
of its look (`box_check.rim_view`) and compares them with the look before the release
(`box_check.rim_covered`): a run of a wall's rim that changed is a cloth lying over it.
Single cloths released onto a heap of three or four (16 mm thick each in the simulator)
slid over a wall and ended partly in (held-out 1330, 1384: the fourth into colours; 1268:
the fifth; 1340: the second into whites), the commonest failure of sessions 37-42.

Then the job lays the cloth again (`lay_again`): the released cloth's grasped part landed
last, on top, under where the hand let go (the box's middle); the hand goes down there to
the heap's top as the check measured it, closes (lower again while it closes on nothing,
as a blind grasp: `table_lost.close_lowering`), lifts straight up to the transfer height,
which draws the hanging part back over the rim, and releases it again `clear.rim_shift`
away from that wall. What it takes is whatever lies on top there: the cloth just released
or one under it, all of that box (the rim decides, not the name)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from robot_app.arrays import FloatArray
from robot_app.control.box_check import WALL_NORMALS, look_tcp
from robot_app.control.cell import StereoCapture
from robot_app.control.intercept import hanging_reach
from robot_app.control.pick_checks import AttemptState
from robot_app.control.pick_place import carry_over_box, release_into_box
from robot_app.control.table_lost import close_lowering
from robot_app.errors import IKError

if TYPE_CHECKING:
    from robot_app.control.table_clearer import TableClearer

WALL_NAMES = ("+x", "-x", "+y", "-y")  # `WALL_NORMALS` order: the wall's outward side in Σ_W


def lay_again(job: TableClearer, attempt: AttemptState, wall: int) -> StereoCapture | None:
    """Takes what lies on top in the middle of `attempt.box` and releases it again
    `clear.rim_shift` away from its wall `wall` (`WALL_NORMALS` index), then looks into the
    box from the check's pose: that look's capture, or None where the hand closed on
    nothing or the arm could not reach (noted; the arm is back at the look)."""
    s, loop, table_z = job.settings, job.loop_settings, job.table_z
    box = attempt.box
    middle = np.asarray(box.centre, dtype=float)
    heap = job.box_heap(box.name)
    grasp_z = table_z + max(s.lost.grasp_height, heap + loop.grasp_height)
    job.set_phase("lay again", attempt.name)
    look = look_tcp(box.centre, s.box_view_height, job.camera_offset())
    try:
        here = job.motion.tcp_position()
        job.motion.move_tcp([middle[0], middle[1], here[2]])
        job.motion.move_tcp([middle[0], middle[1], grasp_z + loop.pregrasp_height])
        job.motion.move_tcp([middle[0], middle[1], grasp_z], speed=s.put_down_speed)
        held, _ = close_lowering(job, (float(middle[0]), float(middle[1])), grasp_z, attempt.notes)
        if not held:
            job.cell.release()
            job.cell.set_gripper(loop.gripper_open)
            attempt.notes.append("laid again: the fingers closed on nothing in the box's middle")
            job.motion.move_tcp(look)
            return None
        job.motion.move_tcp([middle[0], middle[1], table_z + loop.transfer_height])
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


def over_wall_note(covered: FloatArray, box: str) -> str:
    """Names the wall of `box` whose rim the longest changed run `covered` ((4,) [m]) crosses."""
    wall = int(np.argmax(covered))
    return f"a cloth over the {WALL_NAMES[wall]} wall of {box} ({covered[wall] * 100:.0f} cm of its rim)"


__all__ = ["WALL_NAMES", "lay_again", "over_wall_note"]
