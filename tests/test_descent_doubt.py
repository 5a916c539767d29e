"""DESCEND's doubt rule (robot_app/control/descent_doubt.py) and the TCP height profile."""

from __future__ import annotations

import math

import pytest

from robot_app.control.descent_doubt import DOUBTED_VIEWS, DescentDoubt, Verdict
from robot_app.control.height_profile import CLOTH_SURFACE_MAX, HeightProfile, tcp_height
from robot_app.control.pose_filter import FilterUpdate, UpdateReason


def update(accepted: bool, reason: UpdateReason, distance: float = 0.002) -> FilterUpdate:
    return FilterUpdate(accepted, reason, math.nan, None, distance)


NEAR = update(True, UpdateReason.ACCEPTED, 0.002)
FAR = update(True, UpdateReason.ACCEPTED, 0.02)  # fused with little weight, 20 mm off
GATED = update(False, UpdateReason.MAHALANOBIS, 0.03)
POOR = update(False, UpdateReason.LOW_FITNESS_CONSISTENT, 0.003)


def test_views_near_the_prediction_neither_doubt_nor_clear() -> None:
    doubt = DescentDoubt(0.9)
    assert [doubt.judge(NEAR, 0.9) for _ in range(5)] == [Verdict.NONE] * 5
    assert not doubt.standing and not doubt.lost


def test_a_gated_or_far_view_doubts_and_a_near_one_clears() -> None:
    doubt = DescentDoubt(0.9)
    assert doubt.judge(GATED, 0.8) is Verdict.DOUBTED
    assert doubt.judge(FAR, 0.8) is Verdict.DOUBTED
    assert doubt.standing and not doubt.lost
    assert doubt.judge(NEAR, 0.8) is Verdict.CLEARED
    assert not doubt.standing


def test_a_poor_view_doubts_only_if_it_turned_poor_at_once() -> None:
    drifting = DescentDoubt(0.35)
    assert drifting.judge(POOR, 0.28) is Verdict.NONE  # drifted across min_fitness
    turned = DescentDoubt(0.9)
    assert turned.judge(POOR, 0.2) is Verdict.DOUBTED  # below half of the previous view's
    assert turned.judge(POOR, 0.25) is Verdict.DOUBTED  # a doubt run is on: poor goes on doubting


def test_doubted_views_in_a_row_lose_the_cloth() -> None:
    doubt = DescentDoubt(0.9)
    for _ in range(DOUBTED_VIEWS):
        doubt.judge(GATED, 0.9)
    assert doubt.lost


def test_the_height_profile_starts_and_ends_at_rest() -> None:
    profile = HeightProfile(0.15, 0.15, 0.0, 1.0).to(0.022, 1.0, speed=0.2)
    assert profile.at(1.0) == pytest.approx(0.15) and profile.at(profile.end) == pytest.approx(0.022)
    assert profile.duration == pytest.approx(0.128 / 0.2)
    for t in (profile.start, profile.end):
        assert profile.rate(t) == pytest.approx(0.0) and profile.acceleration(t) == pytest.approx(0.0)
    middle = (profile.start + profile.end) / 2
    assert profile.rate(middle) == pytest.approx(-0.2 * 1.875)  # the quintic's peak is 15/8 of the mean


def test_the_tcp_height_keeps_the_cloth_on_the_belt() -> None:
    table = 0.7
    assert tcp_height(table + 0.004, 0.022, table, 0.02) == pytest.approx(table + 0.026)
    assert tcp_height(table + 0.05, 0.022, table, 0.02) == pytest.approx(table + CLOTH_SURFACE_MAX + 0.022)
    assert tcp_height(table - 0.03, 0.0, table, 0.02) == pytest.approx(table + 0.02)
