"""Closed-loop regression tests: the whole pick and place in the simulated cell (320x240).

Each test runs one real episode (pybullet world, station-made model, GA recognition,
Kalman filter, Pinocchio IK, ruckig) and judges it by the simulator's ground truth. The
belt tests run the servo strategy with the realistic camera (50 +- 10 ms to memory) and
`loop.vision_latency` on top; the long ones are marked slow. Every test fixes the
recognition latency (`loop.vision_latency`, 60 ms unless it sets its own): with the default
(each recognition's measured wall time) an episode depends on how loaded the machine is.
"""

from __future__ import annotations

import numpy as np
import pytest

from robot_app.config import load_config
from robot_app.control import EpisodeResult, Outcome, judge_success
from robot_app.errors import ConfigError
from robot_app.experiments.pick_place_episode import PickPlaceConfig, run_episode

BASE = ["world.cameras.image_size=[320,240]", "loop.vision_latency=0.06"]


def episode(*overrides: str):
    return run_episode(load_config(PickPlaceConfig, None, [*BASE, *overrides])).result


def assert_placed(result) -> None:
    assert result.outcome is Outcome.PLACED, result.reason
    assert result.placed_fraction is not None and result.placed_fraction >= 0.9
    assert result.limit_report.violations == 0
    assert result.collisions == 0
    assert result.success


def test_plain_pick_and_place_puts_the_cloth_in_the_box() -> None:
    result = episode("seed=1", "scene.target=3")
    assert_placed(result)
    assert result.grasp_attempts == 1
    # the recognitions that steered the arm were accurate against ground truth
    tracked = [r for r in result.recognitions if r.accepted]
    assert tracked and max(abs(r.error_x_mm) for r in tracked) < 10
    assert max(abs(r.error_y_mm) for r in tracked) < 10
    # the fingers closed where the loop meant them to, on the true cloth
    assert len(result.grasp_offsets) == 1 and np.hypot(*result.grasp_offsets[0]) < 0.005


def test_a_transfer_that_arrives_moving_into_the_lowering_places_the_cloth() -> None:
    # `loop.transfer_via_drop` (off by default: more cloths over a box's wall, session 44)
    result = episode("seed=1", "scene.target=3", "loop.transfer_via_drop=0.02")
    assert_placed(result)
    (transfer,) = [p for p in result.phases if p.phase == "transfer"]
    assert transfer.note.startswith("over the box moving down"), transfer.note


def test_pick_and_place_with_the_calibrated_rig_file() -> None:
    # configs/rig_calibrated_320x240.yaml came from `robot-app sim calibration-views` and
    # `robot-app calibrate stereo | hand-eye` (README): the loop sees only what they measured
    result = episode("seed=1", "scene.target=3", "world.cameras.rig_file=configs/rig_calibrated_320x240.yaml")
    assert_placed(result)
    assert np.hypot(*result.grasp_offsets[0]) < 0.005


def test_pick_and_place_with_45_percent_occluded_cloth() -> None:
    assert_placed(episode("seed=2", "scene.target=11", "scene.occluder=true"))


def test_with_a_distractor_the_target_is_picked() -> None:
    result = episode("seed=3", "scene.target=3", "scene.distractor=4")
    assert_placed(result)  # placed_fraction is measured on the target cloth itself


def test_absent_target_is_reported_not_present_without_grasping() -> None:
    result = episode("seed=4", "scene.target=4", "model_cloth=3")
    assert result.outcome is Outcome.NOT_PRESENT
    assert result.grasp_attempts == 0
    assert result.success  # saying "not present" is the right answer here
    assert not any(r.found for r in result.recognitions)


def test_cloth_nudged_during_approach_is_followed() -> None:
    result = episode("seed=5", "scene.target=3", "nudge.after=0.1", "nudge.dx=0.025", "nudge.dy=-0.015")
    assert_placed(result)  # grasped where the cloth went, not where it was first seen
    accepted = [r for r in result.recognitions if r.accepted]
    first, last = accepted[0], accepted[-1]
    moved = np.hypot(last.x - first.x, last.y - first.y)
    assert moved == pytest.approx(np.hypot(0.025, 0.015), abs=0.005)  # the filter followed the push


@pytest.mark.slow
def test_a_cloth_grasped_off_centre_is_let_go_low_enough_to_land_in_the_box() -> None:
    """The true-rig bench's episode 61: No.2 (0.22 x 0.18 m) covered, grasped in its visible
    part 58 mm from its centre, hangs 0.196 m below the fingers, twice the box's walls. Let go
    with its lowest point 2 cm above the floor, its upper half toppled over a wall (77 % in the
    box); the hand now lowers it further (`loop.release_fold`), folding it onto the floor."""
    result = episode("seed=100061", "scene.target=2", "scene.occluder=true", "world.cameras.rig_file=null")
    assert_placed(result)


def test_bad_config_is_a_config_error() -> None:
    with pytest.raises(ConfigError) as too_fast:
        load_config(PickPlaceConfig, None, ["loop.vision_rate_hz=100"])
    assert (too_fast.value.key, too_fast.value.value) == ("loop.vision_rate_hz", 100)
    with pytest.raises(ConfigError) as unknown:
        load_config(PickPlaceConfig, None, ["loop.speed=3"])
    assert unknown.value.key == "loop.speed" and unknown.value.problems[0].problem == "unknown key"


def assert_tracked_and_grasped_near(result: EpisodeResult, offset_mm: float) -> None:
    """The filtered pose followed the moving cloth and the fingers closed where meant."""
    errors = [t.error_xy_mm for t in result.tracking]
    assert errors and float(np.median(errors)) < 5.0
    assert result.grasps and result.grasps[-1].offset_mm is not None
    assert result.grasps[-1].offset_mm < offset_mm


def test_a_cloth_on_a_belt_at_50_mm_per_s_is_placed() -> None:
    result = episode(
        "seed=21", "scene.target=3", "scene.conveyor_speed=0.05", "scene.conveyor_direction_deg=60",
        "loop.vision_latency=0.06",
    )  # fmt: skip
    assert_placed(result)
    assert result.strategy == "servo"
    assert_tracked_and_grasped_near(result, offset_mm=8.0)
    assert 0.04 < result.grasps[-1].tcp_speed < 0.06  # the fingers closed moving with the belt
    tracked = [r for r in result.recognitions if r.mode == "track"]
    assert tracked and min(r.age for r in tracked) >= 0.06  # every result came after its latency


def test_a_still_cloth_whose_second_look_took_a_neighbouring_peak_is_placed() -> None:
    """bench_conveyor's episode 20: No.4's second look landed 20 mm off, the two looks made a
    172 mm/s 'velocity' and the intercept left the arm's reach; APPROACH now gives up and the
    loop looks again instead of ending the episode. With the regenerated rig files a later look
    then settled on that peak (turned half round) and the fingers closed 140 mm off; the first
    look's pose, polished on the second look's frame, fits it better (0.904 against 0.818), so the
    search now takes that as the second measurement (`ClothTracker.take_second_look`)."""
    result = episode(
        "seed=1600020", "scene.target=4", "scene.conveyor_direction_deg=109.5", "scene.conveyor_speed=0.0",
    )  # fmt: skip
    assert_placed(result)
    assert result.grasps and result.grasps[-1].offset_mm is not None and result.grasps[-1].offset_mm < 5.0


@pytest.mark.slow
@pytest.mark.parametrize("latency", [0.0, 0.1])
def test_latency_0_and_100_ms_both_succeed_at_25_mm_per_s(latency: float) -> None:
    result = episode(
        "seed=22", "scene.target=11", "scene.conveyor_speed=0.025", "scene.conveyor_direction_deg=200",
        f"loop.vision_latency={latency}",
    )  # fmt: skip
    assert_placed(result)
    assert_tracked_and_grasped_near(result, offset_mm=8.0)
    ages = [r.age for r in result.recognitions if r.mode == "track"]
    assert min(ages) >= latency  # the camera's latency comes on top


@pytest.mark.slow
@pytest.mark.parametrize(
    "encoder",
    [
        pytest.param("false", id="vision_only"),
        pytest.param("true", id="belt_encoder"),
    ],
)
def test_a_belt_that_stops_halfway(encoder: str) -> None:
    """The belt runs 2 s (the cloth is being approached), brakes at 0.5 m/s^2 and stands.
    With the conveyor's encoder (`loop.belt_encoder`) the filter knows the belt stopped.
    Vision only, the cameras see the stop: they track down to 0.14 m from the cloth
    (`loop.min_working_distance`, the tracker scoring the model points in view), and the
    views after the stop do not confirm the prediction still running at 50 mm/s."""
    result = episode(
        "seed=23", "scene.target=7", "scene.conveyor_speed=0.05", "scene.conveyor_direction_deg=120",
        "scene.conveyor_profile=stop_and_go", "scene.conveyor_run_time=2.0", "scene.conveyor_stop_time=60",
        "loop.vision_latency=0.06", f"loop.belt_encoder={encoder}",
    )  # fmt: skip
    assert_placed(result)
    assert_tracked_and_grasped_near(result, offset_mm=8.0)
    assert result.grasps[-1].tcp_speed < 0.01  # closed on the standing cloth, not on its old motion
    moving = [t for t in result.tracking if t.cloth_speed > 0.04]
    standing = [t for t in result.tracking if t.cloth_speed < 0.005]
    assert moving and standing  # the belt did stop while the loop was tracking the cloth


@pytest.mark.slow
@pytest.mark.parametrize(("speed", "encoder"), [(0.0, False), (0.025, False), (0.025, True)])
def test_a_cloth_pushed_30_mm_during_descend_is_still_grasped(speed: float, encoder: bool) -> None:
    """With the belt's encoder too: the push moves the cloth across the belt, which the
    encoder does not see; vision must still follow it."""
    result = episode(
        "seed=24", "scene.target=3", f"scene.conveyor_speed={speed}", "scene.conveyor_direction_deg=90",
        "loop.vision_latency=0.06", "nudge.phase=descend", "nudge.after=0.05", "nudge.dx=0.03", "nudge.dy=0",
        f"loop.belt_encoder={str(encoder).lower()}",
    )  # fmt: skip
    assert_placed(result)
    assert result.grasp_attempts == 1  # the fingers closed once: not blind where the cloth had been
    assert result.grasps[0].offset_mm is not None and result.grasps[0].offset_mm < 10.0
    # the push was seen (the filtered pose 20 mm or more off the truth) and the loop's
    # estimate followed it before the fingers closed
    assert any(t.error_xy_mm > 20.0 for t in result.tracking)
    assert result.tracking[-1].error_xy_mm < 5.0


@pytest.mark.slow
def test_a_cloth_carried_toward_the_base_out_of_reach_is_reported_unreachable() -> None:
    """bench_conveyor's servo 100 mm/s episode 21: No.13 heading at 170 deg toward the
    robot's base, where the hand pointing down cannot get low; the descent ended in an
    IK failure 0.9 s in. DESCEND now foresees it before the hand moves down."""
    result = episode(
        "seed=1600021", "scene.target=13", "scene.conveyor_direction_deg=170.3",
        "scene.conveyor_speed=0.1", "loop.vision_latency=0.06",
    )  # fmt: skip
    assert result.outcome is Outcome.UNREACHABLE and not result.success
    assert "leaves the arm's reach" in result.reason
    assert result.grasp_attempts == 0 and result.limit_report.violations == 0 and result.collisions == 0


@pytest.mark.slow
def test_look_then_move_baseline_still_places_a_still_cloth() -> None:
    result = episode("seed=1", "scene.target=3", "loop.strategy=look_then_move", "loop.vision_latency=0.06")
    assert_placed(result)
    assert result.strategy == "look_then_move"


@pytest.mark.parametrize(
    ("speed", "direction", "why"),
    [(2.0, 45.0, "to its end"), (0.3, 0.0, "to its end"), (0.3, 180.0, "out of the arm's reach")],
)
def test_a_belt_no_robot_could_keep_up_with_is_refused_before_the_start(
    speed: float, direction: float, why: str
) -> None:
    result = episode(
        f"scene.conveyor_speed={speed}",
        f"scene.conveyor_direction_deg={direction}",
        "loop.vision_latency=0.06",
    )
    assert result.outcome is Outcome.UNREACHABLE and not result.success
    assert why in result.reason
    assert result.commanded_samples == 0 and not result.phases  # refused, not run


def test_the_same_speed_along_a_longer_belt_is_accepted() -> None:
    from robot_app.control import JointLimits, Kinematics, observation_posture
    from robot_app.experiments.conveyor_check import conveyor_problem
    from robot_app.sim import observation_camera_pose

    config = load_config(
        PickPlaceConfig,
        None,
        ["scene.conveyor_speed=0.3", "scene.conveyor_direction_deg=90", "loop.vision_latency=0.06"],
    )
    urdf = config.world.robot.urdf
    kinematics, limits = (
        Kinematics.from_urdf(urdf, "base_link", "tcp"),
        JointLimits.from_urdf(urdf, config.trajectory),
    )
    posture = observation_posture(
        kinematics, limits, observation_camera_pose(config.world), config.world.robot.home_joints, 1e-4
    )
    assert conveyor_problem(config.world, config.scene, config.loop, kinematics, limits, posture) is None


def test_success_is_decided_once_from_outcome_limits_contacts_and_placement() -> None:
    ok = {"limit_violations": 0, "collisions": 0, "grasp_attempts": 1, "placed_fraction": 0.95}
    assert judge_success(Outcome.PLACED, **ok)
    assert not judge_success(Outcome.PLACED, **(ok | {"placed_fraction": 0.5}))
    assert not judge_success(Outcome.PLACED, **(ok | {"limit_violations": 1}))
    assert not judge_success(Outcome.PLACED, **(ok | {"collisions": 1}))
    assert not judge_success(Outcome.LOST, **ok)
    assert judge_success(Outcome.PLACED, **(ok | {"placed_fraction": None}))  # a real cell cannot tell
    absent = ok | {"grasp_attempts": 0, "placed_fraction": 0.0, "target_present": False}
    assert judge_success(Outcome.NOT_PRESENT, **absent)
    assert not judge_success(Outcome.NOT_PRESENT, **(absent | {"grasp_attempts": 1}))


def _searches_miss(monkeypatch: pytest.MonkeyPatch, shift_m: float) -> EpisodeResult:
    """One episode whose every one-shot search is made to miss the cloth (its result kept,
    `found` off), the loop given where another recognition found it: the truth moved by
    `shift_m` along x (0: the cloth's place; 0.25: bare sheet beside it)."""
    from dataclasses import replace

    from robot_app.control import pick_place, vision_pipeline

    search = vision_pipeline.VisionPipeline.search

    def missing(self, seed, capture=None):
        result = search(self, seed, capture)
        return replace(result, recognition=replace(result.recognition, found=False, confidence=0.0))

    monkeypatch.setattr(vision_pipeline.VisionPipeline, "search", missing)
    init = pick_place.PickPlaceLoop.__init__

    def told(self, *args, **kwargs):
        init(self, *args, **kwargs)
        expected = self.ground_truth().copy()
        expected[0, 3] += shift_m
        self.expected_pose = expected

    monkeypatch.setattr(pick_place.PickPlaceLoop, "__init__", told)
    return episode("seed=1", "scene.target=3")


def test_a_cloth_every_search_misses_is_checked_where_the_caller_found_it(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The clear-table job's survey found the cloth, the loop's searches did not (held-out
    episode 395, session 28): the last search's frame is checked at the survey's pose, and
    the pick goes on; checked where no cloth lies, nothing is found."""
    assert_placed(_searches_miss(monkeypatch, 0.0))
    absent = _searches_miss(monkeypatch, 0.25)
    assert absent.outcome is Outcome.NOT_PRESENT and absent.grasp_attempts == 0


def test_a_search_on_the_callers_frame_goes_straight_from_elsewhere_to_the_cloth(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The clear-table job's look into a box (`clear.straight_from_box`): the frame was taken
    at the observation pose, the arm went over the box since; the loop does not go back to
    look again but recognises that frame and moves straight over the cloth. A frame of the
    wrong scene would not be found (the check on the table below)."""
    from robot_app.control import pick_place

    run = pick_place.PickPlaceLoop.run
    taken: dict[str, float] = {}

    def from_the_box(self):
        self.arm.reset()
        self.arm.move_to_joints(self.observation_joints)
        self.first_look = self.cell.capture()
        taken["time"] = self.first_look.time
        self.arm.move_to_joints(self.arm.solve_tcp(self.place_position + np.array([0.0, 0.0, 0.45])))
        taken["left"] = self.cell.time
        return run(self)

    monkeypatch.setattr(pick_place.PickPlaceLoop, "run", from_the_box)
    result = episode("seed=1", "scene.target=3", "loop.strategy=look_then_move")
    assert_placed(result)
    assert np.hypot(*result.grasp_offsets[0]) < 0.005
    first = result.recognitions[0]
    assert first.mode == "search" and first.found and first.time == taken["time"]
    observe, search, approach = result.phases[:3]
    assert (observe.phase, search.phase, approach.phase) == ("observe", "search", "approach")
    assert observe.duration < 1e-9  # no move back to the observation pose
    assert search.duration < 1e-9  # the frame's result had long arrived
    assert approach.start_time == pytest.approx(taken["left"])
    # the approach's tracking frames saw the cloth: it came over it before tracking
    tracked = [r for r in result.recognitions if r.mode == "track"]
    assert tracked and all(r.found for r in tracked[:3])


def test_an_approach_blended_into_the_descent_grasps_as_surely_and_sooner() -> None:
    """`loop.approach_blend` (look-then-move): APPROACH ends while still moving, that far from
    the hover, once enough recognitions are fused; DESCEND goes on from that state."""

    def approach_to_grasp(result: EpisodeResult) -> float:
        approach = next(p for p in result.phases if p.phase == "approach")
        grasp = next(p for p in result.phases if p.phase == "grasp")
        return grasp.start_time - approach.start_time

    runs = {
        blend: episode(
            "seed=1", "scene.target=3", "loop.strategy=look_then_move", f"loop.approach_blend={blend}"
        )
        for blend in (0.0, 0.1)
    }
    for result in runs.values():
        assert_placed(result)
        assert np.hypot(*result.grasp_offsets[0]) < 0.005
    blended = next(p for p in runs[0.1].phases if p.phase == "approach")
    assert "on into DESCEND" in blended.note, blended.note
    assert approach_to_grasp(runs[0.1]) < approach_to_grasp(runs[0.0]) - 0.1
