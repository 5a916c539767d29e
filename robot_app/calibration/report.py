"""What a calibration writes besides the rig: per-view tables, a summary and a coverage picture.

The coverage picture shows, for each camera, where the used views' corners fell on the
image, over a grid of 8 x 6 cells: cells without corners are where the lens model is
extrapolated, not measured (take more views with the board there).
"""

from __future__ import annotations

import csv
import io
import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray
from robot_app.calibration.board import BoardConfig
from robot_app.calibration.hand_eye import HandEyeCalibration
from robot_app.calibration.stereo import StereoCalibration
from robot_app.calibration.views import BOTH, DetectedView
from robot_app.geometry import quaternion_xyzw_from_matrix, rotation_angle_between
from robot_app.outputs import atomic_write_image, atomic_write_text, check_output_folder

GRID = (8, 6)  # coverage cells across, down


def coverage_fraction(points: FloatArray, image_size: tuple[int, int], grid: tuple[int, int] = GRID) -> float:
    """Fraction of the image's grid cells that hold at least one corner."""
    return float(_covered(points, image_size, grid).mean())


def _covered(points: FloatArray, image_size: tuple[int, int], grid: tuple[int, int]) -> npt.NDArray[np.bool_]:
    width, height = image_size
    cells = np.zeros((grid[1], grid[0]), dtype=bool)
    P = np.asarray(points, dtype=float).reshape(-1, 2)
    if len(P):
        i = np.clip((P[:, 1] / height * grid[1]).astype(int), 0, grid[1] - 1)
        j = np.clip((P[:, 0] / width * grid[0]).astype(int), 0, grid[0] - 1)
        cells[i, j] = True
    return cells


def coverage_picture(
    views: Sequence[DetectedView], used: Sequence[int], image_size: tuple[int, int]
) -> npt.NDArray[np.uint8]:
    """Left and right image areas side by side with every used view's corners drawn on them."""
    width, height = image_size
    panels = []
    for side in BOTH:
        panel = np.full((height, width, 3), 40, np.uint8)
        points = [v.side(side).image_points for v in views if v.pair.index in used and v.usable((side,))]
        all_points = np.concatenate(points) if points else np.zeros((0, 2))
        cells = _covered(all_points, image_size, GRID)
        cw, ch = width / GRID[0], height / GRID[1]
        for i, j in np.argwhere(cells):
            top_left = (round(j * cw), round(i * ch))
            bottom_right = (round((j + 1) * cw) - 1, round((i + 1) * ch) - 1)
            cv2.rectangle(panel, top_left, bottom_right, (40, 90, 40), -1)
        for k in range(1, GRID[0]):
            cv2.line(panel, (round(k * cw), 0), (round(k * cw), height), (90, 90, 90), 1)
        for k in range(1, GRID[1]):
            cv2.line(panel, (0, round(k * ch)), (width, round(k * ch)), (90, 90, 90), 1)
        for n, view_points in enumerate(points):
            hue = int(180 * n / max(1, len(points)))
            hsv = np.array([[[hue, 220, 255]]], dtype=np.uint8)
            colour = np.asarray(cv2.cvtColor(hsv, cv2.COLOR_HSV2BGR))[0, 0].tolist()
            for u, v in view_points:
                cv2.circle(panel, (round(u), round(v)), 1, colour, -1)
        label = f"{side}: {len(points)} views, {cells.mean():.0%} of the cells"
        scale = max(0.4, width / 1000)
        cv2.putText(
            panel, label, (8, round(24 * scale / 0.6)), cv2.FONT_HERSHEY_SIMPLEX, scale, (255, 255, 255), 1
        )
        panels.append(panel)
    gap = np.full((height, 6, 3), 255, np.uint8)
    return np.hstack([panels[0], gap, panels[1]])


def prepare_folder(folder: str | Path, key: str = "--report") -> Path:
    """Checks before any work that the report folder can be made (or is a folder; its
    files are replaced)."""
    return check_output_folder(folder, key=key, force=True)


def write_stereo_report(folder: str | Path, calibration: StereoCalibration, board: BoardConfig) -> list[Path]:
    """views.csv, summary.json and coverage.png of a stereo calibration; returns their paths."""
    out = Path(folder)
    out.mkdir(exist_ok=True)
    errors = {e.index: e for e in calibration.view_errors}
    refused = dict(calibration.refused)
    rows = []
    for view in calibration.views:
        error = errors.get(view.pair.index)
        status = "refused"
        if error is not None:
            status = "used" if error.left_px is not None and error.right_px is not None else "left only"
            status = "right only" if error.left_px is None else status
        rows.append(
            {
                "view": view.pair.index,
                "left_file": view.pair.left.name if view.pair.left else "",
                "right_file": view.pair.right.name if view.pair.right else "",
                "status": status,
                "reason": refused.get(view.pair.index, "") or view.reason(),
                "left_error_px": _round(error.left_px if error else None),
                "right_error_px": _round(error.right_px if error else None),
                "left_edge_width_px": _round(view.left.edge_width_px),
                "right_edge_width_px": _round(view.right.edge_width_px),
            }
        )
    rig = calibration.rig
    size = rig.image_size
    used = calibration.used
    summary: dict[str, Any] = {
        "board": board.model_dump(),
        "image_size": list(size),
        "views": len(calibration.views),
        "views_used": len(used),
        "views_refused": [{"view": i, "reason": r} for i, r in calibration.refused],
        "reprojection_rms_px": calibration.rms_px,
        "baseline_mm": 1000.0 * rig.baseline,
        "T": rig.transform_left_to_right[:3, 3].tolist(),
        "R_angle_deg": float(
            np.degrees(rotation_angle_between(np.eye(3), rig.transform_left_to_right[:3, :3]))
        ),
    }
    for side, fit in zip(BOTH, (calibration.left, calibration.right), strict=True):
        K = getattr(rig, side).camera_matrix
        points = [v.side(side).image_points for v in calibration.views if v.pair.index in used]
        summary[side] = {
            "fx": K[0, 0],
            "fy": K[1, 1],
            "cx": K[0, 2],
            "cy": K[1, 2],
            "dist_coeffs": getattr(rig, side).dist_coeffs.tolist(),
            "std_fx_fy_cx_cy": list(fit.std_fx_fy_cx_cy),
            "alone_rms_px": fit.rms_px,
            "coverage": coverage_fraction(np.concatenate(points), size) if points else 0.0,
        }
    paths = [
        atomic_write_text(out / "views.csv", _csv(rows)),
        atomic_write_text(out / "summary.json", json.dumps(summary, indent=2, default=float)),
        atomic_write_image(out / "coverage.png", coverage_picture(calibration.views, used, size)),
    ]
    return paths


def write_hand_eye_report(folder: str | Path, calibration: HandEyeCalibration) -> list[Path]:
    """views.csv and summary.json of a hand-eye calibration; returns their paths."""
    out = Path(folder)
    out.mkdir(exist_ok=True)
    residuals = {r.index: r for r in calibration.residuals}
    refused = dict(calibration.refused)
    left_out = set(calibration.left_unused)
    rows = []
    for index in sorted(set(residuals) | set(refused)):
        r = residuals.get(index)
        rows.append(
            {
                "view": index,
                "status": "used" if r else "refused",
                "reason": refused.get(index, ""),
                "left_image": "" if not r else ("left out" if index in left_out else "used"),
                "reprojection_px": _round(r.reprojection_px if r else None),
                "board_offset_mm": _round(r.board_offset_mm if r else None),
                "board_angle_deg": _round(r.board_angle_deg if r else None),
            }
        )
    X = calibration.transform_right_camera_to_hand
    summary = {
        "method": calibration.method,
        "transform_right_camera_to_hand": X.tolist(),
        "translation_mm": (1000.0 * X[:3, 3]).tolist(),
        "quaternion_xyzw": quaternion_xyzw_from_matrix(X[:3, :3]).tolist(),
        "reprojection_rms_px": calibration.reprojection_rms_px,
        "scale_camera_to_robot": calibration.scale,
        "second_axis_turn_deg": calibration.turn_deg,
        "views_used": len(calibration.residuals),
        "views_refused": [{"view": i, "reason": r} for i, r in calibration.refused],
        "left_images_left_out": list(calibration.left_unused),
        "methods": [
            {
                "name": m.name,
                "reprojection_rms_px": m.reprojection_rms_px,
                "board_spread_mm": m.board_spread_mm,
                "board_spread_deg": m.board_spread_deg,
                "translation_mm": (1000.0 * m.transform_right_camera_to_hand[:3, 3]).tolist(),
            }
            for m in calibration.methods
        ],
        "transform_board_to_base": calibration.transform_board_to_base.tolist(),
        "rig": calibration.rig_note,
        "camera_matrices": {
            side: getattr(calibration.rig, side).camera_matrix.tolist() for side in ("left", "right")
        },
        "baseline_mm": 1000.0 * calibration.rig.baseline,
    }
    return [
        atomic_write_text(out / "views.csv", _csv(rows)),
        atomic_write_text(out / "summary.json", json.dumps(summary, indent=2, default=float)),
    ]


def _round(value: float | None) -> str:
    return "" if value is None or not np.isfinite(value) else f"{value:.4f}"


def _csv(rows: list[dict[str, Any]]) -> str:
    out = io.StringIO()
    if rows:
        writer = csv.DictWriter(out, fieldnames=list(rows[0]), lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)
    return out.getvalue()


__all__ = [
    "coverage_fraction",
    "coverage_picture",
    "prepare_folder",
    "write_hand_eye_report",
    "write_stereo_report",
]
