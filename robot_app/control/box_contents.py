"""How high the cloths already in a box heap up (`contents_top`), so that the next release
does not lower the hand into them.

The release lowers the hand until the hanging cloth's lowest point is near the box floor
and then `loop.release_fold` further, never below `loop.min_release_height` over the floor:
into an empty box. Over cloths placed before, the hand pressed the released cloth into
their heap (held-out 876, session 35: No.3 and No.7, each confirmed in colours, heaped
0.06-0.11 m high; the hand went down to 0.06 m to release No.20). A second later, the hand
gone home (no link of the arm within 3 cm of them, notes `s35/links.py`), the two rose out
of the box at about 0.7 m/s and ended on the table beside it: pybullet's soft-soft contact
in a heap whose layers were pressed across each other, as in held-out 400 (session 28). A
real heap does not jump, but a hand pressed into it may snag or push it; the rerun with the
release above the heap cleared. The box check's stereo pair from above the box measures
the heap: horizontal planes swept over patches of the box's inside
(`table_surface.surface_heights`, the grasp's measurement of a pile's top), the highest
trusted one its top; the release then takes that top for the floor.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from robot_app.control.cell import StereoCapture
from robot_app.control.clear_table_records import BoxPlace
from robot_app.control.table_furniture import fill_box_hull
from robot_app.control.table_surface import SurfaceSettings, surface_heights
from robot_app.vision import ClothModel
from robot_app.vision.camera import PinholeCamera, StereoRig
from robot_app.vision.stereo_depth import DepthCheckSettings

SPREAD = 0.3  # the measured points lie within this share of the inner side from the centre


def inside_mask(
    capture: StereoCapture, camera: PinholeCamera, box: BoxPlace, shape: tuple[int, int]
) -> npt.NDArray[np.bool_]:
    """(H, W) the right image's pixels inside `box`'s walls: the hull of its inner square at
    the floor and at the walls' top (what lies in it, heaped up to the rim)."""
    mask = np.zeros(shape, np.uint8)
    fill_box_hull(mask, capture, camera, box, box.inner_size / 2)
    return mask.astype(bool)


def contents_top(
    capture: StereoCapture,
    rig: StereoRig,
    box: BoxPlace,
    model: ClothModel,
    depth: DepthCheckSettings,
    settings: SurfaceSettings,
) -> float:
    """How high [m] over `box`'s floor the highest trusted surface lies that the pair of
    `capture` measures at 3 x 3 points within `SPREAD` of its inner side from its centre
    (`surface_heights` with `model`'s sweep settings, heights up to `settings.above`); 0
    where none is trusted (a bare floor, a smooth cloth)."""
    c = np.asarray(box.centre, dtype=float)
    step = SPREAD * box.inner_size
    points = np.array([[c[0] + dx, c[1] + dy] for dx in (-step, 0.0, step) for dy in (-step, 0.0, step)])
    shape = (capture.right_bgr.shape[0], capture.right_bgr.shape[1])
    inside = inside_mask(capture, rig.right, box, shape)
    found = surface_heights(capture, rig, model, depth, inside, points, float(c[2]), settings)
    tops = [h.z - float(c[2]) for h in found if h.trusted]
    return max(0.0, max(tops, default=0.0))


__all__ = ["contents_top", "inside_mask"]
