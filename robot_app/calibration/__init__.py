"""Calibration of the hand stereo rig from board images: intrinsics, stereo pose, hand-eye.

Pure OpenCV and numpy, like `robot_app.vision` (never imports sim or control); works on
image folders from real cameras. `robot-app calibrate stereo` and `calibrate hand-eye`
are its command-line face; the rig file it writes is `robot_app.vision.camera`'s.
"""

from robot_app.calibration.board import BoardConfig, BoardType, board_image, load_board, save_board
from robot_app.calibration.detection import BoardDetection, DetectionSettings, detect_board, edge_width
from robot_app.calibration.files import (
    POSE_COLUMNS,
    ImagePair,
    find_image_pairs,
    read_robot_poses,
    robot_poses_csv,
)
from robot_app.calibration.flat_field import (
    FLAT_FIELD_FOLDER,
    FlatField,
    apply_flat_field,
    check_flat_field_size,
    flat_field_for,
    load_flat_field,
    measure_flat_field,
)
from robot_app.calibration.hand_eye import (
    HandEyeCalibration,
    HandEyeMethod,
    HandEyeSettings,
    calibrate_hand_eye,
    match_robot_poses,
)
from robot_app.calibration.hand_eye_methods import (
    HAND_EYE_METHODS,
    hand_eye_daniilidis,
    hand_eye_park,
    hand_eye_tsai,
    motion_pairs,
)
from robot_app.calibration.hand_eye_residuals import BoardObservations, MethodResult, ViewResidual
from robot_app.calibration.report import (
    coverage_fraction,
    coverage_picture,
    prepare_folder,
    write_hand_eye_report,
    write_stereo_report,
)
from robot_app.calibration.rig_file import rig_yaml, write_rig
from robot_app.calibration.stereo import (
    CameraFit,
    StereoCalibration,
    StereoCalibrationSettings,
    ViewError,
    calibrate_stereo,
)
from robot_app.calibration.views import DetectedView, detect_views, reason_kind, require_views

__all__ = [
    "FLAT_FIELD_FOLDER",
    "HAND_EYE_METHODS",
    "POSE_COLUMNS",
    "BoardConfig",
    "BoardDetection",
    "BoardObservations",
    "BoardType",
    "CameraFit",
    "DetectedView",
    "DetectionSettings",
    "FlatField",
    "HandEyeCalibration",
    "HandEyeMethod",
    "HandEyeSettings",
    "ImagePair",
    "MethodResult",
    "StereoCalibration",
    "StereoCalibrationSettings",
    "ViewError",
    "ViewResidual",
    "apply_flat_field",
    "board_image",
    "calibrate_hand_eye",
    "calibrate_stereo",
    "check_flat_field_size",
    "coverage_fraction",
    "coverage_picture",
    "detect_board",
    "detect_views",
    "edge_width",
    "find_image_pairs",
    "flat_field_for",
    "hand_eye_daniilidis",
    "hand_eye_park",
    "hand_eye_tsai",
    "load_board",
    "load_flat_field",
    "match_robot_poses",
    "measure_flat_field",
    "motion_pairs",
    "prepare_folder",
    "read_robot_poses",
    "reason_kind",
    "require_views",
    "rig_yaml",
    "robot_poses_csv",
    "save_board",
    "write_hand_eye_report",
    "write_rig",
    "write_stereo_report",
]
