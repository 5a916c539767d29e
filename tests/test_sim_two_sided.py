"""A cloth lying face down is lit as one lying face up (`lighting.render_two_sided`).

TinyRenderer lights a soft body by its physics normals, which point out of the face side:
before, a face-down cloth got the ambient share alone (a white napkin's back at grey 55
under the realistic lamp, instead of its back's 0.72 of the face's brightness)."""

from __future__ import annotations

import numpy as np
import pytest

from robot_app.geometry import make_transform, rotation_about_z
from robot_app.sim import World, cloth_spec
from robot_app.sim.cameras import render_bgr_depth
from robot_app.sim.config import WorldConfig
from robot_app.sim.fabrics import BACK_DARKENING
from robot_app.sim.lighting import render_two_sided
from robot_app.sim.world import FLIP_FACE_UP


def _centre(number: int, face_up: bool, two_sided: bool) -> tuple[np.ndarray, np.ndarray]:
    """Mean BGR of the middle of cloth No.`number` lying face up or down under the
    realistic cell's lamp, seen from 0.6 m straight above, and of the bare sheet."""
    config = WorldConfig.model_validate({"realism": "realistic", "lighting": {"two_sided": two_sided}})
    with World(config) as world:
        x, y = config.range.centre_xy
        z = config.table.top_z + config.cloth.collision_margin
        turn = rotation_about_z(0.3) @ (FLIP_FACE_UP if face_up else np.eye(3))
        world.add_cloth_at(cloth_spec(number), make_transform(turn, [x, y, z]), settle=True)
        pose = make_transform(np.diag([1.0, -1.0, -1.0]), [x, y, z + 0.6])
        camera = world.stereo.true_rig.right
        render = render_two_sided if two_sided else render_bgr_depth
        image, _ = render(world.client, camera, pose, 0.05, 3.0, world.stereo.lighting)
    h, w = image.shape[:2]
    middle = image[h // 2 - 10 : h // 2 + 10, w // 2 - 10 : w // 2 + 10].reshape(-1, 3).astype(float)
    sheet = image[5:25, 5:25].reshape(-1, 3).astype(float)
    return middle.mean(axis=0), sheet.mean(axis=0)


@pytest.mark.parametrize("number", [18, 1])
def test_a_face_down_cloth_shows_its_back_lit_as_the_lamp_lights_it(number: int) -> None:
    up, sheet_up = _centre(number, face_up=True, two_sided=True)
    down, sheet_down = _centre(number, face_up=False, two_sided=True)
    ratio = down.sum() / up.sum()  # the back is the front faded, BACK_DARKENING as bright
    assert ratio == pytest.approx(BACK_DARKENING, abs=0.08)
    np.testing.assert_allclose(sheet_down, sheet_up, atol=1.0)  # the table is drawn as before
    one_sided, sheet = _centre(number, face_up=False, two_sided=False)
    assert one_sided.sum() / up.sum() < 0.4  # what the renderer alone draws: ambient only
    np.testing.assert_allclose(sheet, sheet_down, atol=1.0)
    face_up_once, _ = _centre(number, face_up=True, two_sided=False)
    np.testing.assert_allclose(face_up_once, up, atol=1.0)  # a face-up cloth is drawn as before
