"""The clear-table witness tells a cloth the simulator flung (a soft-body blow-up) from one
the robot moved, and the judge says so in the episode's cause."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from robot_app.experiments.clear_table_faults import WATCH_EVERY, Flung, PickWitness
from robot_app.sim.checks import BLOW_UP_SPEED


class _Cloth:
    def __init__(self, number: int) -> None:
        self.number = number
        self.points = np.zeros((4, 3))
        self.body = SimpleNamespace(nodes=lambda: self.points.copy())


def _run(
    witness: PickWitness, world: SimpleNamespace, moves: dict[int, float], dt: float, steps: int
) -> None:
    """`steps` control steps of `dt` [s]; each cloth in `moves` moves one node at that speed [m/s]."""
    for _ in range(steps):
        world.time += dt
        for cloth in witness.pile.cloths:
            cloth.points[0, 0] += moves.get(cloth.number, 0.0) * dt
        witness.on_step("put back", "No.3")


def test_a_node_faster_than_a_blow_up_is_noted_once_a_carried_or_falling_one_is_not() -> None:
    world = SimpleNamespace(time=0.0, config=SimpleNamespace(table=SimpleNamespace(top_z=0.0)))
    cloths = [_Cloth(3), _Cloth(7), _Cloth(12), _Cloth(15)]
    cloths[3].points[:, 2] = -0.3  # No.15 fell off the table: its edge whips past the floor
    witness = PickWitness(world, SimpleNamespace(cloths=cloths))  # type: ignore[arg-type]
    dt = 1 / 60
    # carried by the arm (1.5 m/s), falling from the table to the floor (3.8 m/s), whipping
    # below the table's top (2x the blow-up speed): not flung
    _run(witness, world, {3: 1.5, 7: 3.8, 15: 2 * BLOW_UP_SPEED}, dt, 4 * WATCH_EVERY)
    assert witness.flung == {}
    # No.12 flung at twice the blow-up speed
    _run(witness, world, {12: 2 * BLOW_UP_SPEED}, dt, 2 * WATCH_EVERY)
    assert set(witness.flung) == {12}
    fling = witness.flung[12]
    assert fling.phase == "put back" and abs(fling.speed - 2 * BLOW_UP_SPEED) < 1e-6
    first = fling.time
    _run(witness, world, {12: 3 * BLOW_UP_SPEED}, dt, 2 * WATCH_EVERY)
    assert witness.flung[12].time == first  # the first fling is kept


def test_the_judge_names_the_fling_in_the_cause_of_a_cloth_not_in_its_box(monkeypatch) -> None:
    from robot_app.control.sort_rule import SortSettings
    from robot_app.experiments import clear_table_judge

    cloths = [SimpleNamespace(number=3, body="b3"), SimpleNamespace(number=7, body="b7")]
    world = SimpleNamespace(boxes=[SimpleNamespace(name="colours"), SimpleNamespace(name="whites")])
    result = SimpleNamespace(cloths=(), attempts=(), unknown=(), interrupted=False)
    where = {"b3": "floor", "b7": "colours"}  # No.3 on the floor, No.7 in its box
    monkeypatch.setattr(clear_table_judge, "final_place", lambda w, body: (where[body], 0.0))
    flung = {3: Flung(16.1, "put back", 12.0), 7: Flung(20.0, "lift", 6.0)}
    sort, known = SortSettings(default="colours"), {"No.3", "No.7"}
    verdict = clear_table_judge.judge(world, SimpleNamespace(cloths=cloths), result, [], sort, known, flung)  # type: ignore[arg-type]
    assert not verdict.cleared and verdict.flung == (3, 7)
    assert verdict.cause is not None and "No.3 ended in floor" in verdict.cause
    assert "flung by the simulator: a node at 12 m/s at 16.1 s, put back" in verdict.cause
    assert "No.7" not in verdict.cause  # in its box: no problem, whatever the simulator did
    unflung = clear_table_judge.judge(world, SimpleNamespace(cloths=cloths), result, [], sort, known)  # type: ignore[arg-type]
    assert unflung.flung == () and unflung.cause is not None and "flung" not in unflung.cause


def test_a_lift_counts_the_cloths_that_rose_by_the_hand_not_those_lying_as_high_in_a_box() -> None:
    # held-out 1350 (session 42): blind grasps by the colours box's wall closed on nothing,
    # and the cloths heaped in the box beside them were counted as lifted (a double pick)
    world = SimpleNamespace(
        time=0.0,
        config=SimpleNamespace(table=SimpleNamespace(top_z=0.0)),
        robot=SimpleNamespace(frame_pose=lambda name: np.eye(4)),  # the TCP over the origin
    )
    held, dragged, boxed, apart = _Cloth(3), _Cloth(7), _Cloth(12), _Cloth(15)
    for cloth in (held, dragged, boxed):
        cloth.points[:, :2] = 0.1  # within reach of the TCP
    boxed.points[:, 2] = 0.08  # heaped over the box's rim, above HOLD_HEIGHT
    apart.points[:, :2] = 1.0
    witness = PickWitness(world, SimpleNamespace(cloths=[held, dragged, boxed, apart]))  # type: ignore[arg-type]
    witness.on_phase(SimpleNamespace(phase="grasp"), "No.3")  # type: ignore[arg-type]
    held.points[:, 2] = 0.20
    dragged.points[:2, 2] = 0.15  # half of it hangs from the held one
    apart.points[:, 2] = 0.30
    boxed.points[:, 2] += 0.005  # settles, does not rise
    assert witness._hanging() == (3, 7)
    boxed.points[:, 2] += 0.05  # raised with the hand after all
    assert witness._hanging() == (3, 7, 12)
