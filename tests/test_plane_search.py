"""The plane search: its shortlist of distinct coarse poses against a brute-force greedy oracle;
the turns of its best end against a half-turn-symmetric hue fitness."""

from __future__ import annotations

import numpy as np
import pytest

from robot_app.vision.plane_search import PlaneSearchSettings, _distinct, search_in_plane


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


def _yaw(poses: np.ndarray) -> np.ndarray:
    return np.arctan2(poses[:, 1, 0], poses[:, 0, 0])


@pytest.mark.parametrize("turns", [True, False])
def test_a_candidate_half_turned_on_the_truth_is_turned_back(turns: bool) -> None:
    """A print whose hue matches itself half-turned about the cloth's centre (a periodic
    print): the coarse grid's best by hue is the half turn; the texture (the rank) knows the
    truth only within about a millimetre and a degree, finer than the coarse grid, so it
    cannot pick the truth's coarse neighbour. With `turns` each candidate's half turn is
    refined too, and the rank then finds the truth; without, the best is half a turn off."""
    base = np.eye(4)
    base[:3, 3] = [0.0, 0.0, 0.58]
    truth_xy, truth_yaw = np.array([0.0013, -0.0021]), np.deg2rad(8.0 * 5 + 3.0)  # off the grids

    def offsets(poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        d = np.hypot(*(poses[:, :2, 3] - base[:2, 3] - truth_xy).T)
        return d, np.angle(np.exp(1j * (_yaw(poses) - truth_yaw)))

    def hue(poses: np.ndarray) -> np.ndarray:  # a half turn matches as well, slightly better
        d, turn = offsets(poses)
        return np.exp(-0.5 * (d / 0.004) ** 2) * (0.5 + 0.5 * np.cos(2.0 * turn) - 0.01 * np.cos(turn))

    def texture(poses: np.ndarray) -> np.ndarray:  # only near the truth does the texture agree
        d, turn = offsets(poses)
        return np.maximum(-((d / 0.0005) ** 2) - (np.rad2deg(turn) / 0.5) ** 2, -4.0)

    out = search_in_plane(base, hue, hue, hue, PlaneSearchSettings(candidates=1), texture, turns=turns)
    best = out[int(np.argmax(texture(out)))][None]
    d, turn = offsets(best)
    if turns:
        assert d[0] < 0.0005 and abs(np.rad2deg(turn[0])) < 0.5
    else:
        assert abs(np.rad2deg(turn[0])) > 170.0


@pytest.mark.parametrize("yaw_range", [90.0, 16.0])
def test_the_turns_add_three_refined_poses_whatever_the_yaw_grid(yaw_range: float) -> None:
    """Three more poses with `turns` (the best end half and quarter turned), on either yaw grid."""
    base = np.eye(4)
    base[:3, 3] = [0.0, 0.0, 0.58]

    def hue(poses: np.ndarray) -> np.ndarray:
        return -np.hypot(*(poses[:, :2, 3] - base[:2, 3]).T)

    settings = PlaneSearchSettings(yaw_range=yaw_range)
    plain = search_in_plane(base, hue, hue, hue, settings, hue)
    turned = search_in_plane(base, hue, hue, hue, settings, hue, turns=True)
    assert len(plain) == settings.candidates and len(turned) == settings.candidates + 3
    np.testing.assert_allclose(turned[: len(plain)], plain)
