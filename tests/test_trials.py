"""The sweep machinery with a cheap stand-in trial function (the real kinds are tested
elsewhere): seeds, crash capture, streaming CSV, resume, summary, worker equality."""

from __future__ import annotations

import csv
import json
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from robot_app.errors import InputError, OutputError
from robot_app.experiments.experiment_config import RecognitionTrialConfig, parse_trial_config
from robot_app.experiments.results_table import ResultsTable, is_timing_column, table_columns
from robot_app.experiments.trial_result import execute_trial, trial_seed
from robot_app.experiments.trials import SweepInterruptedError, run_sweep

_INTERRUPT_AT: dict[str, int] = {}


@dataclass(frozen=True)
class FakeOutcome:
    cloth_id: int
    found: bool
    error_x_mm: float
    generations: int
    fake_time_s: float


def fake_trial(config: RecognitionTrialConfig, scene_index: int, seed: int) -> FakeOutcome:
    """Deterministic in (config, scene, seed); crashes on scenes 3, 10, 17, ..."""
    if _INTERRUPT_AT.get("scene") == scene_index:
        raise KeyboardInterrupt
    if scene_index % 7 == 3:
        raise ValueError(f"bad scene {scene_index}")
    rng = np.random.default_rng(seed)
    generations = int(config.recognition.get("generations", 100))
    return FakeOutcome(
        cloth_id=config.scene.cloth_ids[scene_index % len(config.scene.cloth_ids)],
        found=bool(rng.random() < 0.8),
        error_x_mm=float(rng.normal(1.0, 100.0 / generations)),
        generations=generations,
        fake_time_s=0.001,
    )


def dying_trial(config: RecognitionTrialConfig, scene_index: int, seed: int) -> FakeOutcome:
    """Kills its worker process on scene 2 (a native crash), else like fake_trial."""
    if scene_index == 2:
        os._exit(3)
    return fake_trial(config, scene_index, seed)


def _config(**changes: object) -> RecognitionTrialConfig:
    data = {"name": "fake", "trials": 12, "seed": 7, **changes}
    config = parse_trial_config(data)
    assert isinstance(config, RecognitionTrialConfig)
    return config


def _rows(folder: Path) -> list[dict[str, str]]:
    with (folder / "trials.csv").open(newline="") as file:
        return [{k: v for k, v in row.items() if not is_timing_column(k)} for row in csv.DictReader(file)]


def test_seeds_depend_on_base_and_scene_only() -> None:
    assert trial_seed(7, 3) == trial_seed(7, 3)
    seeds = {trial_seed(7, i) for i in range(1000)}
    assert len(seeds) == 1000
    assert trial_seed(8, 3) != trial_seed(7, 3)
    with pytest.raises(ValueError):
        trial_seed(7, -1)


def test_crash_becomes_failed_row_with_reason() -> None:
    result = execute_trial(fake_trial, _config(), 3)
    assert result.status == "failed" and result.outcome is None
    assert "ValueError: bad scene 3" in result.reason and "test_trials.py" in result.reason
    ok = execute_trial(fake_trial, _config(), 4)
    assert ok.status == "ok" and ok.reason == "" and isinstance(ok.outcome, FakeOutcome)


def test_sweep_writes_table_summary_and_config(tmp_path: Path) -> None:
    config = _config(trials=30)
    result = run_sweep(config, fake_trial, FakeOutcome, tmp_path / "run", progress=False)
    rows = _rows(tmp_path / "run")
    assert [int(r["index"]) for r in rows] == list(range(30))
    failed = [int(r["index"]) for r in rows if r["status"] == "failed"]
    assert failed == [3, 10, 17, 24] and result.failed == 4 and result.ran == 30
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert summary["ok"] == 26 and summary["failed"] == 4
    errors = np.array([float(r["error_x_mm"]) for r in rows if r["status"] == "ok"])
    stats = summary["errors"]["error_x_mm"]
    assert stats["count"] == 26
    assert stats["mean"] == pytest.approx(errors.mean())
    assert stats["high"] == pytest.approx(errors.mean() + 3 * errors.std(ddof=1))
    found = [r["found"] == "True" for r in rows if r["status"] == "ok"]
    assert summary["rates"]["found"] == pytest.approx(np.mean(found))
    assert (tmp_path / "run" / "config.yaml").exists()
    assert summary["config_hash"] == config.config_hash()


def test_interrupted_sweep_resumes_without_redoing(tmp_path: Path) -> None:
    config = _config(trials=20)
    reference = tmp_path / "reference"
    run_sweep(config, fake_trial, FakeOutcome, reference, progress=False)
    folder = tmp_path / "interrupted"
    _INTERRUPT_AT["scene"] = 9
    try:
        with pytest.raises(SweepInterruptedError, match="rerun the same command"):
            run_sweep(config, fake_trial, FakeOutcome, folder, progress=False)
    finally:
        _INTERRUPT_AT.clear()
    assert len(_rows(folder)) == 9
    with (folder / "trials.csv").open("a") as file:
        file.write("9,123,0,,ok,")  # a half-written line from a killed process
    resumed = run_sweep(config, fake_trial, FakeOutcome, folder, progress=False)
    assert resumed.skipped == 9 and resumed.ran == 11
    assert _rows(folder) == _rows(reference)
    again = run_sweep(config, fake_trial, FakeOutcome, folder, progress=False)
    assert again.ran == 0 and again.skipped == 20
    extended = config.model_copy(update={"trials": 25})
    longer = run_sweep(extended, fake_trial, FakeOutcome, folder, progress=False)
    assert longer.ran == 5 and len(_rows(folder)) == 25


def test_resume_refuses_a_different_config(tmp_path: Path) -> None:
    run_sweep(_config(), fake_trial, FakeOutcome, tmp_path, progress=False)
    with pytest.raises(OutputError) as other:
        run_sweep(_config(seed=8), fake_trial, FakeOutcome, tmp_path, progress=False)
    assert (other.value.path, other.value.key, other.value.value) == (tmp_path, "--out", str(tmp_path))
    assert _config(seed=8).config_hash() in other.value.expected  # the config given
    assert _config(seed=8).config_hash() != _config().config_hash()
    with pytest.raises(OutputError) as no_resume:
        run_sweep(_config(), fake_trial, FakeOutcome, tmp_path, progress=False, resume=False)
    assert (no_resume.value.path, no_resume.value.key) == (tmp_path, "--out")


def test_table_refuses_other_columns(tmp_path: Path) -> None:
    run_sweep(_config(), fake_trial, FakeOutcome, tmp_path, progress=False)

    @dataclass(frozen=True)
    class Other:
        value: float

    with pytest.raises(InputError) as columns:
        ResultsTable(tmp_path / "trials.csv", Other)
    assert columns.value.path == tmp_path / "trials.csv"
    assert columns.value.value == list(table_columns(FakeOutcome))  # the header in the file


def test_sweep_points_share_scenes_and_summarise_separately(tmp_path: Path) -> None:
    config = _config(trials=24, sweep={"key": "recognition.generations", "values": [10, 1000]})
    run_sweep(config, fake_trial, FakeOutcome, tmp_path, progress=False)
    rows = _rows(tmp_path)
    by_point = [[r for r in rows if r["point"] == str(p)] for p in (0, 1)]
    assert [r["seed"] for r in by_point[0]] == [r["seed"] for r in by_point[1]]
    assert {r["generations"] for r in by_point[1] if r["status"] == "ok"} == {"1000"}
    summary = json.loads((tmp_path / "summary.json").read_text())
    coarse = summary["sweep"]["recognition.generations=10"]["errors"]["error_x_mm"]["std"]
    fine = summary["sweep"]["recognition.generations=1000"]["errors"]["error_x_mm"]["std"]
    assert fine < coarse / 10


def test_two_workers_give_the_same_rows_as_one(tmp_path: Path) -> None:
    config = _config(trials=16)
    run_sweep(config, fake_trial, FakeOutcome, tmp_path / "one", workers=1, progress=False)
    run_sweep(config, fake_trial, FakeOutcome, tmp_path / "two", workers=2, progress=False)
    assert _rows(tmp_path / "one") == _rows(tmp_path / "two")


def test_dead_worker_is_a_failed_row_and_the_sweep_goes_on(tmp_path: Path) -> None:
    config = _config(trials=8)
    result = run_sweep(config, dying_trial, FakeOutcome, tmp_path, workers=2, progress=False)
    rows = _rows(tmp_path)
    assert [int(r["index"]) for r in rows] == list(range(8))
    dead = [r for r in rows if "WorkerDied" in r["reason"]]
    assert [r["index"] for r in dead] == ["2"]
    assert result.failed == 2  # scene 2 (died) and scene 3 (raised)


def test_bad_workers_and_backend_are_input_errors(tmp_path: Path) -> None:
    with pytest.raises(InputError) as workers:
        run_sweep(_config(), fake_trial, FakeOutcome, tmp_path, workers=0, progress=False)
    assert (workers.value.key, workers.value.value) == ("--workers", 0)
    with pytest.raises(InputError) as backend:
        run_sweep(_config(), fake_trial, FakeOutcome, tmp_path, backend="slurm", progress=False)  # type: ignore[arg-type]
    assert (backend.value.key, backend.value.value) == ("--backend", "slurm")


@pytest.mark.slow
@pytest.mark.parametrize("source", ["synthetic", "sim"])
def test_real_recognition_trials_measure_small_errors(tmp_path: Path, source: str) -> None:
    from robot_app.experiments import run_trials

    config = _config(trials=2, source=source, scene={"cloth_ids": [1, 9]})
    result = run_trials(config, tmp_path, progress=False)
    rows = _rows(tmp_path)
    assert result.failed == 0 and [r["cloth_id"] for r in rows] == ["1", "9"]
    for row in rows:
        assert row["found"] == "True"
        assert abs(float(row["error_x_mm"])) < 10 and abs(float(row["error_y_mm"])) < 10
    assert (tmp_path / "errors.png").exists()
