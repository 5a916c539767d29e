"""Control: PA10 kinematics, jerk-limited trajectories, the cloth pose filter, the loop."""

from robot_app.control.arm_motion import ArmMotion
from robot_app.control.cell import Cell, StereoCapture
from robot_app.control.cloth_tracker import ClothTracker
from robot_app.control.episode import (
    SUCCESS_FRACTION,
    EpisodeAbortError,
    EpisodeResult,
    GraspRecord,
    Outcome,
    Phase,
    PhaseRecord,
    RecognitionRecord,
    Strategy,
    TrackingRecord,
    judge_success,
)
from robot_app.control.intercept import GraspPath, JointFollower, hanging_reach
from robot_app.control.kinematics import IKResult, Kinematics
from robot_app.control.limits import (
    JointLimits,
    LimitReport,
    TrajectorySettings,
    check_limits,
)
from robot_app.control.loop_settings import LoopSettings
from robot_app.control.online_trajectory import OnlineTrajectory
from robot_app.control.pick_place import PickPlaceLoop, observation_posture
from robot_app.control.pose_filter import (
    FilterUpdate,
    PoseEstimate,
    PoseFilter,
    PoseFilterSettings,
    PoseXYZYaw,
    UpdateReason,
)
from robot_app.control.robot_models import (
    ARM_NAMES,
    ArmSpec,
    arm_spec,
    baxter_right_arm_spec,
    example_robot_data_dir,
    load_arm,
    pa10_spec,
    pr2_right_arm_spec,
)
from robot_app.control.trajectory import (
    JointTrajectory,
    TrajectoryPlanningError,
    TrajectorySample,
    TrajectorySamples,
    plan_point_to_point,
)
from robot_app.control.vision_pipeline import ClothMotion, VisionPipeline, VisionResult

__all__ = [
    "ARM_NAMES",
    "SUCCESS_FRACTION",
    "ArmMotion",
    "ArmSpec",
    "Cell",
    "ClothMotion",
    "ClothTracker",
    "EpisodeAbortError",
    "EpisodeResult",
    "FilterUpdate",
    "GraspPath",
    "GraspRecord",
    "IKResult",
    "JointFollower",
    "JointLimits",
    "JointTrajectory",
    "Kinematics",
    "LimitReport",
    "LoopSettings",
    "OnlineTrajectory",
    "Outcome",
    "Phase",
    "PhaseRecord",
    "PickPlaceLoop",
    "PoseEstimate",
    "PoseFilter",
    "PoseFilterSettings",
    "PoseXYZYaw",
    "RecognitionRecord",
    "StereoCapture",
    "Strategy",
    "TrackingRecord",
    "TrajectoryPlanningError",
    "TrajectorySample",
    "TrajectorySamples",
    "TrajectorySettings",
    "UpdateReason",
    "VisionPipeline",
    "VisionResult",
    "arm_spec",
    "baxter_right_arm_spec",
    "check_limits",
    "example_robot_data_dir",
    "hanging_reach",
    "judge_success",
    "load_arm",
    "observation_posture",
    "pa10_spec",
    "plan_point_to_point",
    "pr2_right_arm_spec",
]
