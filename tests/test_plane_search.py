"""The plane search's shortlist of distinct coarse poses, against a brute-force greedy oracle."""

from __future__ import annotations

import numpy as np
import pytest

from robot_app.vision.plane_search import _distinct


def _greedy(order, a, b, yaw, separation, turn, wanted):
    """The shortlist as first written: every pose in `order` against every pose taken."""
    chosen: list[int] = []
    for k in order:
        if all(
            np.hypot(a[k] - a[j], b[k] - b[j]) > separation
            or abs(np.angle(np.exp(1j * (yaw[k] - yaw[j])))) > turn
            for j in chosen
        ):
            chosen.append(int(k))
            if len(chosen) == wanted:
                break
    return chosen


@pytest.mark.parametrize(
    ("radius", "yaws_deg", "wanted", "seed"),
    [
        (0.036, np.arange(0.0, 360.0, 8.0), 64, 0),  # every yaw (wraps around)
        (0.036, np.concatenate([np.arange(-16.0, 16.1, 8.0) + q * 90.0 for q in range(4)]), 16, 1),  # turns
        (0.012, np.arange(0.0, 360.0, 8.0), 10_000, 2),  # more wanted than there are: all distinct ones
    ],
)
def test_the_shortlist_is_the_greedy_one(radius: float, yaws_deg: np.ndarray, wanted: int, seed: int) -> None:
    span = np.arange(-radius, radius + 1e-12, 0.004)
    yaws = np.deg2rad(yaws_deg)
    a, b, yaw = (g.ravel() for g in np.meshgrid(span, span, yaws, indexing="ij"))
    order = np.argsort(-np.random.default_rng(seed).uniform(size=len(a)), kind="stable")
    expected = _greedy(order, a, b, yaw, 0.008, np.deg2rad(20.0), wanted)
    got = _distinct(order, span, yaws, 0.008, np.deg2rad(20.0), wanted)
    assert got == expected
    assert len(got) == min(wanted, len(expected))
