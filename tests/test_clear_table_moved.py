"""An unknown region a pick moved: the sheet shows where it lay, outside the picked cloth."""

import numpy as np

from robot_app.control.table_moved import MovedSettings, bared_from_elsewhere, moved_regions
from robot_app.vision.identify import UnknownRegion

H, W = 120, 160


def _region(v0: int, v1: int, u0: int, u1: int) -> UnknownRegion:
    mask = np.zeros((H, W), bool)
    mask[v0:v1, u0:u1] = True
    return UnknownRegion(((u0 + u1) / 2, (v0 + v1) / 2), int(mask.sum()), mask)


def test_a_region_bared_outside_the_picked_cloth_moved_one_still_there_did_not() -> None:
    picked = np.zeros((H, W), bool)
    picked[20:60, 20:70] = True  # the picked cloth's footprint at the survey's pose
    dragged = _region(30, 60, 72, 110)  # beside it; after the pick the sheet shows at its place
    stayed = _region(70, 100, 20, 60)  # apart; still covered after the pick
    fold = _region(25, 55, 65, 75)  # the picked cloth's unexplained fold, mostly in its footprint
    sheet_after = np.ones((H, W), bool)
    sheet_after[stayed.mask] = False  # the cloth that stayed still hides the sheet
    sheet_after[30:60, 100:110] = False  # a third of the dragged cloth's place still covered
    settings = MovedSettings()
    moved = moved_regions((dragged, stayed, fold), picked, sheet_after, settings)
    assert [m.region for m in moved] == [dragged]
    assert 0.6 < moved[0].bared < 0.8
    # stricter: two thirds bared is not enough at 0.8
    assert moved_regions((dragged,), picked, sheet_after, MovedSettings(min_bared=0.8)) == []
    # nothing bared: nothing moved
    assert moved_regions((dragged, stayed), picked, np.zeros((H, W), bool), settings) == []


def test_a_region_seen_from_another_pose_is_bared_where_the_sheet_now_shows() -> None:
    # a camera 0.4 m over the table looking straight down (z down), 200 x 100 px, f = 200 px
    K = np.array([[200.0, 0.0, 100.0], [0.0, 200.0, 50.0], [0.0, 0.0, 1.0]])
    camera_to_world = np.diag([1.0, -1.0, -1.0, 1.0])
    camera_to_world[:3, 3] = [0.0, 0.0, 0.4]
    sheet = np.zeros((100, 200), dtype=bool)
    sheet[:, 100:] = True  # the sheet shows on the right half (x > 0 in the world)
    grid = np.linspace(0.01, 0.09, 9)
    gone = np.array([[x, y, 0.0] for x in grid for y in grid - 0.05])  # right of the middle: bared
    stays = gone * [-1.0, 1.0, 1.0]  # mirrored to the left: still covered
    half = np.vstack([gone, stays])
    away = gone + np.array([1.0, 0.0, 0.0])  # out of the image
    shares = bared_from_elsewhere([gone, stays, half, away], camera_to_world, K, sheet, min_pixels=20)
    assert shares[0] == 1.0 and shares[1] == 0.0 and shares[2] == 0.5 and shares[3] is None
