"""The clear-table job's parts: sort rule, boxes in the world config, the command log's
limit check, the look into a box, the config's checks."""

from __future__ import annotations

import numpy as np
import pytest

from robot_app.config import load_config
from robot_app.control.box_check import BoxCheckSettings, BoxView, check_box
from robot_app.control.limits import JointLimits, TrajectorySettings
from robot_app.control.logged_cell import LoggedCell
from robot_app.control.sort_rule import SortSettings
from robot_app.errors import ConfigError
from robot_app.experiments.clear_table import ClearTableConfig
from robot_app.sim.config import CameraSettings, WorldConfig
from robot_app.sim.world import World
from robot_app.vision import ClothModel, FitnessSettings

TWO = [{"name": "colours", "centre_xy": (0.30, -0.56)}, {"name": "whites", "centre_xy": (0.30, 0.56)}]


def test_sort_rule_maps_numbers_and_names_to_boxes() -> None:
    rule = SortSettings(default="colours", boxes={"whites": (6, "No.17", 18)})
    assert rule.box_for("No.17") == "whites"
    assert rule.box_for("No.6") == "whites"
    assert rule.box_for("No.3") == "colours"
    rule.check_boxes(("colours", "whites"))
    with pytest.raises(ConfigError) as err:
        rule.check_boxes(("colours",))
    assert err.value.value == "whites"
    with pytest.raises(ValueError, match="two boxes"):
        SortSettings(default="a", boxes={"a": (1,), "b": (1,)})


def test_world_boxes_list_the_cell_and_the_first_is_the_main_box() -> None:
    config = WorldConfig.model_validate({"boxes": TWO})
    assert config.box.name == "colours" and [b.name for b in config.all_boxes] == ["colours", "whites"]
    assert [b.name for b in WorldConfig().all_boxes] == ["box"]  # pick-place's cell is unchanged
    with pytest.raises(ValueError, match="distinct names"):
        WorldConfig.model_validate({"boxes": [TWO[0], TWO[0]]})
    with pytest.raises(ValueError, match="box and boxes"):
        WorldConfig.model_validate({"box": {"name": "other"}, "boxes": TWO})
    small = WorldConfig.model_validate(
        {"realism": "clean", "boxes": TWO, "cameras": CameraSettings(image_size=(64, 48)).model_dump()}
    )
    with World(small) as world:
        assert [b.name for b in world.boxes] == ["colours", "whites"]
        assert world.box is world.boxes[0]
        assert len(world.static_obstacles) == 1 + 8  # the table and four walls per box
        np.testing.assert_allclose(world.boxes[1].centre, [0.30, 0.56, 0.0])


def test_clear_table_config_checks_its_boxes_and_keeps_the_job_defaults() -> None:
    config = load_config(ClearTableConfig, None, ["world.realism=clean"])
    assert [b.name for b in config.world.all_boxes] == ["colours", "whites"]
    assert config.world.cloth.collision_margin == 0.008
    with pytest.raises(ConfigError) as err:
        load_config(ClearTableConfig, None, ["sort.default=bins"])
    assert any("bins" in str(p) for p in err.value.problems)
    with pytest.raises(ConfigError):
        load_config(ClearTableConfig, None, ["known=[0, 3]"])


class _FakeCell:
    dt = 0.01

    def __init__(self) -> None:
        self.time = 0.0

    def step(self) -> None:
        self.time += self.dt

    def command_joints(self, q, dq) -> None:
        pass

    def joint_positions(self):
        return np.zeros(2)


def _limits() -> JointLimits:
    return JointLimits.from_velocity_limits(
        np.array([-3.0, -3.0]), np.array([3.0, 3.0]), np.array([1.0, 1.0]), TrajectorySettings()
    )


def test_logged_cell_checks_every_command_and_catches_a_jump() -> None:
    limits = _limits()
    cell = LoggedCell(_FakeCell())  # type: ignore[arg-type]
    for k in range(100):  # a slow, smooth motion
        t = k * cell.dt
        cell.command_joints([0.1 * np.sin(t), 0.0], [0.1 * np.cos(t), 0.0])
        cell.step()
    assert cell.limit_report(limits).violations == 0
    np.testing.assert_allclose(cell.last_command, [0.1 * np.sin(0.99), 0.0])
    cell.command_joints([1.0, 0.0], [0.0, 0.0])  # a hand-over that jumps 0.9 rad in one period
    cell.step()
    report = cell.limit_report(limits)
    assert report.velocity >= 1 and report.worst_velocity > 10


def _model(hue: int) -> ClothModel:
    points = np.column_stack([np.random.default_rng(0).uniform(-0.05, 0.05, (50, 2)), np.zeros(50)])
    return ClothModel("m", points, np.full(50, hue, np.uint16), points * 1.2, 85.0, np.zeros(3), (0.1, 0.1))


def test_box_check_needs_a_change_with_the_models_colours() -> None:
    settings, fitness = BoxCheckSettings(), FitnessSettings(min_saturation=40, min_value=40)
    floor = np.full((96, 96, 3), (150, 180, 200), np.uint8)  # beige floor
    before = BoxView(floor, np.ones((96, 96), bool))
    after_image = floor.copy()
    after_image[20:70, 20:70] = (40, 30, 200)  # a red cloth (BGR)
    after = BoxView(after_image, np.ones((96, 96), bool))
    red, blue = _model(253), _model(160)
    assert check_box(before, after, red, fitness, settings).confirmed
    assert not check_box(before, after, blue, fitness, settings).confirmed
    assert not check_box(before, before, red, fitness, settings).confirmed  # nothing changed
    unseen = BoxView(after_image, np.zeros((96, 96), bool))
    result = check_box(before, unseen, red, fitness, settings)
    assert not result.confirmed and result.in_view == 0.0
