"""`robot-app calibrate stereo | hand-eye`: the rig file from board images, as on a real robot."""

from __future__ import annotations

import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from robot_app.errors import CalibrationError
from robot_app.outputs import check_output_file

if TYPE_CHECKING:
    from robot_app.calibration.flat_field import FlatField

calibrate_app = typer.Typer(
    help="Calibrate the hand cameras from board images: stereo first, then hand-eye.", no_args_is_help=True
)

ImagesOption = Annotated[
    Path, typer.Option("--images", help="Folder of left_<n>.png / right_<n>.png board images.")
]
BoardOption = Annotated[
    Path, typer.Option("--board", help="Board YAML (type, rows, cols, square_size in metres).")
]
ReportOption = Annotated[
    Path | None,
    typer.Option("--report", help="Folder for views.csv, summary.json (default: next to the rig)."),
]
FlatFieldOption = Annotated[
    Path | None,
    typer.Option(
        "--flat-field",
        help="Folder of left_<n>.png / right_<n>.png frames of a uniformly lit white card, divided "
        "out of the images before the corners are found (default: the images' flat_field/ if it exists).",
    ),
]
MaxBlurOption = Annotated[
    float, typer.Option("--max-edge-width", help="Refuse views whose edges rise over more pixels (blur).")
]


@calibrate_app.command("stereo")
def stereo(
    images: ImagesOption,
    board: BoardOption,
    out: Annotated[Path, typer.Option("--out", help="Rig YAML to write.")],
    report: ReportOption = None,
    min_views: Annotated[int, typer.Option("--min-views", help="Fewest usable image pairs.")] = 10,
    max_edge_width: MaxBlurOption = 4.0,
    max_view_error: Annotated[
        float,
        typer.Option(
            "--max-view-error", help="Refuse views with a larger RMS error in px (and 3x the median)."
        ),
    ] = 1.0,
    fit_k3: Annotated[bool, typer.Option("--fit-k3", help="Also fit k3 (wide-angle lenses).")] = False,
    flat_field: FlatFieldOption = None,
) -> None:
    """Intrinsics, distortion and the left-to-right pose of the two cameras (OpenCV stereoCalibrate).

    Writes the rig file (without transform_right_camera_to_hand: run `calibrate hand-eye`
    next) and a report folder: views.csv (per view: used or refused and why, RMS error
    per camera), summary.json and coverage.png (where the corners fell on each image).
    """
    from robot_app.calibration import (
        DetectionSettings,
        StereoCalibrationSettings,
        calibrate_stereo,
        find_image_pairs,
        load_board,
        prepare_folder,
        write_rig,
        write_stereo_report,
    )

    board_config = load_board(board)
    rig_path = check_output_file(out, key="--out", suffixes=(".yaml", ".yml"))
    report_dir = prepare_folder(report or rig_path.with_name(f"{rig_path.stem}_stereo_report"))
    settings = StereoCalibrationSettings(
        detection=DetectionSettings(max_edge_width_px=max_edge_width),
        min_views=min_views,
        fit_k3=fit_k3,
        max_view_error_px=max_view_error,
    )
    pairs = find_image_pairs(images)
    flat = _flat_field(images, flat_field)
    views, size = _detect(pairs, board_config, settings.detection, flat)
    if size is None:
        raise CalibrationError(f"no image in {images} could be read", path=images, key="--images")
    with _naming_board(board):
        result = calibrate_stereo(views, board_config, size, settings)
    rig = result.rig
    write_rig(
        rig,
        rig_path,
        (  # header comment lines of the rig file
            f"robot-app calibrate stereo: {len(result.used)} of {len(views)} views",
            f"board: {board_config.describe()}",
            f"reprojection RMS {result.rms_px:.3f} px; no transform_right_camera_to_hand: calibrate hand-eye",
            _flat_note(flat),
        ),
    )
    paths = write_stereo_report(report_dir, result, board_config)
    for index, reason in result.refused:
        typer.echo(f"  view {index}: refused: {reason}")
    for error in result.view_errors:
        left, right = (
            f"{e:.3f} px" if e is not None else "not used" for e in (error.left_px, error.right_px)
        )
        typer.echo(f"  view {error.index}: left {left}, right {right}")
    typer.echo(
        f"used {len(result.used)} of {len(views)} views; reprojection RMS {result.rms_px:.3f} px "
        f"(alone: left {result.left.rms_px:.3f}, right {result.right.rms_px:.3f})"
    )
    for side, fit in (("left", result.left), ("right", result.right)):
        K, dist = getattr(rig, side).camera_matrix, getattr(rig, side).dist_coeffs
        std = fit.std_fx_fy_cx_cy
        typer.echo(
            f"{side:>5}: fx {K[0, 0]:.2f}±{std[0]:.2f} fy {K[1, 1]:.2f}±{std[1]:.2f} "
            f"cx {K[0, 2]:.2f}±{std[2]:.2f} cy {K[1, 2]:.2f}±{std[3]:.2f} px; "
            f"k1 {dist[0]:+.4f} k2 {dist[1]:+.4f} p1 {dist[2]:+.5f} p2 {dist[3]:+.5f} k3 {dist[4]:+.4f}"
        )
    T = rig.transform_left_to_right[:3, 3] * 1000
    typer.echo(f"baseline {rig.baseline * 1000:.2f} mm, T = ({T[0]:.2f}, {T[1]:.2f}, {T[2]:.2f}) mm")
    typer.echo(f"wrote {rig_path}; report {', '.join(str(p) for p in paths)}")


@calibrate_app.command("hand-eye")
def hand_eye(
    images: ImagesOption,
    robot_poses: Annotated[
        Path, typer.Option("--robot-poses", help="CSV: index,x,y,z,qx,qy,qz,qw (flange in base, m).")
    ],
    rig: Annotated[Path, typer.Option("--rig", help="Rig YAML from `calibrate stereo`.")],
    board: BoardOption,
    out: Annotated[
        Path | None, typer.Option("--out", help="Rig YAML to write (default: update --rig in place).")
    ] = None,
    report: ReportOption = None,
    method: Annotated[
        str, typer.Option("--method", help="auto (lowest residual) | tsai | park | daniilidis.")
    ] = "auto",
    refine: Annotated[
        bool, typer.Option("--refine/--no-refine", help="Refine over the pixel errors of both cameras.")
    ] = True,
    refine_rig: Annotated[
        bool,
        typer.Option(
            "--refine-rig/--keep-rig",
            help="Refine the intrinsics and the stereo pose with X (robot-aided), or keep the --rig's.",
        ),
    ] = True,
    min_views: Annotated[int, typer.Option("--min-views", help="Fewest usable views.")] = 6,
    max_edge_width: MaxBlurOption = 4.0,
    flat_field: FlatFieldOption = None,
) -> None:
    """The right camera's pose on the hand from views of a fixed board at several arm poses.

    Writes transform_right_camera_to_hand into the rig file (with the intrinsics and the
    stereo pose refined together with it, unless --keep-rig) and a report folder
    (views.csv: per view its pixel error and how far its board pose is from the others';
    summary.json: every method's residuals).
    """
    from robot_app.calibration import (
        HandEyeSettings,
        calibrate_hand_eye,
        find_image_pairs,
        load_board,
        match_robot_poses,
        prepare_folder,
        read_robot_poses,
        write_hand_eye_report,
        write_rig,
    )
    from robot_app.config import validate
    from robot_app.vision.camera import load_rig

    board_config = load_board(board)
    stereo_rig = load_rig(rig)
    settings = validate(
        HandEyeSettings,
        {
            "detection": {"max_edge_width_px": max_edge_width},
            "min_views": min_views,
            "method": method,
            "refine": refine,
            "refine_rig": refine_rig,
        },
        "command-line options",
    )
    rig_path = check_output_file(out or rig, key="--out", suffixes=(".yaml", ".yml"))
    report_dir = prepare_folder(report or rig_path.with_name(f"{rig_path.stem}_hand_eye_report"))
    pairs = find_image_pairs(images)
    poses = match_robot_poses(pairs, read_robot_poses(robot_poses), str(robot_poses))
    flat = _flat_field(images, flat_field)
    views, size = _detect(pairs, board_config, settings.detection, flat)
    if size is not None and size != stereo_rig.image_size:
        raise CalibrationError(
            f"the images are {size[0]}x{size[1]} px but {rig} is for {stereo_rig.image_size[0]}x"
            f"{stereo_rig.image_size[1]} px",
            path=rig,
            key="--rig",
            value=list(size),
        )
    with _naming_board(board):
        result = calibrate_hand_eye(views, poses, stereo_rig, board_config, settings)
    X = result.transform_right_camera_to_hand
    write_rig(
        result.rig,
        rig_path,
        (
            f"robot-app calibrate hand-eye: {len(result.residuals)} views, method {result.method}",
            f"reprojection RMS {result.reprojection_rms_px:.3f} px",
            result.rig_note,
            _flat_note(flat),
        ),
    )
    paths = write_hand_eye_report(report_dir, result)
    for index, reason in result.refused:
        typer.echo(f"  view {index}: refused: {reason}")
    for index in result.left_unused:
        typer.echo(f"  view {index}: left image left out (its corners do not fit the others)")
    for r in result.residuals:
        typer.echo(
            f"  view {r.index}: {r.reprojection_px:.3f} px; board pose off the mean by "
            f"{r.board_offset_mm:.2f} mm, {r.board_angle_deg:.3f} deg"
        )
    typer.echo("methods (reprojection RMS over all corners, spread of the board pose over the views):")
    for m in result.methods:
        typer.echo(
            f"  {m.name:<10} {m.reprojection_rms_px:.3f} px, "
            f"{m.board_spread_mm:.2f} mm, {m.board_spread_deg:.3f} deg"
        )
    t = X[:3, 3] * 1000
    typer.echo(
        f"method {result.method}: camera in the hand at ({t[0]:.2f}, {t[1]:.2f}, {t[2]:.2f}) mm; "
        f"camera/robot motion scale {result.scale:.4f}; "
        f"hand turned {result.turn_deg:.1f} deg about a second axis"
    )
    typer.echo(result.rig_note)
    typer.echo(f"wrote {rig_path}; report {', '.join(str(p) for p in paths)}")


def _flat_field(images: Path, given: Path | None) -> FlatField | None:
    """The measured flat field of --flat-field, or of the images' flat_field/ folder, or None."""
    from robot_app.calibration import flat_field_for, load_flat_field

    folder = flat_field_for(images, given)
    if folder is None:
        return None
    flat = load_flat_field(folder)
    typer.echo(f"{flat.describe()}: divided out before the corners are found")
    return flat


def _flat_note(flat: FlatField | None) -> str:
    """The rig file's header line about the flat field."""
    if flat is None:
        return "corners found in the images as they are (no flat field)"
    return f"corners found after dividing out the {flat.describe()}"


def _detect(pairs, board_config, detection, flat):
    """Detects the board in every pair with a progress bar on stderr."""
    from robot_app.calibration import detect_views

    with typer.progressbar(length=len(pairs), label="finding the board", file=sys.stderr) as bar:

        def progress(done: int, total: int) -> None:
            bar.update(1)

        return detect_views(pairs, board_config, detection, progress=progress, flat_field=flat)


@contextmanager
def _naming_board(path: Path) -> Iterator[None]:
    """Puts the board file's path into a calibration error about the board."""
    try:
        yield
    except CalibrationError as err:
        if err.key != "--board" or err.path is not None:
            raise
        value = {"value": err.value} if err.has_value else {}
        raise CalibrationError(
            f"--board {path}: {err.message}", path=path, key=err.key, expected=err.expected, **value
        ) from err


def register(app: typer.Typer) -> None:
    """Adds `calibrate` to the `robot-app` CLI."""
    app.add_typer(calibrate_app, name="calibrate")


__all__ = ["register"]
