"""Control: PA10 kinematics, jerk-limited trajectories, the cloth pose filter, the loop."""

from robot_app.control.kinematics import IKResult, Kinematics
from robot_app.control.limits import (
    JointLimits,
    LimitReport,
    TrajectorySettings,
    check_limits,
)
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
    OnlineTrajectory,
    TrajectoryPlanningError,
    TrajectorySample,
    TrajectorySamples,
    plan_point_to_point,
)

__all__ = [
    "ARM_NAMES",
    "ArmSpec",
    "FilterUpdate",
    "IKResult",
    "JointLimits",
    "JointTrajectory",
    "Kinematics",
    "LimitReport",
    "OnlineTrajectory",
    "PoseEstimate",
    "PoseFilter",
    "PoseFilterSettings",
    "PoseXYZYaw",
    "TrajectoryPlanningError",
    "TrajectorySample",
    "TrajectorySamples",
    "TrajectorySettings",
    "UpdateReason",
    "arm_spec",
    "baxter_right_arm_spec",
    "check_limits",
    "example_robot_data_dir",
    "load_arm",
    "pa10_spec",
    "plan_point_to_point",
    "pr2_right_arm_spec",
]
