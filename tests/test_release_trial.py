"""The release trial (`experiments.clear_table.release_trial`, `scripts/bench_release.py`):
where its grasps are drawn, and bad input."""

from __future__ import annotations

import subprocess
import sys
from dataclasses import dataclass

import numpy as np
import pytest

from robot_app.config import load_config
from robot_app.errors import ConfigError
from robot_app.experiments.clear_table import APART, TOGETHER, ClearTableConfig, _trial_grasp, release_trial

CONFIG = "configs/clear_table.yaml"


@dataclass
class _Body:
    points: np.ndarray

    def nodes(self) -> np.ndarray:
        return self.points


@dataclass
class _Cloth:
    body: _Body


def _grid(x0: float, x1: float, y0: float, y1: float, step: float = 0.01) -> np.ndarray:
    xs, ys = np.meshgrid(np.arange(x0, x1 + 1e-9, step), np.arange(y0, y1 + 1e-9, step))
    return np.column_stack([xs.ravel(), ys.ravel(), np.zeros(xs.size)])


def test_grasp_keeps_clear_of_the_cloths_still_on_the_table_and_near_the_edge() -> None:
    cloth = _Cloth(_Body(_grid(0.0, 0.2, 0.0, 0.2)))
    other = _Cloth(_Body(_grid(0.1, 0.3, 0.0, 0.2)))  # covers the right half
    centre = cloth.body.points[:, :2].mean(axis=0)
    radius = np.linalg.norm(cloth.body.points[:, :2] - centre, axis=1).max()
    rng = np.random.default_rng(0)
    for _ in range(50):
        point = _trial_grasp(cloth, [other], 0.1, rng)  # type: ignore[arg-type]
        assert point[0] < 0.1 - APART + 1e-9  # clear of the other cloth
        assert np.linalg.norm(point[:2] - centre) > 0.8 * radius  # out at the edge
    anywhere = {tuple(_trial_grasp(cloth, [], 1.0, rng)) for _ in range(200)}  # type: ignore[arg-type]
    assert min(p[0] for p in anywhere) < 0.05 and max(p[0] for p in anywhere) > 0.15


def test_a_pair_grasp_lies_where_the_cloth_lies_on_another() -> None:
    cloth = _Cloth(_Body(_grid(0.0, 0.2, 0.0, 0.2)))
    other = _Cloth(_Body(_grid(0.15, 0.35, 0.0, 0.2)))
    rng = np.random.default_rng(2)
    for _ in range(20):
        point = _trial_grasp(cloth, [other], 1.0, rng, together=True)  # type: ignore[arg-type]
        assert np.min(np.linalg.norm(other.body.points[:, :2] - point[:2], axis=1)) <= TOGETHER


def test_grasp_falls_back_to_any_node_where_every_one_is_covered() -> None:
    cloth = _Cloth(_Body(_grid(0.0, 0.1, 0.0, 0.1)))
    over = _Cloth(_Body(_grid(-0.05, 0.15, -0.05, 0.15)))
    point = _trial_grasp(cloth, [over], 1.0, np.random.default_rng(1))  # type: ignore[arg-type]
    assert any(np.allclose(point, p) for p in cloth.body.points)


@pytest.mark.parametrize("edge", [0.0, 1.5])
def test_trial_refuses_an_edge_share_outside_0_1(edge: float) -> None:
    config = load_config(ClearTableConfig, CONFIG, ["pile.count=[2,2]"])
    with pytest.raises(ConfigError, match="edge"):
        release_trial(config, "colours", edge)


def test_script_refuses_an_unknown_box_without_running() -> None:
    run = subprocess.run(
        [sys.executable, "scripts/bench_release.py", "--seeds", "1", "--box", "socks"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert run.returncode != 0
    assert "no box 'socks'" in run.stderr and "colours" in run.stderr
    assert "Traceback" not in run.stderr
