"""Output paths and resource limits, over every subcommand that writes or scales.

Outputs are checked before the work (a wrong path never costs a run), files are written
whole, and a rejected command leaves nothing behind. Inputs that scale memory or time
are refused with the value and the limit, and the limit can be raised on purpose.
"""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml

from robot_app.vision.photo_model import ClothModel
from tests.cli_inputs import FAST_GA, REPO, Inputs, assert_one_line_error, files_under, make_inputs, run_cli

READ_ONLY = Path("/proc/robot_app_out")  # even root cannot create files in /proc
FULLSEARCH_FAST = ["--step", "0.02", "--seed", "2", *FAST_GA]
TRIAL_CONFIG = REPO / "configs" / "default.yaml"


@pytest.fixture(scope="module")
def inputs(tmp_path_factory: pytest.TempPathFactory) -> Inputs:
    return make_inputs(tmp_path_factory.mktemp("outputs"))


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


# --- fullsearch ------------------------------------------------------------------------------------


def test_fullsearch_out_naming_a_file(inputs, capsys, tmp_path) -> None:
    target = tmp_path / "taken.txt"
    target.write_text("keep me")
    run = run_cli(capsys, "fullsearch", *inputs.recognize_args(), "--out", target, *FULLSEARCH_FAST)
    assert_one_line_error(run, 2, "--out", str(target), "is a file")
    assert target.read_text() == "keep me"


def test_fullsearch_into_a_folder_with_files_needs_force(inputs, capsys, tmp_path) -> None:
    folder = tmp_path / "fs"
    folder.mkdir()
    (folder / "notes.txt").write_text("mine")
    run = run_cli(capsys, "fullsearch", *inputs.recognize_args(), "--out", folder, *FULLSEARCH_FAST)
    assert_one_line_error(run, 2, "--out", "already holds files", "notes.txt", "--force")
    assert files_under(folder) == ["notes.txt"]
    run = run_cli(
        capsys, "fullsearch", *inputs.recognize_args(), "--out", folder, "--force", *FULLSEARCH_FAST
    )
    assert run.code == 0, run.err
    assert files_under(folder) == [
        "config.yaml",
        "fullsearch_2d.png",
        "fullsearch_3d.png",
        "notes.txt",
        "summary.json",
    ]  # no temporaries left
    assert json.loads((folder / "summary.json").read_text())["full_search"]["step_m"] == 0.02


def test_fullsearch_under_a_read_only_location(inputs, capsys) -> None:
    run = run_cli(capsys, "fullsearch", *inputs.recognize_args(), "--out", READ_ONLY, *FULLSEARCH_FAST)
    assert_one_line_error(run, 2, "--out", "cannot write")


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders")
def test_fullsearch_under_a_folder_without_write_permission(inputs, capsys, tmp_path) -> None:
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o555)
    try:
        run = run_cli(
            capsys, "fullsearch", *inputs.recognize_args(), "--out", locked / "fs", *FULLSEARCH_FAST
        )
        assert_one_line_error(run, 2, "--out", "cannot write")
    finally:
        locked.chmod(0o755)


@pytest.mark.parametrize(
    ("extra", "words"),
    [
        (["--step", "0.00001"], ("--step", "1e-05", "GB", "--max-memory-gb")),
        (["--step", "0.0002", "--yaw-step-deg", "1"], ("--step", "poses", "50,000,000", "--allow-large")),
        (["--step", "0.001", "--max-memory-gb", "0.01"], ("--step", "10 MB")),
        (["--step", "0"], ("--step", "> 0")),
        (["--yaw-step-deg", "0"], ("--yaw-step-deg",)),
        (["--seed", "-1"], ("--seed",)),
    ],
)
def test_a_rejected_fullsearch_leaves_nothing(inputs, capsys, tmp_path, extra, words) -> None:
    out = tmp_path / "new" / "fs"
    run = run_cli(capsys, "fullsearch", *inputs.recognize_args(), "--out", out, *FAST_GA, *extra)
    assert_one_line_error(run, 2, *words)
    assert list(tmp_path.iterdir()) == []  # no folder, no empty folder


# --- model make ------------------------------------------------------------------------------------


def _make(capsys, inputs: Inputs, *extra: object, camera: Path | None = None):
    return run_cli(capsys, "model", "make", inputs.photo, "--camera", camera or inputs.camera, *extra)


def test_model_make_out_naming_a_folder(inputs, capsys, tmp_path) -> None:
    run = _make(capsys, inputs, "--out", tmp_path)
    assert_one_line_error(run, 2, "--out", "is a folder", ".npz")
    assert list(tmp_path.iterdir()) == []


def test_model_make_preview_naming_a_folder_writes_no_model(inputs, capsys, tmp_path) -> None:
    folder = tmp_path / "previews"
    folder.mkdir()
    run = _make(capsys, inputs, "--out", tmp_path / "m.npz", "--preview", folder)
    assert_one_line_error(run, 2, "--preview", "is a folder")
    assert files_under(tmp_path) == ["previews"]


def test_model_make_out_under_a_read_only_location(inputs, capsys) -> None:
    run = _make(capsys, inputs, "--out", READ_ONLY.parent / "m.npz")
    assert_one_line_error(run, 2, "--out", "cannot write")
    run = _make(capsys, inputs, "--out", READ_ONLY / "m.npz")
    assert_one_line_error(run, 2, "--out", "does not exist")


def test_model_make_out_may_not_overwrite_an_input(inputs, capsys, tmp_path) -> None:
    photo_copy = tmp_path / "photo.npz"  # an input whose name ends in .npz
    shutil.copy(inputs.photo, photo_copy)
    before = photo_copy.read_bytes()
    run = run_cli(capsys, "model", "make", photo_copy, "--camera", inputs.camera, "--out", photo_copy)
    assert_one_line_error(run, 2, "--out", "input")
    assert photo_copy.read_bytes() == before


def test_a_failing_preview_leaves_no_model(inputs, capsys, tmp_path, monkeypatch) -> None:
    from robot_app.commands import model as model_command
    from robot_app.errors import InputError

    def broken_preview(*_args: object) -> None:
        raise InputError("could not write the preview image (simulated)")

    monkeypatch.setattr(model_command, "save_preview", broken_preview)
    run = _make(capsys, inputs, "--out", tmp_path / "m.npz", "--preview", tmp_path / "p.png")
    assert_one_line_error(run, 2, "preview")
    assert files_under(tmp_path) == []  # neither the .npz nor a temporary


def test_model_make_writes_model_and_preview_whole(inputs, capsys, tmp_path) -> None:
    run = _make(capsys, inputs, "--out", tmp_path / "m.npz", "--preview", tmp_path / "p.png")
    assert run.code == 0, run.err
    assert files_under(tmp_path) == ["m.npz", "p.png"]
    assert ClothModel.load(tmp_path / "m.npz").n_in > 0
    assert oct((tmp_path / "m.npz").stat().st_mode & 0o777) == oct(0o666 & ~_umask())


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _camera_at(inputs: Inputs, folder: Path, distance: float) -> Path:
    data = yaml.safe_load(inputs.camera.read_text()) | {"distance": distance}
    path = folder / f"camera_{distance:g}.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.mark.parametrize("distance", [1e6, 1e-6])
def test_a_camera_distance_that_would_exhaust_memory(inputs, capsys, tmp_path, distance) -> None:
    camera = _camera_at(inputs, tmp_path, distance)
    run = _make(capsys, inputs, "--out", tmp_path / "m.npz", camera=camera)
    assert_one_line_error(run, 2, str(camera), "distance", f"{distance:g} m", "GB", "--max-memory-gb")
    assert "MemoryError" not in run.err
    assert not (tmp_path / "m.npz").exists()


def test_a_camera_distance_that_makes_a_huge_model(inputs, capsys, tmp_path) -> None:
    camera = _camera_at(inputs, tmp_path, 6.0)  # a 15 cm cloth would measure 2 m
    run = _make(capsys, inputs, "--out", tmp_path / "m.npz", camera=camera)
    assert_one_line_error(run, 2, "distance", "6 m", "model points", "50,000", "--allow-large")
    assert not (tmp_path / "m.npz").exists()


@pytest.mark.slow
def test_allow_large_builds_the_huge_model_with_a_warning(inputs, capsys, tmp_path) -> None:
    camera = _camera_at(inputs, tmp_path, 6.0)
    run = _make(capsys, inputs, "--out", tmp_path / "m.npz", "--allow-large", camera=camera)
    assert run.code == 0, run.err
    assert run.first_err.startswith("warning: ") and "is the distance right" in run.first_err
    model = ClothModel.load(tmp_path / "m.npz")
    assert model.n_in + model.n_out > 50_000


def test_recognize_refuses_a_model_too_large_to_search(inputs, capsys, tmp_path) -> None:
    rng = np.random.default_rng(0)
    points = np.column_stack([rng.uniform(-0.1, 0.1, (60_000, 2)), np.zeros(60_000)])
    big = ClothModel("big", points, np.full(60_000, 40), points[:10], 90.0, np.zeros(3), (0.2, 0.2))
    big.save(tmp_path / "big.npz")
    run = run_cli(capsys, "recognize", *inputs.recognize_args(model=tmp_path / "big.npz"))
    assert_one_line_error(run, 2, "--model", "'big'", "60,010 model points", "--allow-large")


def test_recognize_refuses_a_population_beyond_memory(inputs, capsys) -> None:
    run = run_cli(capsys, "recognize", *inputs.recognize_args(), "--set", "propose.ga.population=100000000")
    assert_one_line_error(run, 2, "propose.ga.population", "100000000", "GB")


# --- pick-place ----------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("extra", "words"),
    [
        (["--video", "{tmp}"], ("--video", "is a folder", ".mp4")),
        (["--video", "{tmp}/episode.avi"], ("--video", ".mp4")),
        (["--video", str(READ_ONLY / "e.mp4")], ("--video", "cannot write")),
        (["--out", str(READ_ONLY)], ("--out", "cannot write")),
        (["--out", "{tmp}/file.txt"], ("--out", "is a file")),
        (["--set", "world.cameras.image_size=[100000,100000]"], ("world.cameras.image_size", "GB")),
        (["--gui"], ("--gui", "display")),
    ],
)
def test_pick_place_checks_its_outputs_before_the_episode(
    capsys, tmp_path, monkeypatch, extra, words
) -> None:
    monkeypatch.delenv("DISPLAY", raising=False)
    (tmp_path / "file.txt").write_text("keep")
    args = [a.format(tmp=tmp_path) for a in extra]
    if "--out" not in args:
        args += ["--out", str(tmp_path / "results")]
    run = run_cli(capsys, "pick-place", *args)
    assert_one_line_error(run, 2, *words)
    assert run.out == ""  # rejected before the episode began (no "pick-place: cloth ..." line)
    assert files_under(tmp_path) == ["file.txt"]


def test_pick_place_does_not_mix_two_runs_in_one_folder(capsys, tmp_path) -> None:
    folder = tmp_path / "results"
    folder.mkdir()
    (folder / "summary.json").write_text('{"outcome": "placed"}')
    before = _snapshot(folder)
    run = run_cli(capsys, "pick-place", "--out", folder)
    assert_one_line_error(run, 2, "--out", "already holds files", "summary.json", "--force")
    assert _snapshot(folder) == before


# --- trial and paper -------------------------------------------------------------------------------


def test_trial_out_naming_a_file(capsys, tmp_path) -> None:
    target = tmp_path / "taken"
    target.write_text("x")
    run = run_cli(capsys, "trial", TRIAL_CONFIG, "--trials", "2", "--out", target, "--no-progress")
    assert_one_line_error(run, 2, "--out", "is a file")
    assert target.read_text() == "x"


def test_trial_into_a_folder_of_other_files(capsys, tmp_path) -> None:
    (tmp_path / "photo.png").write_bytes(b"not mine to mix with")
    run = run_cli(capsys, "trial", TRIAL_CONFIG, "--trials", "2", "--out", tmp_path, "--no-progress")
    assert_one_line_error(run, 2, "--out", "already holds files", "photo.png")
    assert files_under(tmp_path) == ["photo.png"]


def test_trial_resume_on_a_table_that_is_not_text(capsys, tmp_path) -> None:
    folder = tmp_path / "sweep"
    run = run_cli(capsys, "trial", TRIAL_CONFIG, "--trials", "1", "--out", folder, "--no-progress")
    assert run.code == 0, run.err
    (folder / "trials.csv").write_bytes(bytes(range(256)) * 4)
    before = _snapshot(folder)
    run = run_cli(capsys, "trial", TRIAL_CONFIG, "--trials", "2", "--out", folder, "--no-progress")
    assert_one_line_error(run, 2, "trials.csv", "not a text CSV")
    assert _snapshot(folder) == before


def test_trial_resume_with_another_config_is_refused_before_running(capsys, tmp_path) -> None:
    folder = tmp_path / "sweep"
    assert run_cli(capsys, "trial", TRIAL_CONFIG, "--trials", "1", "--out", folder, "--no-progress").code == 0
    before = _snapshot(folder)
    run = run_cli(
        capsys, "trial", TRIAL_CONFIG, "--trials", "2", "--out", folder, "--set", "seed=5", "--no-progress"
    )
    assert_one_line_error(run, 2, "cannot resume", "different config")
    assert _snapshot(folder) == before


@pytest.mark.parametrize(
    ("extra", "words"),
    [
        (["--trials", "1000000"], ("trials", "1000000", "days", "--allow-large")),
        (["--workers", "0"], ("--workers", ">= 1", "0")),
        (["--workers", "500"], ("--workers", "500", "CPU", "--allow-large")),
        (["--workers", "3", "--max-memory-gb", "1"], ("--workers", "3", "GB")),
        (["--backend", "slurm"], ("--backend", "slurm")),
    ],
)
def test_trial_counts_and_workers_are_guarded(capsys, tmp_path, extra, words) -> None:
    run = run_cli(capsys, "trial", TRIAL_CONFIG, "--out", tmp_path / "sweep", "--no-progress", *extra)
    assert_one_line_error(run, 2, *words)
    assert list(tmp_path.iterdir()) == []


def test_paper_rejects_bad_workers_before_any_figure(capsys, tmp_path) -> None:
    out = tmp_path / "paper"
    run = run_cli(capsys, "paper", "--quick", "--workers", "0", "--out", out, "--no-progress")
    assert_one_line_error(run, 2, "--workers", "0")
    assert list(tmp_path.iterdir()) == []  # no figures, no config, no folder


@pytest.mark.parametrize(
    ("extra", "words"),
    [
        (
            ["--set", "fig13.step_m=0.0005", "--set", "fig13.yaw_step_deg=1"],
            ("fig13.step_m", "--allow-large"),
        ),
        (["--out", "{tmp}/file.txt"], ("--out", "is a file")),
        (["--out", str(READ_ONLY)], ("--out", "cannot write")),
    ],
)
def test_paper_checks_before_running(capsys, tmp_path, extra, words) -> None:
    (tmp_path / "file.txt").write_text("keep")
    args = [a.format(tmp=tmp_path) for a in extra]
    if "--out" not in args:
        args += ["--out", str(tmp_path / "paper")]
    run = run_cli(capsys, "paper", "--quick", "--no-progress", *args)
    assert_one_line_error(run, 2, *words)
    assert files_under(tmp_path) == ["file.txt"]


def test_paper_refuses_a_report_folder_of_other_settings(capsys, tmp_path) -> None:
    from robot_app.config import dump_config
    from robot_app.experiments import load_paper_config

    out = tmp_path / "paper"
    out.mkdir()
    dump_config(load_paper_config(quick=False), out / "config.yaml")  # a full run's folder
    before = _snapshot(out)
    run = run_cli(capsys, "paper", "--quick", "--out", out, "--no-progress")
    assert_one_line_error(run, 2, "--out", "other settings")
    assert _snapshot(out) == before


# --- sim -------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("command", "words"),
    [
        (["sim", "rig", "--out", "{tmp}"], ("--out", "is a folder", ".yaml")),
        (["sim", "rig", "--out", str(READ_ONLY / "rig.yaml")], ("--out", "cannot write")),
        (["sim", "show", "--out", "{tmp}/file.txt"], ("--out", "is a file")),
        (["sim", "model-photo", "3", "--out", "{tmp}/file.txt"], ("--out", "is a file")),
    ],
)
def test_sim_outputs_are_checked_first(capsys, tmp_path, command, words) -> None:
    (tmp_path / "file.txt").write_text("keep")
    run = run_cli(capsys, *(a.format(tmp=tmp_path) for a in command))
    assert_one_line_error(run, 2, *words)
    assert files_under(tmp_path) == ["file.txt"]


def test_sim_model_photo_writes_its_three_files(capsys, tmp_path) -> None:
    run = run_cli(capsys, "sim", "model-photo", "3", "--out", tmp_path / "station")
    assert run.code == 0, run.err
    assert files_under(tmp_path / "station") == ["background.png", "camera.yaml", "photo.png"]
    assert files_under(tmp_path) == [
        "station",
        "station/background.png",
        "station/camera.yaml",
        "station/photo.png",
    ]  # the staging folder is gone
