"""The paper report: the writer and plots on small data (fast), pose errors against known
offsets (fast), and a `robot-app paper --quick` run producing every figure (slow)."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from robot_app.cli import main
from robot_app.experiments.paper_report import ClothRow, Fig13Case, PaperFigures, write_paper_report
from robot_app.experiments.report import plot_error_histograms, plot_matrix, plot_sweep
from robot_app.experiments.summary import error_stats
from robot_app.geometry import make_transform, pose_error, rotation_about_z, rotation_from_rpy


def _png_ok(path: Path) -> bool:
    image = cv2.imread(str(path))
    return image is not None and image.shape[0] > 100 and image.shape[1] > 100


def _figures(rng: np.random.Generator) -> PaperFigures:
    errors = {"error_x_mm": rng.normal(0.5, 2.0, 200), "error_yaw_deg": rng.normal(-0.2, 1.0, 200)}
    case = Fig13Case(
        key="c",
        title="No.3 beside No.4",
        paper="No.3 0.788 at (-111, 21) mm; No.4 0.66 at (89, 24) mm",
        paper_fitness=(0.788, 0.66),
        peaks=[(-110.0, 20.0, 0.91), (90.0, 25.0, 0.41)],
        truth_xy_mm=[(-111.0, 21.0), (89.0, 24.0)],
        truth_fitness=[0.9, 0.4],
        ga_fitness=0.93,
        ga_xy_mm=(-109.0, 22.0),
        full_search_evaluations=1000,
        full_search_time_s=0.5,
        ga_time_s=0.1,
        map_png="fig13_c_map.png",
        surface_png="fig13_c_surface.png",
    )
    return PaperFigures(
        source="synthetic",
        cases=[case],
        errors={k: error_stats(v) for k, v in errors.items()},
        fig12_trials=200,
        fig12_ok=200,
        fig12_found_rate=0.99,
        fig12_success_rate=0.97,
        fig12_trials_per_s=3.0,
        fig12_per_cloth=[ClothRow(3, 100, 0.9, 7), ClothRow(4, 100, 1.0, 0)],
        identification_ids=[3, 4],
        identification_fitness=[[0.95, 0.3], [0.2, 0.9]],
        identification_found=[[True, False], [True, True]],
        tolerance_mm=10.0,
        tolerance_deg=10.0,
        workers=2,
        wall_time_s=12.0,
    )


def test_report_writer_puts_ours_beside_the_paper(tmp_path: Path) -> None:
    figures = _figures(np.random.default_rng(0))
    path, table = write_paper_report(figures, tmp_path)
    text = path.read_text()
    assert table in text
    lines = table.splitlines()
    assert lines[0] == "| experiment | paper | ours (measured) |"
    row_c = next(line for line in lines if "Fig. 13 (c)" in line)
    assert "0.788" in row_c and "0.66" in row_c and "0.910 at (-110, 20) mm" in row_c and "0.410" in row_c
    stats = figures.errors["error_x_mm"]
    row_x = next(line for line in lines if "position x error" in line)
    assert "within ±10 mm" in row_x and f"{stats.low:+.2f}" in row_x and f"{stats.high:+.2f}" in row_x
    row_id = next(line for line in lines if line.startswith("| identification"))
    assert "2/2 own cloth found" in row_id and "1/2 other cloths" in row_id
    assert "| No.3 | 100 | 90.0 % | 7 |" in text
    for image in ("fig13_c_map.png", "fig13_c_surface.png", "fig12_errors.png", "identification.png"):
        assert f"({image})" in text


def test_plots_write_images(tmp_path: Path) -> None:
    rng = np.random.default_rng(1)
    rows = [
        {"status": "ok", "error_x_mm": float(v), "error_yaw_deg": float(w)}
        for v, w in rng.normal(0, 3, (50, 2))
    ] + [{"status": "failed", "error_x_mm": "", "error_yaw_deg": ""}]
    hist = plot_error_histograms(rows, tmp_path / "h.png", tolerances={"error_x_mm": 10.0})
    matrix = plot_matrix([[0.9, 0.1], [0.2, 0.8]], tmp_path / "m.png", ["No.1", "No.2"])
    sweep_summary = {
        "sweep": {
            f"recognition.ga.generations={g}": {
                "errors": {"error_x_mm": {"std": 10.0 / g}},
                "rates": {"success": 0.5 + g / 400},
                "mean_times_s": {"recognition_time_s": g / 100},
            }
            for g in (10, 50, 100)
        }
    }
    sweep = plot_sweep(sweep_summary, tmp_path / "s.png")
    assert all(_png_ok(p) for p in (hist, matrix, sweep))


def test_pose_error_against_known_offsets() -> None:
    truth = make_transform(rotation_about_z(0.4), [0.01, -0.02, 0.58])
    moved = make_transform(rotation_about_z(0.4 + np.deg2rad(5.0)), [0.013, -0.024, 0.585])
    error = pose_error(moved, truth)
    assert (error.x_mm, error.y_mm, error.z_mm) == pytest.approx((3.0, -4.0, 5.0))
    assert error.yaw_deg == pytest.approx(5.0) and error.tilt_deg == pytest.approx(0.0, abs=1e-6)
    flipped = make_transform(rotation_about_z(0.4 + np.pi + np.deg2rad(2.0)), truth[:3, 3])
    assert pose_error(flipped, truth).yaw_deg == pytest.approx(-178.0)
    assert pose_error(flipped, truth, (np.pi,)).yaw_deg == pytest.approx(2.0)
    tilted = make_transform(rotation_from_rpy(np.deg2rad(7.0), 0.0, 0.4), truth[:3, 3])
    assert pose_error(tilted, truth).tilt_deg == pytest.approx(7.0)


@pytest.mark.slow
def test_quick_paper_run_writes_every_figure(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "paper"
    code = main(["paper", "--quick", "--out", str(out), "--workers", "2", "--no-progress"])
    assert code == 0
    printed = capsys.readouterr().out
    assert "| experiment | paper | ours (measured) |" in printed
    figures = [f"fig13_{k}_{view}.png" for k in "abc" for view in ("map", "surface")]
    figures += ["fig12_errors.png", "identification.png", "fig12/errors.png"]
    for name in figures:
        assert _png_ok(out / name), name
    report = (out / "report.md").read_text()
    for name in figures[:-1]:
        assert f"({name})" in report
    summary = json.loads((out / "summary.json").read_text())
    assert len(summary["cases"]) == 3 and summary["fig12_ok"] == summary["fig12_trials"] == 24
    a = summary["cases"][0]
    assert a["peaks"][0][2] > 0.8  # an undisturbed cloth matches its own model well
    assert np.hypot(a["peaks"][0][0] - 9.0, a["peaks"][0][1] - 11.0) < 15.0  # near its true centre
    for folder in ("fig12", "identification"):
        assert (out / folder / "trials.csv").exists() and (out / folder / "config.yaml").exists()
