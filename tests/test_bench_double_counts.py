"""The clear-table bench's counts for detected double picks, against the simulator's truth:
the other cloth named right or wrong, both placed, put back (`double_pick_counts`)."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType, SimpleNamespace

from robot_app.control.episode import Outcome
from robot_app.experiments.clear_table_faults import LiftTruth

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "bench_clear_table.py"


def _bench() -> ModuleType:
    spec = importlib.util.spec_from_file_location("bench_clear_table", SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _attempt(
    name: str, start: float, end: float, check: str, outcome: Outcome, **kw: object
) -> SimpleNamespace:
    fields: dict[str, object] = {"came_along": (), "laid_back_too": (), "put_back": False} | kw
    return SimpleNamespace(
        name=name,
        start_time=start,
        end_time=end,
        lift_check=check,
        not_meant_alone=check in ("double", "wrong"),
        result=SimpleNamespace(outcome=outcome),
        **fields,
    )


def test_double_picks_are_counted_against_the_truth() -> None:
    attempts = [
        # No.3 came up with No.12, named, both placed
        _attempt("No.3", 0, 10, "double", Outcome.PLACED, came_along=("No.12",)),
        # No.5 came up with No.8, No.4 named: wrong, put back (another box)
        _attempt("No.5", 10, 20, "double", Outcome.GRASP_FAILED, laid_back_too=("No.4",), put_back=True),
        # No.9 came up with No.2 and No.13, only No.2 named: wrong (No.13 unbooked)
        _attempt("No.9", 20, 30, "double", Outcome.PLACED, came_along=("No.2",)),
        # No.6 came up with No.17, nothing named, put back
        _attempt("No.6", 30, 40, "double", Outcome.GRASP_FAILED, put_back=True),
        # a double pick the lift check missed: not a detected one
        _attempt("No.1", 40, 50, "ok", Outcome.PLACED),
        # a false alarm (one cloth lifted): no double pick
        _attempt("No.7", 50, 60, "double", Outcome.GRASP_FAILED, put_back=True),
    ]
    lifts = [
        LiftTruth(1, 5, "No.3", (3, 12)),
        LiftTruth(2, 15, "No.5", (5, 8)),
        LiftTruth(3, 25, "No.9", (9, 2, 13)),
        LiftTruth(4, 35, "No.6", (6, 17)),
        LiftTruth(5, 45, "No.1", (1, 11)),
        LiftTruth(6, 55, "No.7", (7,)),
    ]
    episode = SimpleNamespace(result=SimpleNamespace(attempts=attempts), lifts=lifts)
    assert _bench().double_pick_counts(episode) == {
        "double_named": 3,
        "double_named_right": 1,
        "double_named_wrong": 2,
        "double_both_placed": 2,
        "double_put_back": 2,
    }
