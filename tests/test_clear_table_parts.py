"""The clear-table job's parts: sort rule, boxes in the world config, the command log's
limit check, the look into a box, the config's checks."""

from __future__ import annotations

import numpy as np
import pytest

from robot_app.config import load_config
from robot_app.control.box_check import BoxCheckSettings, BoxView, check_box
from robot_app.control.clear_table_records import TableArea
from robot_app.control.grasp_point import PileGraspSettings, choose_pile_grasp, points_in_mask
from robot_app.control.job_motion import FREEDOM_STEP, PutBackSettings, cloth_half_width, lay_out_paths
from robot_app.control.limits import JointLimits, TrajectorySettings
from robot_app.control.logged_cell import LoggedCell
from robot_app.control.sort_rule import SortSettings
from robot_app.control.table_survey import disk_points
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
    with pytest.raises(ConfigError) as err:  # a sort entry no cloth could ever match
        load_config(ClearTableConfig, None, ["sort.default=colours", "sort.boxes.whites=[6, 25]"])
    assert "No.25" in str(err.value)
    with pytest.raises(ConfigError):
        load_config(ClearTableConfig, None, ["sort.default=colours", 'sort.boxes.whites=["No.6", "no17"]'])


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


def _square(side: float = 0.2, step: float = 0.005) -> ClothModel:
    """A square cloth of `side` [m]: S_in on a grid, S_out a band 10 mm outside its edge."""
    grid = np.arange(-side / 2, side / 2 + 1e-9, step)
    u, v = np.meshgrid(grid, grid)
    points = np.column_stack([u.ravel(), v.ravel(), np.zeros(u.size)])
    ring = np.arange(-side / 2 - 0.01, side / 2 + 0.01 + 1e-9, step)
    edge = side / 2 + 0.01
    out = np.concatenate(
        [np.column_stack([ring, np.full(ring.size, s * edge)]) for s in (-1, 1)]
        + [np.column_stack([np.full(ring.size, s * edge), ring]) for s in (-1, 1)]
    )
    out = np.column_stack([out, np.zeros(len(out))])
    hues = np.full(len(points), 10, np.uint16)
    return ClothModel("sq", points, hues, out, 85.0, np.zeros(3), (side, side))


def test_pile_grasp_keeps_away_from_the_cloth_underneath() -> None:
    model = _square()
    pose = np.eye(4)
    pose[:3, 3] = (0.5, 0.1, 0.72)
    seen = np.ones(len(model.points_in), bool)
    alone = choose_pile_grasp(model, pose, seen, np.empty((0, 2)))
    assert alone is not None and np.isinf(alone.clearance)
    np.testing.assert_allclose(alone.point_model[:2], [0.0, 0.0], atol=1e-9)  # the middle, as the loop's
    # another cloth lies under the target's half x > 0.03 (Σ_M): its points, in Σ_W
    xs, ys = np.meshgrid(np.arange(0.03, 0.25, 0.005), np.arange(-0.1, 0.1, 0.005))
    under = np.column_stack([xs.ravel() + 0.5, ys.ravel() + 0.1])
    settings = PileGraspSettings(clearance=0.06, min_edge_gap=0.02)
    chosen = choose_pile_grasp(model, pose, seen, under, settings)
    assert chosen is not None
    assert chosen.clearance >= 0.06 - 1e-9 and chosen.edge_gap >= 0.02
    assert chosen.point_model[0] <= -0.03 + 1e-9  # on the free half
    np.testing.assert_allclose(chosen.point_world, pose[:3, :3] @ chosen.point_model + pose[:3, 3])
    # ... but not where the cloth would hang lower than max_reach below the fingers
    short = choose_pile_grasp(model, pose, seen, under, PileGraspSettings(clearance=0.06, max_reach=0.15))
    assert short is not None and short.clearance < 0.06
    corners = np.array([[x, y] for x in (-0.1, 0.1) for y in (-0.1, 0.1)])
    assert np.max(np.linalg.norm(corners - short.point_model[:2], axis=1)) <= 0.15 + 1e-9
    # the whole target lies on the other cloth: the farthest point from it, still inside the edge
    everywhere = np.column_stack([xs.ravel() + 0.3, ys.ravel() + 0.1])  # under x_M in [-0.17, 0.05]
    cornered = choose_pile_grasp(model, pose, seen, np.concatenate([under, everywhere]), settings)
    assert cornered is not None and cornered.edge_gap >= 0.02 - 1e-9 and cornered.clearance < 0.01
    # hidden points are edge too; too little seen: the loop's own choice stands
    half = model.points_in[:, 0] < 0.0
    hidden = choose_pile_grasp(model, pose, half, np.empty((0, 2)))
    assert hidden is not None and hidden.point_model[0] < 0.0
    assert choose_pile_grasp(model, pose, np.zeros(len(model.points_in), bool), under) is None
    with pytest.raises(ValueError, match="flags"):
        choose_pile_grasp(model, pose, seen[:-1], under)


def test_pile_grasp_moves_to_where_the_arm_reaches() -> None:
    # bench episode 30: a cloth by the arm's base; here the hand reaches only x >= 0.56 (Σ_W)
    model = _square()
    pose = np.eye(4)
    pose[:3, 3] = (0.5, 0.1, 0.72)
    seen = np.ones(len(model.points_in), bool)
    asked: list[np.ndarray] = []

    def reaches(point: np.ndarray) -> bool:
        asked.append(np.array(point))
        return bool(point[0] >= 0.56)

    settings = PileGraspSettings(reach_tries=8)
    best = choose_pile_grasp(model, pose, seen, np.empty((0, 2)), settings)
    chosen = choose_pile_grasp(model, pose, seen, np.empty((0, 2)), settings, reaches)
    assert best is not None and chosen is not None
    assert best.point_world[0] < 0.56  # the middle, out of reach
    assert chosen.point_world[0] >= 0.56 and chosen.edge_gap >= settings.min_edge_gap
    assert chosen.moved_for_reach and not best.moved_for_reach
    assert 2 <= len(asked) <= settings.reach_tries + 1
    # as deep inside the edge as the deepest reachable point the spread asked
    asked_ok = [q for q in asked if q[0] >= 0.56]
    deepest_asked = max(0.11 - max(abs(q[0] - 0.5), abs(q[1] - 0.1)) for q in asked_ok)
    assert chosen.edge_gap >= deepest_asked - 1e-9
    # reachable at once: nothing else asked; nowhere reachable: the best point stands
    asked.clear()
    at_once = choose_pile_grasp(model, pose, seen, np.empty((0, 2)), settings, lambda p: True)
    assert at_once is not None and np.allclose(at_once.point_world, best.point_world)
    assert not at_once.moved_for_reach
    nowhere = choose_pile_grasp(model, pose, seen, np.empty((0, 2)), settings, lambda p: False)
    assert nowhere is not None and np.allclose(nowhere.point_world, best.point_world)


def test_a_cloth_laid_back_under_the_target_is_kept_away_from() -> None:
    # a double pick was put back: the other cloth lies under the spot let go at, unseen
    spot = np.array([0.55, 0.15])
    disk = disk_points(spot, 0.08)
    assert np.all(np.hypot(*(disk - spot).T) <= 0.08 + 1e-9)
    assert abs(len(disk) - np.pi * 8**2) < 0.1 * np.pi * 8**2  # the disk filled on a 10 mm grid
    np.testing.assert_array_equal(disk_points(spot, 0.0), [spot])
    model = _square()
    pose = np.eye(4)
    pose[:3, 3] = (0.5, 0.1, 0.72)  # the spot is at (0.05, 0.05) in the target's Σ_M
    seen = np.ones(len(model.points_in), bool)
    chosen = choose_pile_grasp(model, pose, seen, disk, PileGraspSettings(clearance=0.06, min_edge_gap=0.02))
    assert chosen is not None
    assert np.hypot(*(chosen.point_world[:2] - spot)) >= 0.08 + 0.06 - 1e-9  # past the disk's clearance
    assert chosen.point_model[0] < 0.0 and chosen.point_model[1] < 0.0  # the far corner's side


def test_points_in_mask_projects_through_the_pinhole() -> None:
    K = np.array([[100.0, 0.0, 32.0], [0.0, 100.0, 24.0], [0.0, 0.0, 1.0]])
    mask = np.zeros((48, 64), bool)
    mask[24, 42] = True  # 10 px right of the centre: x = 0.1 * z
    pose = np.eye(4)
    pose[2, 3] = 0.5
    points = np.array([[0.05, 0.0, 0.0], [0.0, 0.0, 0.0], [0.05, 0.0, -1.0]])  # the last behind the camera
    np.testing.assert_array_equal(points_in_mask(points, pose, K, mask), [True, False, False])


def test_put_back_lays_out_over_free_table_inside_the_view() -> None:
    view = np.array([[0.3, -0.3], [0.8, -0.3], [0.8, 0.3], [0.3, 0.3]])
    # another cloth lies on the +y side of the hand
    xs, ys = np.meshgrid(np.arange(0.4, 0.7, 0.01), np.arange(0.05, 0.25, 0.01))
    others = np.column_stack([xs.ravel(), ys.ravel()])
    settings = PutBackSettings(directions=8, max_length=0.25, view_margin=0.04, waypoints=3)
    paths = lay_out_paths((0.55, 0.0), 0.2, 0.7, 0.05, others, view, settings)
    assert paths, "some direction fits the view"
    best = paths[0]
    assert best.direction[1] < -0.5  # away from the other cloth
    steps = [np.floor(p.freedom / FREEDOM_STEP) for p in paths]
    assert steps == sorted(steps, reverse=True)  # most free first, to the centimetre
    w = best.waypoints
    assert w.shape == (4, 3)
    np.testing.assert_allclose(w[0], [0.55, 0.0, 0.7 + 0.2])  # the hanging cloth just touches
    np.testing.assert_allclose(w[-1, 2], 0.7 + 0.05)  # let go at the release height
    np.testing.assert_allclose(np.linalg.norm(w[-1, :2] - w[0, :2]), 0.2)  # laid its reach long
    for path in paths:  # every strip stays inside the view by the margin
        end = path.waypoints[-1, :2]
        assert 0.34 - 1e-9 <= end[0] <= 0.76 + 1e-9 and -0.26 - 1e-9 <= end[1] <= 0.26 + 1e-9
    # near the view's edge, directions that leave it are not offered; a long cloth is laid max_length
    edge = lay_out_paths((0.36, 0.0), 0.4, 0.7, 0.05, np.empty((0, 2)), view, settings)
    assert edge and all(p.direction[0] > -1e-9 for p in edge) and edge[0].freedom == settings.free_distance
    np.testing.assert_allclose(np.linalg.norm(edge[0].waypoints[-1, :2] - [0.36, 0.0]), 0.25)
    with pytest.raises(ValueError, match="corners"):
        lay_out_paths((0.5, 0.0), 0.2, 0.7, 0.05, others, view[:3], settings)


def test_of_equally_free_lay_outs_the_one_deepest_inside_the_view_comes_first() -> None:
    # with the first angle (+x) winning ties, every free strip ran to the view's far edge, where
    # put-back heaps ended unseen or seen in part (bench episodes 8, 9 and 64, session 20)
    view = np.array([[0.3, -0.3], [0.8, -0.3], [0.8, 0.3], [0.3, 0.3]])
    settings = PutBackSettings(directions=12, max_length=0.25, view_margin=0.04, waypoints=3)
    paths = lay_out_paths((0.6, 0.0), 0.1, 0.7, 0.05, np.empty((0, 2)), view, settings, half_width=0.02)
    outward = next(p for p in paths if p.direction[0] > 0.99)
    assert outward.fits and outward is not paths[0]  # fits, but not first
    assert paths[0].direction[0] < -0.8  # towards the view's middle: the most room
    assert paths[0].slack == max(p.slack for p in paths)


def test_put_back_keeps_the_whole_laid_cloth_inside_the_view() -> None:
    # Episodes 31 and 33 of the bench (seeds 100031, 100033): a double lift laid out along a
    # strip that stayed inside the view while the cloth beside it did not. Here the hand is
    # 15 cm from the view's +y edge and the other cloths lie on the -y side: the freest
    # strip runs towards +y, ending 5 cm from the edge, but a cloth 16 cm wide laid along it
    # reaches 3 cm past the edge.
    view = np.array([[0.3, -0.3], [0.8, -0.3], [0.8, 0.3], [0.3, 0.3]])
    xs, ys = np.meshgrid(np.arange(0.3, 0.81, 0.01), np.arange(-0.25, 0.125, 0.01))
    others = np.column_stack([xs.ravel(), ys.ravel()])
    settings = PutBackSettings(directions=12, max_length=0.25, view_margin=0.04, waypoints=3)
    start = np.array([0.55, 0.15])
    half_width, margin = 0.08, settings.view_margin
    paths = lay_out_paths(start, 0.10, 0.7, 0.05, others, view, settings, half_width=half_width)
    towards_edge = [p for p in paths if p.direction[1] > 0.99]
    assert towards_edge and not towards_edge[0].fits  # still offered, but not first
    assert towards_edge[0].freedom == max(p.freedom for p in paths)  # the freest
    best = paths[0]
    assert best.fits
    # the laid cloth: the strip past the start, widened by the half width, inside the view
    strip = start + np.linspace(0.0, 1.0, 11)[1:, None] * (best.waypoints[-1, :2] - start)
    assert np.all(strip[:, 0] - half_width >= 0.3 + margin - 1e-9)
    assert np.all(strip[:, 0] + half_width <= 0.8 - margin + 1e-9)
    assert np.all(strip[:, 1] - half_width >= -0.3 + margin - 1e-9)
    assert np.all(strip[:, 1] + half_width <= 0.3 - margin + 1e-9)
    first_unfit = next(k for k, p in enumerate(paths) if p is towards_edge[0] or not p.fits)
    assert all(p.fits for p in paths[:first_unfit]) and not any(p.fits for p in paths[first_unfit:])
    # when nothing fits (a bundle of lifted cloths 26 cm wide), the least outside comes first,
    # not the freest: towards the view's middle (-y here), not over its edge
    bundle = lay_out_paths(start, 0.10, 0.7, 0.05, others, view, settings, half_width=0.13)
    assert bundle and not any(p.fits for p in bundle)
    assert [p.slack for p in bundle] == sorted((p.slack for p in bundle), reverse=True)
    assert bundle[0].direction[1] < -0.99
    # the part of a long cloth not laid falls round the strip's end: that must fit too
    long = lay_out_paths(start, 0.45, 0.7, 0.05, others, view, settings, half_width=0.0)
    for path in long:
        end = path.waypoints[-1, :2]
        inside = 0.3 + margin + 0.2 <= end[0] <= 0.8 - margin - 0.2 and abs(end[1]) <= 0.3 - margin - 0.2
        assert path.fits == inside
    with pytest.raises(ValueError, match="half_width"):
        lay_out_paths(start, 0.1, 0.7, 0.05, others, view, settings, half_width=-0.01)


def test_cloth_half_width_is_half_the_narrow_side() -> None:
    xs, ys = np.meshgrid(np.linspace(-0.1, 0.1, 21), np.linspace(-0.06, 0.06, 13))
    rectangle = np.column_stack([xs.ravel(), ys.ravel(), np.zeros(xs.size)])
    turned = rectangle @ np.array([[0.6, -0.8, 0.0], [0.8, 0.6, 0.0], [0.0, 0.0, 1.0]]).T
    assert cloth_half_width(turned) == pytest.approx(0.06)


def test_picks_rows_carry_the_simulators_truth_of_each_lift() -> None:
    # which lift the verdict counted as an undetected double pick must be readable from
    # picks.csv (bench episode 30: 3 double picks, 2 detected, and no way to tell which)
    from types import SimpleNamespace

    from robot_app.experiments.clear_table_faults import LiftTruth
    from robot_app.experiments.clear_table_results import pick_rows

    def attempt(name: str, start: float, end: float) -> SimpleNamespace:
        result = SimpleNamespace(
            outcome=SimpleNamespace(value="placed"),
            reason="",
            limit_report=SimpleNamespace(violations=0),
            collisions=0,
        )
        return SimpleNamespace(
            name=name, box="colours", start_time=start, end_time=end, result=result, lift_check="ok",
            weighed=0.0335, expected_weight=0.0242, put_back=False, dropped=False, box_check=None,
            grasp_clearance=None, came_along=("No.11",) if name == "No.7" else (), remembered=("No.11",),
            named_by="memory" if name == "No.7" else "", laid_back_too=(),
        )  # fmt: skip

    episode = SimpleNamespace(
        result=SimpleNamespace(attempts=[attempt("No.6", 3.7, 15.8), attempt("No.7", 17.7, 28.2)]),
        lifts=(
            LiftTruth(1, 6.5, "No.6", (6, 11), held=(6, 11)),
            LiftTruth(2, 20.1, "No.7", (7, 11), held=(7,)),
        ),
    )
    rows = pick_rows(episode)  # type: ignore[arg-type]
    assert [r["lifted_truth"] for r in rows] == ["No.6 No.11", "No.7 No.11"]
    assert [r["named_by"] for r in rows] == ["", "memory"]  # how the companion was named
    # anchored by the fingers, or dragged along by what they hold
    assert [r["held_truth"] for r in rows] == ["No.6 No.11", "No.7"]
    assert rows[1]["weighed_g"] == 33.5 and rows[1]["lift_check"] == "ok"
    assert [r["came_along"] for r in rows] == ["", "No.11 (memory)"]  # and where its name came from


def test_a_double_picks_hidden_companion_is_named_from_memory_only_when_one_fits() -> None:
    # bench episode 33: No.17 came up with No.18 (44 g for 23 g); No.18 was seen by the
    # first survey and hidden under No.17 in the survey the pick was chosen from
    from robot_app.control.clear_table_records import ClearTableSettings
    from robot_app.control.pick_checks import remembered_companion

    settings = ClearTableSettings()  # weight within 30 % + 3 g, footprint within 40 mm
    square = np.array([[x, y] for x in np.linspace(-0.1, 0.1, 21) for y in np.linspace(-0.1, 0.1, 21)])
    grasp = np.array([0.50, 0.02])
    weights = {"No.18": 0.0230, "No.4": 0.0229, "No.10": 0.0266, "No.2": 0.0450}
    under = square + np.array([0.56, 0.08])  # reaches to 0.46 in x: under the grasp point
    far = square + np.array([0.50, -0.25])  # its nearest point 0.13 m from the grasp
    assert remembered_companion(grasp, 0.0212, {"No.18": under, "No.4": far}, weights, settings) == "No.18"
    # a cloth remembered far from the fingers is not it, whatever it weighs
    assert remembered_companion(grasp, 0.0229, {"No.4": far}, weights, settings) is None
    # its weight must be the extra the load cell read
    assert remembered_companion(grasp, 0.0212, {"No.2": under}, weights, settings) is None
    # two remembered cloths under the grasp that both weigh it: no name from memory
    both = {"No.18": under, "No.10": square + np.array([0.52, 0.0])}
    assert remembered_companion(grasp, 0.0230, both, weights, settings) is None
    # off
    off = settings.model_copy(update={"remembered_reach": 0.0})
    assert remembered_companion(grasp, 0.0212, {"No.18": under}, weights, off) is None


def test_a_companion_is_named_only_within_the_load_cells_error() -> None:
    # held-out 1028 (session 37): 64.7 g lifted for No.7 (25.6 g); No.5 (30.6 g), the one
    # cloth it lay on, was named for the 39.1 g extra (8.5 g off, within 30 % + 3 g), and No.17
    # of whites, with No.15, went into colours in its stead
    from robot_app.control.clear_table_records import ClearTableSettings
    from robot_app.control.pick_checks import names_weight, remembered_companion, weighs_extra

    settings = ClearTableSettings()
    assert weighs_extra(0.0391, 0.0306, settings)  # the loose test a doubt uses lets it pass
    assert not names_weight(0.0391, 0.0306, settings)
    assert names_weight(0.0341, 0.0306, settings)  # 3.5 g off: the worst of the right namings
    assert not names_weight(0.0306, None, settings)
    square = np.array([[x, y] for x in np.linspace(-0.1, 0.1, 21) for y in np.linspace(-0.1, 0.1, 21)])
    under = {"No.5": square + np.array([0.56, 0.08])}
    grasp, weights = np.array([0.50, 0.02]), {"No.5": 0.0306}
    assert remembered_companion(grasp, 0.0391, under, weights, settings) is None
    assert remembered_companion(grasp, 0.0320, under, weights, settings) == "No.5"
    # a second cloth that fits only loosely still makes the name ambiguous
    under["No.4"] = square + np.array([0.52, 0.0])
    weights["No.4"] = 0.0250
    assert remembered_companion(grasp, 0.0320, under, weights, settings) is None


def test_a_remembered_companion_still_found_where_it_was_did_not_come_along(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # the job's side of the rule: the pick's survey did not see No.18, an earlier one did;
    # it is named only if the check after the lift no longer finds it where it was
    from types import SimpleNamespace

    from robot_app.control import table_clearer
    from robot_app.control.clear_table_records import ClearTableSettings
    from robot_app.control.table_ledger import TableLedger

    square = _square()
    job = table_clearer.TableClearer.__new__(table_clearer.TableClearer)
    job.settings = ClearTableSettings(survey_latency=0.0)
    job.weights = {"No.17": 0.0227, "No.18": 0.0230, "No.4": 0.0229}
    job.recognizers = {n: SimpleNamespace(model=square) for n in job.weights}  # type: ignore[misc]
    job.ledger = TableLedger()
    job.motion = SimpleNamespace(hold=lambda seconds: None)  # type: ignore[assignment]
    for name, x in (("No.18", 0.56), ("No.4", 0.50)):
        pose = np.eye(4)
        pose[:2, 3] = (x, 0.08 if name == "No.18" else -0.25)
        job.ledger.last_pose[name] = pose
    attempt = SimpleNamespace(target=SimpleNamespace(name="No.17"), name="No.17", others=(), check_wall_s=0.0)
    grasp = np.array([0.50, 0.02, 0.0])
    found = {"No.18": False}
    monkeypatch.setattr(table_clearer, "still_there", lambda recognizer, *_: found["No.18"])
    assert job._remembered_companion(attempt, None, grasp, 0.0212) == "No.18"  # type: ignore[arg-type]
    found["No.18"] = True  # still lies where it was: not in the gripper
    assert job._remembered_companion(attempt, None, grasp, 0.0212) is None  # type: ignore[arg-type]
    found["No.18"] = False
    job.ledger.placed_order.append("No.18")  # put away before: not on the table
    assert job._remembered_companion(attempt, None, grasp, 0.0212) is None  # type: ignore[arg-type]
    job.ledger.placed_order.clear()
    attempt.others = (SimpleNamespace(name="No.18"),)  # the pick's own survey saw it elsewhere
    assert job._remembered_companion(attempt, None, grasp, 0.0212) is None  # type: ignore[arg-type]


def test_a_surveyed_cloth_that_weighs_the_extra_but_stayed_in_place_is_not_carried_along(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # bench episode 33 (this session): No.10 came up with No.17, hidden and never identified
    # (47 g for 27 g); No.4, which the pick's survey saw by the grasp point and which weighs
    # about the extra, was named and "placed" with it, though it still lay in its place (it
    # was picked from there two picks later): had No.17 stayed in the gripper, a white cloth
    # would have gone into the colours box
    from types import SimpleNamespace

    from robot_app.control import table_clearer
    from robot_app.control.clear_table_records import ClearTableSettings
    from robot_app.control.episode import EpisodeAbortError
    from robot_app.control.table_ledger import TableLedger

    job = table_clearer.TableClearer.__new__(table_clearer.TableClearer)
    job.settings = ClearTableSettings(survey_latency=0.0, held_look={"name_companion": False})
    job.weights = {"No.10": 0.0266, "No.4": 0.0229, "No.17": 0.0227}
    job.recognizers = {n: SimpleNamespace(name=n, model=_square()) for n in job.weights}  # type: ignore[misc]
    job.ledger = TableLedger()
    job.table_z = 0.0
    job.weigh = lambda: 0.0469
    job.cell = SimpleNamespace(capture=lambda: None)  # type: ignore[assignment]
    job.motion = SimpleNamespace(  # type: ignore[assignment]
        hold=lambda seconds: None, tcp_position=lambda: np.array([0.46, -0.05, 0.4]), q=np.zeros(7)
    )
    resumed: list[np.ndarray] = []
    loop = SimpleNamespace(
        arm=SimpleNamespace(resume_at=resumed.append)
    )  # the loop goes on from the put-back
    job.rig = SimpleNamespace(right=None)  # type: ignore[assignment]
    job._survey_capture = SimpleNamespace(transform_right_camera_to_world=np.eye(4))  # type: ignore[assignment]
    job.sort = SortSettings(default="colours", boxes={"whites": (6, 17, 18)})
    job._hidden_spots = {}
    job._laid = []  # nothing laid back before
    put_back: list[str] = []
    job.recovery = SimpleNamespace(  # type: ignore[assignment]
        put_back=lambda *args: (put_back.append("No.10"), (np.zeros(2), np.zeros(2)))[1],
        put_back_spots=[np.zeros(2)],
    )
    four = SimpleNamespace(name="No.4", transform_model_to_camera=np.eye(4))
    attempt = table_clearer.AttemptState(
        SimpleNamespace(name="No.10"),  # type: ignore[arg-type]
        SimpleNamespace(name="colours"),  # type: ignore[arg-type]
        np.eye(4),
        0.0,
        others=(four,),  # type: ignore[arg-type]
    )
    monkeypatch.setattr(table_clearer, "companion", lambda *args: "No.4")  # No.4 is by the grasp and fits
    stays = {"No.10": False, "No.4": True}  # the target left its place, No.4 did not
    monkeypatch.setattr(table_clearer, "still_there", lambda recognizer, *args: stays[recognizer.name])
    with pytest.raises(EpisodeAbortError):
        job._after_lift(attempt, loop)  # type: ignore[arg-type]
    assert attempt.lift_check == "double" and attempt.came_along == () and put_back == ["No.10"]
    assert len(resumed) == 1
    # gone from its place: it came along, and both go into the colours box
    stays["No.4"] = False
    again = table_clearer.AttemptState(attempt.target, attempt.box, np.eye(4), 0.0, others=(four,))  # type: ignore[arg-type]
    job._after_lift(again, loop)  # type: ignore[arg-type]
    assert again.came_along == ("No.4",) and put_back == ["No.10"] and len(resumed) == 1


def test_put_back_lays_out_on_the_table_top_clear_of_the_boxes() -> None:
    # Bench episode 24 (session 18): a double lift at (0.51, 0.49), by the whites box
    # (centre (0.30, 0.56), inner 0.22 m, walls 0.01 m) and 0.21 m from the table's edge at
    # y = 0.70, was put back from a look-around view that reached past both; the heap then
    # hung over the edge, where no blind grasp could close on it.
    table = TableArea((-0.30, 1.00), (-0.70, 0.70))
    view = np.array([[0.30, 0.30], [0.80, 0.30], [0.80, 0.90], [0.30, 0.90]])
    walls = [(np.array([0.30, 0.56]), 0.12)]
    settings = PutBackSettings(directions=12, max_length=0.25, view_margin=0.04, waypoints=3)
    start, reach, half_width = np.array([0.51, 0.49]), 0.2, 0.06
    unbounded = lay_out_paths(start, reach, 0.0, 0.05, np.empty((0, 2)), view, settings, half_width)
    # the view alone lets the laid cloth reach past the edge
    assert any(p.fits and p.waypoints[-1, 1] + half_width > 0.70 for p in unbounded)
    paths = lay_out_paths(
        start, reach, 0.0, 0.05, np.empty((0, 2)), view, settings, half_width, table.corners(), walls
    )
    fitting = [p for p in paths if p.fits]
    assert fitting and paths[0].fits
    for path in fitting:  # the laid cloth on the table top and off the box, by the margin
        laid = start + np.linspace(0.0, 1.0, 11)[1:, None] * (path.waypoints[-1, :2] - start)
        assert np.all(laid[:, 1] + half_width <= 0.70 - settings.view_margin + 1e-9)
        outside = np.max(np.abs(laid - walls[0][0]), axis=1) - walls[0][1]
        assert np.all(outside >= half_width + settings.view_margin - 1e-9)
    for path in paths:  # no strip at all enters the box or leaves the table
        end = path.waypoints[-1, :2]
        assert end[1] <= 0.70 - settings.view_margin + 1e-9
        assert np.max(np.abs(end - walls[0][0])) - walls[0][1] >= settings.view_margin - 1e-9
