"""Where the judge says a cloth ended: inside a box's walls at any height, partly in, table, floor."""

from types import SimpleNamespace

import numpy as np

from robot_app.experiments.clear_table_judge import final_place
from robot_app.sim.world import BoxGeometry

TOP = 0.70  # table top [m]
BOX = BoxGeometry(np.array([0.3, -0.56, TOP]), 0.22, 0.10, "colours")
OTHER = BoxGeometry(np.array([0.3, 0.56, TOP]), 0.22, 0.10, "whites")
WORLD = SimpleNamespace(boxes=[BOX, OTHER], config=SimpleNamespace(table=SimpleNamespace(top_z=TOP)))


def _cloth(nodes: np.ndarray, grasped: bool = False) -> SimpleNamespace:
    return SimpleNamespace(nodes=lambda: nodes, is_grasped=grasped)


def _grid(centre: np.ndarray, half: float, z: float, n: int = 10) -> np.ndarray:
    xs = np.linspace(-half, half, n)
    gx, gy = np.meshgrid(xs, xs)
    return np.column_stack([gx.ravel() + centre[0], gy.ravel() + centre[1], np.full(n * n, z)])


def test_a_cloth_heaped_over_the_rim_inside_the_walls_is_in_the_box_and_its_share_over_reported() -> None:
    nodes = _grid(BOX.centre, 0.09, TOP + 0.06)
    nodes[:12, 2] = TOP + 0.12  # a fold standing 2 cm over the 10 cm walls
    place, over = final_place(WORLD, _cloth(nodes))  # type: ignore[arg-type]
    assert place == "colours"
    assert abs(over - 0.12) < 1e-9
    assert float(np.mean(BOX.contains(nodes))) < 0.9  # what the rim-high rule counted as partly in


def test_a_cloth_hanging_over_a_wall_is_partly_in() -> None:
    nodes = _grid(BOX.centre + np.array([0.05, 0.0, 0.0]), 0.09, TOP + 0.05)  # a fifth over the wall
    place, over = final_place(WORLD, _cloth(nodes))  # type: ignore[arg-type]
    assert place == "partly in colours" and over == 0.0


def test_the_other_box_the_table_the_floor_and_the_hand() -> None:
    assert final_place(WORLD, _cloth(_grid(OTHER.centre, 0.08, TOP + 0.01)))[0] == "whites"  # type: ignore[arg-type]
    table = _grid(np.array([0.5, 0.0]), 0.1, TOP + 0.008)
    assert final_place(WORLD, _cloth(table))[0] == "table"  # type: ignore[arg-type]
    assert final_place(WORLD, _cloth(table - [0, 0, 0.7]))[0] == "floor"  # type: ignore[arg-type]
    held = _grid(BOX.centre, 0.05, TOP + 0.3)  # hanging from the fingers over the box
    assert final_place(WORLD, _cloth(held, grasped=True)) == ("in the hand", 0.0)  # type: ignore[arg-type]


def test_a_drag_noticed_by_the_next_survey_counts_apart_from_the_lift_checks(monkeypatch) -> None:
    from robot_app.control.sort_rule import SortSettings
    from robot_app.experiments import clear_table_judge
    from robot_app.experiments.clear_table_faults import LiftTruth

    cloths = [SimpleNamespace(number=8, body="b8"), SimpleNamespace(number=18, body="b18")]
    monkeypatch.setattr(clear_table_judge, "final_place", lambda w, body: ("colours", 0.0))
    first = SimpleNamespace(start_time=0.0, end_time=10.0, not_meant_alone=False)
    second = SimpleNamespace(start_time=11.0, end_time=20.0, not_meant_alone=False)
    lifts = [
        LiftTruth(1, 5.0, "No.8", (8, 18), (8,), False, False),  # No.18 dragged along, unnoticed
        LiftTruth(2, 15.0, "No.18", (18,), (18,), False, False),
    ]
    sort, known = SortSettings(default="colours"), {"No.8", "No.18"}

    def verdict(moved_by: tuple[int, ...]):
        result = SimpleNamespace(
            cloths=(), attempts=(first, second), unknown=(), interrupted=False, moved_by=moved_by
        )
        return clear_table_judge.judge(WORLD, SimpleNamespace(cloths=cloths), result, lifts, sort, known)  # type: ignore[arg-type]

    seen = verdict((1,))  # the survey after attempt 1 saw an unidentified cloth moved
    assert (seen.double_picks, seen.double_picks_detected, seen.double_picks_noticed_after) == (1, 0, 1)
    assert verdict((2,)).double_picks_noticed_after == 0  # after another attempt: not this drag
    assert verdict(()).double_picks_noticed_after == 0
