"""Views of a cloth lying far out (bench_clear_table episode 32, session 19: a cloth laid
back at x = 0.78 m; centring the cameras over it put the TCP 10 mm out of reach at the
observation height, and the attempt ended ik_unreachable): the search's centring look goes
as far towards the candidate as the arm reaches, and the look-then-move APPROACH hovers lower
where it must, never so low that the cameras stop seeing the cloth."""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from robot_app.control.episode import EpisodeAbortError, Outcome
from robot_app.control.look_then_move import HOVER_MARGIN, HOVER_STEP, LookThenMoveStrategy
from robot_app.control.loop_settings import LoopSettings
from robot_app.control.pick_place import CENTRING_SHARES, PickPlaceLoop

SHOULDER = np.array([0.0, 0.0, 0.10])  # a reach sphere about the shoulder stands in for the arm's IK
REACH = 0.9  # [m]
HOVER_TCP_Z, CAMERA_ABOVE_TCP = 0.48, 0.15
CAMERA_AHEAD = 0.07  # [m] the right camera lies this far along +x of the TCP


class SphereArm:
    """An arm whose TCP reaches every point within `REACH` of `SHOULDER`."""

    preferred_posture = np.zeros(7)
    asked: list[float]

    def __init__(self) -> None:
        self.asked = []

    def tcp_position(self, q=None) -> np.ndarray:
        return np.array([0.55, 0.0, HOVER_TCP_Z])

    def frame_position(self, frame: str, q=None) -> np.ndarray:
        return np.array([0.55 + CAMERA_AHEAD, 0.0, HOVER_TCP_Z + CAMERA_ABOVE_TCP])

    def solve_tcp(self, position, seed=None) -> np.ndarray:
        p = np.asarray(position, dtype=float)
        self.asked.append(float(p[2]))
        if np.linalg.norm(p - SHOULDER) > REACH:
            raise EpisodeAbortError(Outcome.IK_UNREACHABLE, f"no IK solution for {p}")
        return np.array([*p, 0.0, 0.0, 0.0, 0.0])  # the joints stand for the TCP position here


class OutOfReachArm(SphereArm):
    """An arm that reaches nothing."""

    def solve_tcp(self, position, seed=None) -> np.ndarray:
        raise EpisodeAbortError(Outcome.IK_UNREACHABLE, f"no IK solution for {position}")


def test_the_hover_comes_down_only_as_far_as_the_arm_needs_and_the_cameras_allow() -> None:
    arm, settings = SphereArm(), LoopSettings()
    strategy = LookThenMoveStrategy(arm, SimpleNamespace(), settings, table_z=0.0)  # type: ignore[arg-type]
    near = np.array([0.55, 0.0, 0.01])
    target, joints = strategy._hover(near)
    assert target[2] == pytest.approx(HOVER_TCP_Z) and arm.asked == [HOVER_TCP_Z]  # in reach: unchanged
    far = np.array([0.85, 0.10, 0.01])  # out of reach at the observation height, in reach lower
    assert np.linalg.norm([0.85, 0.10, HOVER_TCP_Z] - SHOULDER) > REACH
    target, joints = strategy._hover(far)
    np.testing.assert_allclose(target[:2], far[:2])
    one_step_higher = target + np.array([0.0, 0.0, HOVER_STEP])
    assert np.linalg.norm(target - SHOULDER) <= REACH < np.linalg.norm(one_step_higher - SHOULDER)
    np.testing.assert_allclose(joints[:3], target)
    camera_over_cloth = target[2] + CAMERA_ABOVE_TCP - far[2]
    assert camera_over_cloth >= settings.min_working_distance + HOVER_MARGIN
    # farther still: no height where the cameras still see the cloth is in reach
    arm.asked.clear()
    with pytest.raises(EpisodeAbortError) as raised:
        strategy._hover(np.array([0.95, 0.10, 0.01]))
    assert raised.value.outcome is Outcome.IK_UNREACHABLE
    lowest = 0.01 + settings.min_working_distance + HOVER_MARGIN - CAMERA_ABOVE_TCP
    assert min(arm.asked) >= lowest - 1e-9 and len(arm.asked) > 1


def test_the_centring_look_goes_as_far_towards_a_far_candidate_as_the_arm_reaches() -> None:
    arm = SphereArm()
    loop = SimpleNamespace(arm=arm, observation_joints=np.zeros(7))
    tcp = arm.tcp_position()

    def centred(point) -> np.ndarray:
        return PickPlaceLoop._centring_joints(loop, np.asarray(point, dtype=float))[:3]  # type: ignore[arg-type]

    near = centred([0.60, 0.05, 0.0])  # in reach: the camera right over it
    np.testing.assert_allclose(near, [0.60 - CAMERA_AHEAD, 0.05, HOVER_TCP_Z])
    far = np.array([0.98, 0.15, 0.0])  # the TCP over it at this height is out of reach
    goal = np.array([far[0] - CAMERA_AHEAD, far[1], HOVER_TCP_Z])
    assert np.linalg.norm(goal - SHOULDER) > REACH
    reached = centred(far)
    assert np.linalg.norm(reached - SHOULDER) <= REACH and reached[2] == pytest.approx(HOVER_TCP_Z)
    shares = [s for s in CENTRING_SHARES if np.linalg.norm(tcp + s * (goal - tcp) - SHOULDER) <= REACH]
    np.testing.assert_allclose(reached, tcp + shares[0] * (goal - tcp))  # the farthest share in reach
    assert np.linalg.norm(reached[:2] - far[:2]) < np.linalg.norm(tcp[:2] - far[:2])  # nearer than before
    # nothing on the way in reach: the observation joints, to look again from there
    loop.arm = OutOfReachArm()
    np.testing.assert_array_equal(centred(far), np.zeros(3))


# ------------------------------------------------------------------ put-backs the arm can pick again
class RingArm:
    """The job's motion for an arm that reaches out to 0.9 m from its base, but down to a
    grasp's height (under 0.04 m) only from `inner` out, as the PA10 near its base; it records
    the joints it was sent to (joints = the TCP position)."""

    def __init__(self, tcp: np.ndarray, inner: float = 0.33) -> None:
        self.tcp, self.sent, self.inner = np.array(tcp, dtype=float), [], inner

    def tcp_position(self, q=None) -> np.ndarray:
        return self.tcp.copy()

    def solve_tcp(self, position) -> np.ndarray:
        from robot_app.errors import IKError

        p = np.asarray(position, dtype=float)
        if not self.reaches(p):
            raise IKError(f"no IK solution for {p}")
        return p

    def reaches(self, position) -> bool:
        p = np.asarray(position, dtype=float)
        r = float(np.hypot(p[0], p[1]))
        return r <= 0.9 and (r >= self.inner or p[2] >= 0.04)  # near the base: not down to a grasp

    def move_to_joints(self, q, speed: float = 1.0) -> None:
        self.sent.append(np.array(q, dtype=float))
        self.tcp = np.array(q, dtype=float)


def _recovery_scene(
    arm: RingArm, lift_x: float, margin: float | None = None
) -> tuple[Any, SimpleNamespace, Any, np.ndarray]:
    """(a `TableRecovery` for `arm`, the survey, a square cloth's model, the other cloths'
    points) where a cloth lifted at (`lift_x`, 0) finds every way but towards the arm's
    base taken by other cloths (`put_back.reach_margin` = `margin`; None: the default)."""
    from robot_app.control.clear_table_records import ClearTableSettings
    from robot_app.control.job_motion import PutBackSettings
    from robot_app.control.table_recovery import TableRecovery
    from robot_app.control.table_survey import TablePlane
    from robot_app.geometry import make_transform
    from robot_app.vision import ClothModel, PinholeCamera

    camera = PinholeCamera.from_fov((320, 240), np.deg2rad(60))
    survey = SimpleNamespace(
        transform_right_camera_to_world=make_transform(np.diag([1.0, -1.0, -1.0]), [lift_x - 0.02, 0.0, 0.6])
    )
    grid = np.arange(-0.08, 0.0801, 0.01)
    u, v = np.meshgrid(grid, grid)
    points = np.column_stack([u.ravel(), v.ravel(), np.zeros(u.size)])
    model = ClothModel(
        "sq", points, np.full(len(points), 10, np.uint16), points[:4], 85.0, np.zeros(3), (0.16, 0.16)
    )
    angles = np.linspace(-2.4, 2.4, 9)
    others = np.concatenate(
        [np.column_stack([lift_x + r * np.cos(a), r * np.sin(a)]) for a in angles for r in (0.1, 0.15, 0.2)]
    )
    settings = ClearTableSettings()
    if margin is not None:
        settings = settings.model_copy(update={"put_back": PutBackSettings(reach_margin=margin)})
    cell = SimpleNamespace(release=lambda: None, set_gripper=lambda opening: None)
    arm.hold = lambda duration: None  # type: ignore[attr-defined]
    arm.move_tcp = lambda p, speed=1.0: arm.move_to_joints(arm.solve_tcp(p))  # type: ignore[attr-defined]
    recovery = TableRecovery(
        arm, cell, TablePlane(camera.camera_matrix, 0.0), camera,  # type: ignore[arg-type]
        settings, LoopSettings(),
    )  # fmt: skip
    return recovery, survey, model, others


def _laid_out(lift_x: float, inner: float, margin: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Where a `RingArm` (`inner`) lets go of the square cloth of `_recovery_scene` after
    laying it out, and the strip's direction."""
    start = np.array([lift_x, 0.0, 0.4])
    arm = RingArm(start, inner=inner)
    recovery, survey, model, others = _recovery_scene(arm, lift_x, margin)
    assert recovery.lay_down(survey, model, None, others, [])
    end = arm.sent[-1]
    return end, (end[:2] - start[:2]) / np.linalg.norm(end[:2] - start[:2])


def test_a_put_back_is_laid_where_a_blind_grasp_can_reach_it_again() -> None:
    # Bench episode 30 (session 20): a double lift at x = 0.42 m laid back towards the arm's
    # base, to x = 0.22 m, where every later blind grasp was out of reach.
    anywhere, _ = _laid_out(0.42, inner=0.0)
    assert float(np.hypot(anywhere[0], anywhere[1])) < 0.33  # the free way leads to the base
    ring, _ = _laid_out(0.42, inner=0.33)
    assert float(np.hypot(ring[0], ring[1])) >= 0.33  # not laid out of reach


def test_a_look_at_a_place_out_of_reach_goes_as_far_towards_it_as_the_arm_reaches() -> None:
    # Bench episode 64 (session 20): a put-back heap at x = 0.79-0.86 m, y = 0.23-0.32 m; both
    # looks over it were out of reach, the survey saw nothing and the job stopped.
    from robot_app.control.clear_table_records import ClearTableSettings
    from robot_app.control.table_recovery import TableRecovery

    def recovery(arm: RingArm) -> TableRecovery:
        arm.hold = lambda duration: None  # type: ignore[attr-defined]
        arm.move_tcp = lambda p, speed=1.0: arm.move_to_joints(arm.solve_tcp(p))  # type: ignore[attr-defined]
        return TableRecovery(
            arm, SimpleNamespace(), SimpleNamespace(), SimpleNamespace(),  # type: ignore[arg-type]
            ClearTableSettings(), LoopSettings(),
        )  # fmt: skip

    offset, camera_z, observation = np.array([0.07, 0.0, 0.15]), 0.6, np.array([0.55, 0.0])
    far = np.array([0.85, 0.30])  # the camera over it: TCP at 0.78, 0.30, 0.45 (0.84 m out)
    arm = RingArm(np.array([0.48, 0.0, 0.45]))
    arm.reaches = lambda p: float(np.linalg.norm(np.asarray(p, dtype=float))) <= 0.85  # type: ignore[method-assign]
    assert recovery(arm).look_from(far, offset, camera_z, observation)
    camera = arm.sent[-1][:2] + offset[:2]
    assert np.linalg.norm(camera - far) < np.linalg.norm(observation - far) - 0.1  # well on the way
    assert float(np.linalg.norm(arm.sent[-1])) <= 0.85
    assert not recovery(arm).look_from(far, offset, camera_z)  # only over the place: out of reach
    near = np.array([0.6, 0.1])
    assert recovery(arm).look_from(near, offset, camera_z, observation)
    assert np.allclose(arm.sent[-1][:2] + offset[:2], near)  # in reach: right over it
    nowhere = RingArm(np.array([0.48, 0.0, 0.45]))
    nowhere.reaches = lambda p: False  # type: ignore[method-assign]
    assert not recovery(nowhere).look_from(far, offset, camera_z, observation)


def test_a_put_back_heap_is_laid_where_a_blind_grasp_reaches_past_the_strip_s_end() -> None:
    # Replay of held-out episode 519 (session 30): four cloths lifted at x = 0.47 m were laid
    # out 207 mm towards the arm's base; the strip's end was graspable, the heap spread 0.1 m
    # past it, out of every blind grasp's reach.
    end, direction = _laid_out(0.47, inner=0.33, margin=0.0)
    assert float(np.hypot(*end[:2])) >= 0.33  # the strip's end is graspable ...
    assert float(np.hypot(*(end[:2] + 0.1 * direction))) < 0.33  # ... the heap past it is not
    end, direction = _laid_out(0.47, inner=0.33)  # the default margin, 0.1 m
    assert float(np.hypot(*(end[:2] + 0.1 * direction))) >= 0.33


def test_a_put_back_after_a_look_out_of_reach_starts_from_over_the_lift() -> None:
    # Replay of held-out episode 519 (session 30): the look at a lift of four cloths took them
    # towards the arm's base (x = 0.25 m), and the put-back laid them out from there
    lifted_at, look = np.array([0.47, 0.0, 0.4]), np.array([0.25, 0.0, 0.4])
    arm = RingArm(look)
    recovery, survey, model, others = _recovery_scene(arm, 0.47)
    notes: list[str] = []
    recovery.put_back(survey, model, None, others, notes, lifted_at)
    assert np.allclose(arm.sent[0], lifted_at)  # back over the lift first
    let_go = recovery.put_back_spots[-1]
    assert float(np.hypot(*let_go)) >= 0.33 and any("over the lift" in n for n in notes)
    # without the lift's place: lowered where the look left it, out of every grasp's reach
    arm = RingArm(look)
    recovery, survey, model, others = _recovery_scene(arm, 0.47)
    recovery.put_back(survey, model, None, others, [], None)
    assert float(np.hypot(*recovery.put_back_spots[-1])) < 0.33


def test_a_laid_cloth_must_be_graspable_across_the_strip_s_end() -> None:
    # Replay of held-out episode 519 (session 30): laid out to (0.24, -0.27), 0.37 m from the
    # base, the heap spread across the strip to 0.28 m, where no blind grasp reaches the table
    from robot_app.control.job_motion import LayOutPath

    arm = RingArm(np.array([0.40, 0.20, 0.4]), inner=0.33)
    recovery, *_ = _recovery_scene(arm, 0.40)
    start, end = np.array([0.40, 0.20]), np.array([0.37, 0.0])  # along the ring, 0.37 m out
    direction = (end - start) / np.linalg.norm(end - start)
    path = LayOutPath(direction, np.array([[*start, 0.2], [*(start + end) / 2, 0.1], [*end, 0.05]]), 0.1)
    assert recovery._graspable_along(path, 0.0)  # the strip and past its end: in reach
    assert not recovery._graspable_along(path, 0.08)  # its inner side lies 0.29 m out


def test_a_put_back_is_laid_out_on_the_green_sheet_where_it_fits_there() -> None:
    # held-out 1703 (session 48): a put-back from a look around's view laid No.9 out beyond the
    # sheet's edge, towards the box; no rule took it again and the job stopped with it there.
    # Here the free way leads off the sheet, towards the arm's base (other cloths all round)
    from robot_app.control.clear_table_records import ClearTableSettings, TableArea
    from robot_app.control.job_motion import PutBackSettings

    sheet = TableArea((0.33, 1.0), (-0.5, 0.5))

    def laid(on: bool, known: TableArea | None) -> np.ndarray:
        arm = RingArm(np.array([0.5, 0.0, 0.4]), inner=0.0)
        recovery, survey, model, others = _recovery_scene(arm, 0.5)
        recovery.sheet = known
        recovery.settings = ClearTableSettings(put_back=PutBackSettings(on_sheet=on))
        assert recovery.lay_down(survey, model, None, others, [])
        return np.asarray(arm.sent[-1][:2])

    freest = laid(False, sheet)
    half_width = 0.08  # the square cloth's
    assert not sheet.contains(freest, half_width)[0]  # the freest way: the laid cloth over the edge
    on_sheet = laid(True, sheet)
    assert sheet.contains(on_sheet, half_width + 0.04)[0]  # wholly on it, the margin inside the edge
    assert np.allclose(laid(True, None), freest)  # no sheet known: the freest way
    # the lift at the survey view's edge (1703's first put-back): no laid cloth fits in the
    # view, and the sheet beyond it comes before a heap lowered on the spot
    from robot_app.geometry import make_transform

    for on, lays in ((False, False), (True, True)):
        arm = RingArm(np.array([0.5, 0.0, 0.4]), inner=0.0)
        recovery, survey, model, others = _recovery_scene(arm, 0.5)
        survey.transform_right_camera_to_world = make_transform(np.diag([1.0, -1.0, -1.0]), [0.83, 0.0, 0.6])
        recovery.sheet = sheet
        recovery.settings = ClearTableSettings(put_back=PutBackSettings(on_sheet=on))
        assert recovery.lay_down(survey, model, None, others, []) is lays
        if lays:
            assert sheet.contains(arm.sent[-1][:2], half_width + 0.04)[0]
