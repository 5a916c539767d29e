"""The conveyor: belt speed profiles, the belt area, and a soft-body cloth carried by it."""

from __future__ import annotations

import math

import numpy as np
import pytest

from robot_app.config import load_config
from robot_app.errors import ConfigError
from robot_app.experiments.pick_place_episode import PickPlaceConfig
from robot_app.geometry import yaw_of
from robot_app.sim import BeltArea, BeltMotion, SceneSettings, World, WorldConfig, make_scene
from robot_app.sim.conveyor import CONTACT_HEIGHT

WORLD = WorldConfig.model_validate({"realism": "clean", "cameras": {"image_size": [64, 48]}})


def test_constant_ramp_and_stop_and_go_speeds_and_travel() -> None:
    constant = BeltMotion(0.05, 30.0)
    assert constant.speed_at(-0.1) == 0.0 and constant.speed_at(3.0) == pytest.approx(0.05)
    assert constant.travel(2.0) == pytest.approx(0.1, rel=1e-6)
    np.testing.assert_allclose(constant.velocity_at(1.0), 0.05 * np.array([math.sqrt(3) / 2, 0.5, 0.0]))
    ramp = BeltMotion(0.1, profile="ramp", ramp_time=4.0)
    assert ramp.speed_at(2.0) == pytest.approx(0.05) and ramp.speed_at(9.0) == pytest.approx(0.1)
    assert ramp.travel(4.0) == pytest.approx(0.2, rel=1e-4)  # the area of the triangle
    go = BeltMotion(0.1, profile="stop_and_go", run_time=2.0, stop_time=1.0, acceleration=0.5)
    assert go.speed_at(0.1) == pytest.approx(0.05)  # accelerating at 0.5 m/s^2
    assert go.speed_at(1.0) == pytest.approx(0.1)
    assert go.speed_at(1.95) == pytest.approx(0.025)  # braking to stand at 2.0 s
    assert go.speed_at(2.5) == 0.0 and go.speed_at(3.1) == pytest.approx(0.05)  # the next cycle
    # one cycle: 2 s minus the two 0.2 s ramps at full speed, plus the ramps at half speed
    assert go.travel(3.0) == pytest.approx(0.1 * 1.6 + 0.1 * 0.4 / 2, rel=1e-3)


@pytest.mark.parametrize(
    "kwargs",
    [
        {"speed": -0.1},
        {"speed": math.nan},
        {"speed": 0.1, "profile": "wobble"},
        {"speed": 0.1, "run_time": 0.0},
    ],
)
def test_bad_belt_motion_is_refused(kwargs: dict[str, object]) -> None:
    with pytest.raises(ValueError):
        BeltMotion(**kwargs)  # type: ignore[arg-type]


def test_belt_carries_only_points_lying_on_it() -> None:
    area = BeltArea((0.0, 1.0), (-0.5, 0.5), 0.0)
    points = np.array(
        [
            [0.5, 0.0, 0.0003],  # resting on it
            [0.5, 0.0, CONTACT_HEIGHT * 0.9],  # a folded flap
            [0.5, 0.0, CONTACT_HEIGHT * 1.5],  # lifted off it
            [1.2, 0.0, 0.0],  # past its end
        ]
    )
    np.testing.assert_array_equal(area.carries(points), [True, True, False, False])


def test_bad_conveyor_settings_are_config_errors() -> None:
    with pytest.raises(ConfigError) as profile:
        load_config(PickPlaceConfig, None, ["scene.conveyor_profile=wobble"])
    assert profile.value.key == "scene.conveyor_profile"
    with pytest.raises(ConfigError) as speed:
        load_config(PickPlaceConfig, None, ["scene.conveyor_speed=-0.1"])
    assert speed.value.key == "scene.conveyor_speed"


def test_a_cloth_rides_the_belt_as_a_soft_body_and_a_held_node_stays() -> None:
    with World(WORLD) as world:
        scene = make_scene(
            world, SceneSettings(target=3, conveyor_speed=0.05, conveyor_direction_deg=30.0), seed=1
        )
        cloth = scene.target
        assert world.conveyor is scene.conveyor and scene.conveyor is not None and scene.conveyor.running
        before = cloth.pose()
        world.step(round(1.0 / world.dt))
        after = cloth.pose()
        moved = after[:2, 3] - before[:2, 3]
        np.testing.assert_allclose(moved, 0.05 * np.array([math.sqrt(3) / 2, 0.5]), atol=0.001)
        assert abs(yaw_of(after[:3, :3]) - yaw_of(before[:3, :3])) < math.radians(0.5)
        assert cloth.max_edge_stretch() < 1.05
        # a node held in place (as by the gripper) is not carried; the others are
        cloth.pin([0])
        held_before, others_before = cloth.nodes()[0].copy(), cloth.nodes()[1:].copy()
        world.step(round(0.5 / world.dt))
        assert np.linalg.norm(cloth.nodes()[0] - held_before) < 0.002
        assert np.median(np.linalg.norm(cloth.nodes()[1:] - others_before, axis=1)) > 0.01


def test_a_belt_scene_lays_the_cloth_at_the_upstream_edge() -> None:
    with World(WORLD) as world:
        settings = SceneSettings(target=7, conveyor_speed=0.05, conveyor_direction_deg=0.0)
        scene = make_scene(world, settings, seed=4)
        outline = scene.target.outline_world()
        upstream_edge = world.config.range.centre_xy[0] - world.config.range.size_xy[0] / 2
        # drawn touching the range's upstream edge (inside the position margin), then settled
        assert outline[:, 0].min() == pytest.approx(upstream_edge + settings.position_margin, abs=0.01)
    with World(WORLD) as world:  # a still table: the scene of before (no conveyor)
        still = make_scene(world, SceneSettings(target=7), seed=4)
        assert world.conveyor is None and still.conveyor is None
