"""`robot-app paper`: the paper's experiments (Fig. 11-13, identification), measured anew.

- Fig. 11/13 (a, b, c): cloth No.3 near the centre without disturbance, ~45% hidden by
  a blue sheet, and beside cloth No.4. For each: the full-search fitness distribution
  over the x-y plane (best over a yaw grid) and the GA's individuals after its
  generations, the peaks' fitness and positions.
- Fig. 12: error histograms over many recognitions covering all 12 cloths (a trial
  sweep, run with the worker pool), mean ± 3σ marked.
- Identification: the best fitness of model i in a scene holding only cloth j.

Everything lands in one folder: config.yaml (these settings), summary.json, report.md,
the PNGs and the sweeps' own folders (fig12/, identification/).
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from robot_app.config import dump_config
from robot_app.errors import InterruptError
from robot_app.experiments.identification_trial import IdentificationOutcome, run_identification_trial
from robot_app.experiments.image_sources import image_source
from robot_app.experiments.kinds import run_trials
from robot_app.experiments.paper_config import (
    QUICK,
    Fig13Settings,
    PaperConfig,
    check_paper,
    load_paper_config,
    sweep_configs,
)
from robot_app.experiments.paper_report import ClothRow, Fig13Case, PaperFigures, write_paper_report
from robot_app.experiments.recognition_trial import check_recognition_config, recognizer_settings
from robot_app.experiments.report import plot_error_histograms, plot_matrix
from robot_app.experiments.scenes import OBSERVATION_DEPTH, Placement, SceneSample
from robot_app.experiments.summary import error_stats, write_summary
from robot_app.experiments.trials import run_sweep
from robot_app.interrupts import interrupt_signal, signal_name
from robot_app.outputs import atomic_path
from robot_app.resources import ResourceLimits

# --- Fig. 11/13 -------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Case:
    key: str
    title: str
    scene: SceneSample
    paper: str
    paper_fitness: tuple[float, ...]


def fig13_cases() -> list[_Case]:
    """The three scenes of Fig. 11: No.3 alone, No.3 45% hidden, No.3 beside No.4."""
    no3 = Placement(3, 0.009, 0.011, np.deg2rad(30.0))
    alone, hidden = SceneSample(3, no3, None, 0.0, 0.0, 0.0), SceneSample(3, no3, None, 0.45, 0.0, 0.0)
    return [
        _Case("a", "No.3 without disturbance", alone, "0.85 at (9, 11) mm", (0.85,)),
        _Case("b", "No.3 about 45% hidden", hidden, "0.32 at (-6, 0) mm", (0.32,)),
        _Case(
            "c",
            "No.3 beside No.4",
            SceneSample(
                3,
                Placement(3, -0.111, 0.021, np.deg2rad(30.0)),
                Placement(4, 0.089, 0.024, np.deg2rad(-60.0)),
                0.0,
                0.0,
                0.0,
            ),
            "No.3 0.788 at (-111, 21) mm; No.4 0.66 at (89, 24) mm",
            (0.788, 0.66),
        ),
    ]


def run_fig13_case(case: _Case, settings: PaperConfig, out: Path) -> Fig13Case:
    """Full search and GA on one Fig. 11 scene; writes its 2D map and 3D surface."""
    from robot_app.vision.fitness import FitnessEvaluator, KernelFitness
    from robot_app.vision.full_search import find_peaks, full_search
    from robot_app.vision.ga import GASettings, GeneticAlgorithm
    from robot_app.vision.plots import plot_full_search

    recognition = recognizer_settings(settings.recognition)
    source = image_source(settings.source)
    rng = np.random.default_rng([settings.seed, ord(case.key)])
    rendered = source.render(case.scene, rng)
    evaluator = FitnessEvaluator(source.model(case.scene.target_id), source.rig, recognition.fitness)
    evaluator.update(rendered.left_bgr, rendered.right_bgr)
    start = time.perf_counter()
    step = settings.fig13.yaw_step_deg
    yaws = np.deg2rad(np.arange(-180.0, 180.0, step))
    search = full_search(evaluator, step=settings.fig13.step_m, depth=OBSERVATION_DEPTH, yaws=yaws)
    search_time = time.perf_counter() - start
    peaks = find_peaks(search, min_separation=0.08, min_fitness=0.05)[: max(2, len(case.paper_fitness))]
    sizes = {"population": settings.fig13.population, "generations": settings.fig13.generations}
    ga_settings = GASettings.model_validate({**recognition.propose.ga.model_dump(), **sizes})
    rng_ga = np.random.default_rng(settings.seed)
    ga = GeneticAlgorithm(recognition.propose.bounds, ga_settings, rng_ga)
    start = time.perf_counter()
    best = ga.run(KernelFitness(evaluator))  # the reported fitness: the paper's by `recognition.fitness`
    ga_time = time.perf_counter() - start
    individuals = ga.transforms(ga.population) if ga.population is not None else None
    map_png, surface_png = out / f"fig13_{case.key}_map.png", out / f"fig13_{case.key}_surface.png"
    title = f"Fig. 13 ({case.key}) {case.title}: model No.{case.scene.target_id}"
    with atomic_path(map_png) as map_file, atomic_path(surface_png) as surface_file:
        plot_full_search(search, map_file, surface_file, individuals=individuals, title=title)
    truths = [p for p in (case.scene.target, case.scene.distractor) if p is not None]
    gx, gy = np.meshgrid(search.xs, search.ys)
    near = [np.hypot(gx - p.x, gy - p.y) <= max(0.02, search.step) for p in truths]
    return Fig13Case(
        key=case.key,
        title=case.title,
        paper=case.paper,
        paper_fitness=case.paper_fitness,
        peaks=[(1000 * p.x, 1000 * p.y, p.fitness) for p in peaks],
        truth_xy_mm=[(1000 * p.x, 1000 * p.y) for p in truths],
        truth_fitness=[float(search.fitness[mask].max()) for mask in near],
        ga_fitness=best.fitness,
        ga_xy_mm=(1000 * best.transform_model_to_camera[0, 3], 1000 * best.transform_model_to_camera[1, 3]),
        full_search_evaluations=search.evaluations,
        full_search_time_s=search_time,
        ga_time_s=ga_time,
        map_png=map_png.name,
        surface_png=surface_png.name,
    )


# --- the whole run -------------------------------------------------------------------------------


@dataclass(frozen=True)
class PaperReport:
    """A finished `robot-app paper` run.

    Attributes:
        out_dir: the report folder.
        report_path: its report.md.
        table_markdown: the paper-vs-ours table.
        wall_time_s: wall time of the whole run [s].
        figures: everything measured.
    """

    out_dir: Path
    report_path: Path
    table_markdown: str
    wall_time_s: float
    figures: PaperFigures


def run_paper(
    settings: PaperConfig,
    out_dir: str | Path,
    *,
    workers: int = 2,
    progress: bool = True,
    limits: ResourceLimits | None = None,
) -> PaperReport:
    """Runs every experiment and writes the report folder.

    Args:
        settings: what to run (see `load_paper_config`).
        out_dir: the report folder (the sweeps inside it resume if rerun with the same settings).
        workers: worker processes for the sweeps.
        progress: show progress bars.
        limits: resource limits (default limits if None).

    Raises:
        InputError, OutputError, ResourceError: see `check_paper`, before anything is written.
        InterruptError: Ctrl-C or SIGTERM; the parts finished are on disk and summary.json
            says `"status": "interrupted"`.
    """
    start = time.perf_counter()
    out = Path(out_dir)
    limits = limits or ResourceLimits()
    check_paper(settings, out, workers, limits)
    finished: list[str] = []
    try:
        return _run_paper(settings, out, workers, progress, limits, start, finished)
    except (KeyboardInterrupt, InterruptError) as err:
        number = interrupt_signal(err)
        status = {"status": "interrupted", "signal": signal_name(number), "finished": finished}
        write_summary(status, out / "summary.json")
        done = ", ".join(finished) or "nothing"
        raise InterruptError(
            f"stopped by {signal_name(number)}; finished: {done} (in {out}); rerun the same command "
            "to resume the trial sweeps",
            signal_number=number,
        ) from err


def _run_paper(
    settings: PaperConfig,
    out: Path,
    workers: int,
    progress: bool,
    limits: ResourceLimits,
    start: float,
    finished: list[str],
) -> PaperReport:
    out.mkdir(parents=True, exist_ok=True)
    dump_config(settings, out / "config.yaml")
    cases = []
    for case in fig13_cases():
        cases.append(run_fig13_case(case, settings, out))
        finished.append(f"fig13_{case.key}")
    fig12_config, ident_config = sweep_configs(settings)
    fig12 = run_trials(fig12_config, out / "fig12", workers=workers, progress=progress, limits=limits)
    rows = _rows(out / "fig12")
    columns = ["error_x_mm", "error_y_mm", "error_yaw_deg", "error_z_mm", "error_tilt_deg"]
    bounds = {"error_x_mm": settings.tolerance_mm, "error_y_mm": settings.tolerance_mm}
    bounds["error_yaw_deg"] = settings.tolerance_deg
    plot_error_histograms(rows, out / "fig12_errors.png", columns, "Fig. 12: errors over all cloths", bounds)
    finished.append("fig12")
    ids = list(settings.identification_cloths)
    check_recognition_config(ident_config)
    run_sweep(
        ident_config, run_identification_trial, IdentificationOutcome, out / "identification",
        workers=workers, progress=progress, limits=limits,
    )  # fmt: skip
    fitness, found = _matrix(_rows(out / "identification"), ids)
    labels = [f"No.{i}" for i in ids]
    title = "identification: best fitness (row: model, column: cloth in the scene)"
    plot_matrix(fitness, out / "identification.png", labels, title)
    finished.append("identification")
    figures = PaperFigures(
        source=settings.source,
        cases=cases,
        errors={c: error_stats([r[c] for r in rows if r["status"] == "ok" and r[c] != ""]) for c in columns},
        fig12_trials=settings.fig12_trials,
        fig12_ok=fig12.summary["ok"],
        fig12_found_rate=fig12.summary["rates"].get("found", float("nan")),
        fig12_success_rate=fig12.summary["rates"].get("success", float("nan")),
        fig12_trials_per_s=fig12.summary["run"].get("trials_per_s") or float("nan"),
        fig12_per_cloth=_per_cloth(rows),
        identification_ids=ids,
        identification_fitness=fitness.tolist(),
        identification_found=found.tolist(),
        tolerance_mm=settings.tolerance_mm,
        tolerance_deg=settings.tolerance_deg,
        workers=workers,
        wall_time_s=time.perf_counter() - start,
    )
    report_path, table = write_paper_report(figures, out)
    write_summary(asdict(figures) | {"status": "finished"}, out / "summary.json")
    return PaperReport(out, report_path, table, figures.wall_time_s, figures)


def _per_cloth(rows: list[dict[str, Any]]) -> list[ClothRow]:
    ok = [r for r in rows if r["status"] == "ok"]
    table = []
    for cloth in sorted({int(r["cloth_id"]) for r in ok}):
        mine = [r for r in ok if int(r["cloth_id"]) == cloth]
        success = sum(bool(r["success"]) for r in mine) / len(mine)
        half_turns = sum(abs(float(r["error_yaw_deg"])) > 90.0 for r in mine)
        table.append(ClothRow(cloth, len(mine), success, half_turns))
    return table


def _rows(folder: Path) -> list[dict[str, Any]]:
    from robot_app.experiments.results_table import read_table

    return read_table(folder / "trials.csv")


def _matrix(rows: list[dict[str, Any]], ids: list[int]) -> tuple[np.ndarray, np.ndarray]:
    index = {cloth: k for k, cloth in enumerate(ids)}
    fitness = np.full((len(ids), len(ids)), np.nan)
    found = np.zeros((len(ids), len(ids)), dtype=bool)
    for row in rows:
        if row["status"] == "ok":
            i, j = index[int(row["model_id"])], index[int(row["scene_id"])]
            fitness[i, j], found[i, j] = float(row["fitness"]), bool(row["found"])
    return fitness, found


__all__ = [
    "QUICK",
    "Fig13Settings",
    "IdentificationOutcome",
    "PaperConfig",
    "PaperReport",
    "check_paper",
    "fig13_cases",
    "load_paper_config",
    "run_fig13_case",
    "run_identification_trial",
    "run_paper",
]
