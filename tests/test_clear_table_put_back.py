"""Where a rejected lift is laid back: away from the pile it came from (`free_starts`)."""

from __future__ import annotations

import numpy as np

from robot_app.control.clear_table_records import ClearTableSettings
from robot_app.control.job_motion import lay_out_paths
from robot_app.control.table_recovery import free_starts

VIEW = np.array([[-0.30, -0.20], [0.30, -0.20], [0.30, 0.20], [-0.30, 0.20]])  # the survey's view [m]
REACH, HALF_WIDTH = 0.15, 0.05


def _disk(centre: tuple[float, float], radius: float) -> np.ndarray:
    g = np.arange(-radius, radius + 1e-9, 0.005)
    xy = np.stack(np.meshgrid(g, g), -1).reshape(-1, 2)
    return xy[np.hypot(*xy.T) <= radius] + np.asarray(centre)


def _laid_clearance(start: np.ndarray, obstacles: np.ndarray, settings: ClearTableSettings) -> float:
    """Ground truth: the nearest other cloth's point to the best laid strip, brute force."""
    path = lay_out_paths(
        start, REACH, 0.0, settings.put_down_height, obstacles, VIEW, settings.put_back, HALF_WIDTH
    )[0]
    strip = start + np.linspace(0.0, 1.0, 101)[:, None] * (path.waypoints[-1, :2] - start)
    return float(np.min(np.linalg.norm(strip[:, None, :] - obstacles[None, :, :], axis=2)))


def test_a_lift_from_a_pile_is_laid_out_clear_of_every_other_cloth() -> None:
    settings = ClearTableSettings(put_back_away=0.3)
    lifted = np.array([0.0, 0.0])
    # the pile the pair came from (the meant cloth's own place is not an obstacle: a ring)
    # and two more cloths around it
    pile = _disk((0.0, 0.0), 0.10)
    pile = pile[np.hypot(*pile.T) >= 0.04]
    obstacles = np.concatenate([pile, _disk((-0.20, 0.10), 0.06), _disk((0.20, -0.12), 0.05)])
    starts = free_starts(lifted, REACH, HALF_WIDTH, obstacles, VIEW, 0.0, settings)
    assert starts, "the view has free table"
    best = starts[0]
    assert np.hypot(*(best - lifted)) <= settings.put_back_away + 1e-9
    here = _laid_clearance(lifted, obstacles, settings)
    there = _laid_clearance(best, obstacles, settings)
    assert here < HALF_WIDTH  # laid from the lift, the cloth lands on the pile
    assert there >= HALF_WIDTH  # laid from the start found, it touches no other cloth
    path = lay_out_paths(
        best, REACH, 0.0, settings.put_down_height, obstacles, VIEW, settings.put_back, HALF_WIDTH
    )[0]
    assert path.fits  # and stays in the view, where the next survey sees it


def test_a_lift_already_on_free_table_stays_where_it_was_lifted() -> None:
    settings = ClearTableSettings(put_back_away=0.3)
    lifted = np.array([0.05, 0.0])
    far = _disk((-0.27, -0.17), 0.02)  # one cloth in a corner, far from every lay-out from here
    assert free_starts(lifted, REACH, HALF_WIDTH, far, VIEW, 0.0, settings) == []
    assert free_starts(lifted, REACH, HALF_WIDTH, np.empty((0, 2)), VIEW, 0.0, settings) == []


def test_no_start_beyond_the_distance_allowed() -> None:
    settings = ClearTableSettings(put_back_away=0.05)
    obstacles = _disk((0.0, 0.0), 0.12)
    obstacles = obstacles[np.hypot(*obstacles.T) >= 0.03]
    starts = free_starts(np.zeros(2), REACH, HALF_WIDTH, obstacles, VIEW, 0.0, settings)
    assert all(np.hypot(*s) <= 0.05 + 1e-9 for s in starts)
