"""Settings of the pick-and-place loop (`loop:` in configs/pick_place.yaml).

Heights are of the TCP [m]; times are cell time [s]. The servo-only keys say so.
"""

from __future__ import annotations

from pydantic import Field

from robot_app.config import StrictModel
from robot_app.control.episode import Strategy


class LoopSettings(StrictModel):
    """Settings of the loop. Heights are of the TCP [m]; times are cell time [s]."""

    strategy: Strategy = Field(
        Strategy.SERVO, description="servo (predict, intercept, track down) | look_then_move (baseline)"
    )
    vision_rate_hz: float = Field(15.0, ge=10.0, le=30.0, description="camera triggers per second")
    vision_latency: float | None = Field(
        None,
        ge=0.0,
        le=2.0,
        description="recognition time in cell time [s], after the camera's own latency; "
        "null: each recognition's measured wall time",
    )
    search_attempts: int = Field(3, ge=1, description="one-shot GA runs before 'not present'")
    candidate_confidence: float = Field(
        0.05,
        ge=0.0,
        le=1.0,
        description="recognition confidence below 'found' (recognition.decide.threshold) but at least "
        "this: centre the cameras on the candidate and look again",
    )
    max_observe_returns: int = Field(2, ge=0, description="returns to OBSERVE after losing the cloth")
    grasp_retries: int = Field(2, ge=0, description="new attempts after a missed grasp")
    min_accepted_updates: int = Field(3, ge=1, description="fused recognitions before descending")
    approach_tolerance: float = Field(0.004, gt=0.0, description="TCP to target to end APPROACH [m]")
    approach_timeout: float = Field(6.0, gt=0.0)
    approach_blend: float = Field(
        0.0,
        ge=0.0,
        le=0.3,
        description="look_then_move: with min_accepted_updates fused, APPROACH ends this far [m] "
        "from the hover while still moving, and DESCEND goes on from that state without a stop "
        "(0: it ends at rest within approach_tolerance)",
    )
    settle_time: float = Field(0.3, ge=0.0, description="wait after arriving at the observation pose")
    pregrasp_height: float = Field(
        0.08, gt=0.0, description="look_then_move: TCP above the cloth before the last move"
    )
    descend_via_speed: float = Field(
        0.25,
        ge=0.0,
        le=1.0,
        description="look_then_move: the TCP passes the pregrasp point without a stop, heading "
        "down at about this speed [m/s], and comes down the last pregrasp_height on a straight "
        "line in joint space (arm_motion.move_through; 0: stops there, the two moves of before). "
        "0.25: descend 1.48-1.65 -> about 1.15-1.3 s over the clear-table range (notes s35 "
        "descend2.py), the last 8 cm within 1.1-2.1 mm of the vertical where the two stops' "
        "time-synchronised last move strayed 3.8-5.7 mm",
    )
    track_height: float = Field(
        0.15,
        gt=0.0,
        description="servo: TCP above the cloth while APPROACH tracks it [m] (cameras 0.1 m higher)",
    )
    min_working_distance: float = Field(
        0.14,
        gt=0.0,
        description="servo: closest camera-to-cloth distance at which captures are recognised [m]; "
        "below it DESCEND goes on blind, on the prediction. scripts/bench_close_range.py (arm at rest, "
        "tracking scoring the model points in view, propose.tracking.view_floor) keeps the p95 in-plane "
        "error within the filter's noise model (8.6 mm) down to 0.10 m; in the moving loop views below "
        "~0.13 m slid 10 mm off a still No.4 with falling fitness (test_pick_place's neighbouring-peak "
        "episode: 12.3 mm grasp offset at 0.10, 4.2 at 0.13, 2.7 at 0.14), so 0.14: the last ~2 cm blind",
    )
    belt_encoder: bool = Field(
        False,
        description="servo: fuse the conveyor's encoder (the belt's velocity) into the cloth filter's "
        "velocity while the cloth lies on the belt (belt_odometry.BeltOdometry); false: vision only",
    )
    belt_encoder_std: float = Field(
        0.002, gt=0.0, description="servo: the encoder's velocity noise per horizontal axis [m/s]"
    )
    belt_encoder_rate_hz: float = Field(100.0, gt=0.0, le=1000.0, description="servo: encoder samples [Hz]")
    grasp_tolerance: float = Field(
        0.003, gt=0.0, description="servo: TCP to the moving grasp target before the fingers close [m]"
    )
    velocity_tolerance: float = Field(
        0.02, gt=0.0, description="servo: TCP velocity to the cloth's to end APPROACH and close [m/s]"
    )
    max_prediction: float = Field(
        1.5, gt=0.0, description="servo: farthest the filter predicts the cloth ahead [s]"
    )
    grasp_height: float = Field(
        0.022, ge=0.0, description="TCP above the recognised cloth surface (fingertips reach 0.01 below it)"
    )
    min_table_clearance: float = Field(0.02, ge=0.0, description="TCP never lower above the table")
    close_time: float = Field(0.3, gt=0.0, description="time the fingers get to close")
    lift_height: float = Field(0.40, gt=0.05, description="TCP above the table after lifting")
    lift_clearance: float = Field(
        0.02,
        ge=0.0,
        description="servo: the hanging cloth's lowest point above the belt when the hand "
        "stops following it [m]",
    )
    lift_check: float = Field(0.05, gt=0.0, description="cloth must be this far off the table [m]")
    transfer_height: float = Field(0.40, gt=0.05, description="TCP above the table over the box")
    transfer_via_drop: float = Field(
        0.0,
        ge=0.0,
        le=0.1,
        description="TRANSFER does not stop over the box: it arrives, moving, where RELEASE's "
        "lowering from a stop there would have come this far down [m] (or half as far), in that "
        "lowering's state, and RELEASE goes on with it; more than 3 mm below the transfer height "
        "only within 5 cm of the box's middle (else it stops over the box). Not for a load that "
        "hangs lower than the meant cloth (a double pick carried together). 0 (default): stops "
        "over the box. 0.02 made a placed attempt 0.2 s shorter, but over 50 held-out "
        "clear-table episodes (1455-1504, session 44) a cloth was seen over a box's wall after 23 "
        "of 190 releases (7 of ~190 with the stop, session 43): the swing the stop let die out",
    )
    release_clearance: float = Field(
        0.02, ge=0.0, description="lowest point of the hanging cloth above the box floor when let go [m]"
    )
    min_release_height: float = Field(0.06, gt=0.0, description="TCP never lower than this over the box")
    release_fold: float = Field(
        0.2,
        ge=0.0,
        le=0.5,
        description="lower the hand this much further once the hanging cloth's lowest point is "
        "release_clearance above the box floor, so that it folds onto the floor under the fingers "
        "instead of toppling over a wall when let go [m] (0: let go there). 0.2: a cloth grasped "
        "off-centre hangs up to 0.2-0.24 m, twice the box's 0.1 m walls (pick-place bench episode "
        "61: 77 % in the box at 0, 100 % at 0.2; clear-table's two 'partly in' cloths)",
    )
    release_speed: float = Field(0.3, gt=0.0, le=1.0, description="limit scale for lowering into the box")
    release_slow_from: float | None = Field(
        0.1,
        ge=0.0,
        description="the lowering into the box runs at the full limits until the hanging cloth's "
        "lowest point (grasp_height + its hanging reach below the TCP) is this far above the box "
        "floor, then on at release_speed, without a stop: from there on the move is the slow one's "
        "own, at its velocity [m]; null: the whole lowering at release_speed",
    )
    release_wait: float = Field(
        1.0,
        ge=0.0,
        description="longest wait after letting go for the cloth to fall and settle before the "
        "fingers open [s] (with release_settle_share null: always this long)",
    )
    release_settle_share: float | None = Field(
        None,
        ge=0.0,
        le=1.0,
        description="the fingers open once the right hand camera's successive frames (at "
        "vision_rate_hz) differ in at most this share of pixels release_settle_frames times in a "
        "row: the cloth under the hand has come to rest (release_watch); null (default): wait "
        "release_wait. 0.002 saw the cloth at rest 0.78-0.93 s after letting go in 2 of 4 "
        "pick-place episodes, and with the joined lowering the clear-table test of three cloths "
        "into two boxes ended No.6 'partly in whites' in 4 of 5 runs (each change alone passed 3 of 3)",
    )
    release_settle_frames: int = Field(2, ge=1, le=30, description="still frame pairs in a row")
    release_settle_threshold: float = Field(
        25.0, gt=0.0, le=255.0, description="a pixel changed if its grey level moved this much"
    )
    gripper_open: float = Field(0.08, gt=0.0, le=0.08)
    max_episode_time: float = Field(60.0, gt=0.0)
    ik_time_budget: float = Field(0.02, gt=0.0, description="per IK solve [s]; one retry gets 5x")
    ik_tolerance: float = Field(1e-4, gt=0.0, description="IK position tolerance [m] (and [rad])")
    collision_check_period: float = Field(0.05, gt=0.0, description="[s] between contact checks")
    track_generations: int | None = Field(None, ge=0, description="None: the recogniser's default")


__all__ = ["LoopSettings"]
