"""Control: PA10 kinematics, jerk-limited trajectories, the cloth pose filter, the loop."""

from robot_app.control.limits import (
    PA10_JOINT_NAMES,
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
from robot_app.control.trajectory import (
    JointTrajectory,
    OnlineTrajectory,
    TrajectoryPlanningError,
    TrajectorySample,
    TrajectorySamples,
    plan_point_to_point,
)

__all__ = [
    "PA10_JOINT_NAMES",
    "FilterUpdate",
    "JointLimits",
    "JointTrajectory",
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
    "check_limits",
    "plan_point_to_point",
]
