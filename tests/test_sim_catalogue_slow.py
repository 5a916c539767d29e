"""Per-cloth checks over the whole catalogue (slow: run with `pytest -m slow`).

The recognition check runs in the clean cell: there every cloth must be found precisely
(the realistic and harsh figures are measured by scripts/bench_sim.py, not asserted).
"""

from __future__ import annotations

import pytest

from robot_app.sim.checks import lift_check, recognition_check
from robot_app.sim.cloths import CATALOGUE, ClothSpec
from robot_app.sim.config import CameraSettings, WorldConfig
from robot_app.sim.world import World

CONFIG = WorldConfig(cameras=CameraSettings(image_size=(320, 240)))  # realistic looks, same physics


@pytest.mark.slow
@pytest.mark.parametrize("spec", CATALOGUE, ids=lambda s: f"No{s.number}")
def test_every_cloth_settles_and_survives_a_lift(spec: ClothSpec) -> None:
    with World(CONFIG) as world:
        cloth = world.add_cloth(spec, *CONFIG.range.centre_xy, 0.5, drop_height=0.03, settle=False)
        assert world.settle([cloth]) < 1.0
        result = lift_check(world, cloth, height=0.3)
    assert result.finite
    assert result.anchored >= 2
    assert result.max_stretch < 1.3
    assert result.lifted > 0.25


@pytest.mark.slow
@pytest.mark.parametrize("spec", CATALOGUE, ids=lambda s: f"No{s.number}")
def test_station_model_recognises_the_flat_cloth(spec: ClothSpec) -> None:
    result = recognition_check(spec, WorldConfig(realism="clean"), seed=spec.number)
    assert result.found
    assert abs(result.error_x_mm) <= 3.0 and abs(result.error_y_mm) <= 3.0
    assert abs(result.error_yaw_deg) <= 3.0
