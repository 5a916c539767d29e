"""robot_app.outputs and robot_app.resources: atomic files, path checks, estimates and limits."""

from __future__ import annotations

import os
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

from robot_app.errors import InputError, OutputError, ResourceError
from robot_app.outputs import (
    atomic_path,
    atomic_write_text,
    check_output_file,
    check_output_folder,
    output_folder,
    staged_folder,
    unique_folder,
)
from robot_app.resources import (
    GB,
    ResourceLimits,
    check_trial_time,
    check_workers,
    format_bytes,
    full_search_estimate,
    model_make_estimate,
)


def _everything(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


# --- atomic writes ------------------------------------------------------------------------------


def test_an_atomic_file_replaces_the_target_only_when_whole(tmp_path) -> None:
    target = tmp_path / "summary.json"
    target.write_text("old")
    with atomic_path(target) as temporary:
        assert temporary.parent == tmp_path and temporary.suffix == ".json"
        temporary.write_text("new")
        assert target.read_text() == "old"  # not yet
    assert target.read_text() == "new" and _everything(tmp_path) == ["summary.json"]


@pytest.mark.parametrize("error", [RuntimeError("disk on fire"), KeyboardInterrupt()])
def test_a_failed_write_leaves_the_old_file_and_no_temporary(tmp_path, error) -> None:
    target = tmp_path / "table.csv"
    target.write_text("old")
    with pytest.raises(type(error)), atomic_path(target) as temporary:
        temporary.write_text("half")
        raise error
    assert target.read_text() == "old" and _everything(tmp_path) == ["table.csv"]


def test_a_failed_write_removes_the_folders_it_made(tmp_path) -> None:
    with pytest.raises(RuntimeError), atomic_path(tmp_path / "a" / "b" / "x.png") as temporary:
        temporary.write_bytes(b"half")
        raise RuntimeError("stop")
    assert _everything(tmp_path) == []


def test_an_os_error_becomes_an_output_error_naming_the_file(tmp_path) -> None:
    target = tmp_path / "x.txt"
    with pytest.raises(OutputError) as caught, atomic_path(target):
        raise OSError(28, "No space left on device")
    assert caught.value.path == target and "No space left" in str(caught.value)
    assert _everything(tmp_path) == []


def test_atomic_files_get_the_usual_permissions(tmp_path) -> None:
    mask = os.umask(0o022)
    try:
        path = atomic_write_text(tmp_path / "f.txt", "x")
    finally:
        os.umask(mask)
    assert path.stat().st_mode & 0o777 == 0o644


def test_output_folder_is_removed_if_the_work_fails_before_writing(tmp_path) -> None:
    with pytest.raises(ValueError), output_folder(tmp_path / "new" / "run"):
        raise ValueError("failed")
    assert _everything(tmp_path) == []
    existing = tmp_path / "existing"
    existing.mkdir()
    with pytest.raises(ValueError), output_folder(existing / "run") as folder:
        (folder / "half_done.txt").write_text("kept: it is whole")
        raise ValueError("failed")
    assert _everything(tmp_path) == ["existing", "existing/run", "existing/run/half_done.txt"]


def test_a_staged_folder_moves_its_files_in_or_leaves_nothing(tmp_path) -> None:
    with staged_folder(tmp_path / "pics") as stage:
        (stage / "a.png").write_bytes(b"a")
        (stage / "b.png").write_bytes(b"b")
    assert _everything(tmp_path) == ["pics", "pics/a.png", "pics/b.png"]
    with pytest.raises(RuntimeError), staged_folder(tmp_path / "other") as stage:
        (stage / "a.png").write_bytes(b"a")
        raise RuntimeError("render failed")
    assert _everything(tmp_path) == ["pics", "pics/a.png", "pics/b.png"]


# --- path checks --------------------------------------------------------------------------------


def test_output_file_checks(tmp_path) -> None:
    (tmp_path / "dir.mp4").mkdir()
    (tmp_path / "file").write_text("x")
    cases = [  # (path, suffixes, create_parents, what would be valid)
        (tmp_path / "dir.mp4", (".mp4",), True, "a file name"),
        (tmp_path / "v.avi", (".mp4",), True, "a file name ending in .mp4"),
        (Path("/dev/null"), (), True, "a regular file name"),
        (tmp_path / "file" / "x.npz", (), True, "a path whose parents are folders"),
        (tmp_path / "missing" / "x.npz", (), False, "a file in an existing folder"),
    ]
    for path, suffixes, create_parents, expected in cases:
        with pytest.raises(OutputError) as caught:
            check_output_file(path, key="--video", suffixes=suffixes, create_parents=create_parents)
        error = caught.value
        assert (error.path, error.key, error.value, error.expected) == (path, "--video", str(path), expected)
    assert check_output_file(tmp_path / "new" / "deeper" / "v.mp4", key="--video", suffixes=(".mp4",))
    assert _everything(tmp_path) == ["dir.mp4", "file"]  # checks create nothing, probes are gone


def test_output_folder_checks(tmp_path) -> None:
    (tmp_path / "empty").mkdir()
    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "x").write_text("x")
    check_output_folder(tmp_path / "empty", key="--out")
    check_output_folder(tmp_path / "new", key="--out")
    cases = [  # (path, what would be valid)
        (tmp_path / "full", "a new or empty folder (or --force)"),
        (tmp_path / "full" / "x", "a new or empty folder"),  # a file
        (Path("/proc/robot_app_results"), "a writable location"),
    ]
    for path, expected in cases:
        with pytest.raises(OutputError) as caught:
            check_output_folder(path, key="--out")
        error = caught.value
        assert (error.path, error.key, error.value, error.expected) == (path, "--out", str(path), expected)
    check_output_folder(tmp_path / "full", key="--out", force=True)
    check_output_folder(tmp_path / "full", key="--out", resumable=True)
    assert _everything(tmp_path) == ["empty", "full", "full/x"]


def test_unique_folder(tmp_path) -> None:
    assert unique_folder(tmp_path / "run") == tmp_path / "run"
    (tmp_path / "run").mkdir()
    (tmp_path / "run-2").mkdir()
    assert unique_folder(tmp_path / "run") == tmp_path / "run-3"


# --- limits ---------------------------------------------------------------------------------------


def test_memory_and_count_limits() -> None:
    limits = ResourceLimits(max_memory_gb=1.0)
    limits.check_memory(0.9 * GB, key="--step", value=0.001, what="a grid")
    with pytest.raises(ResourceError) as caught:
        limits.check_memory(2 * GB, key="--step", value=0.001, what="a grid")
    assert caught.value.key == "--step" and caught.value.value == 0.001 and "1.0 GB" in str(caught.value)
    with pytest.raises(ResourceError) as count:
        limits.check_count(11, 10, key="--step", value=1, what="poses")
    assert (count.value.key, count.value.value, count.value.expected) == ("--step", 1, "at most 10 poses")
    ResourceLimits(allow_large=True).check_count(11, 10, key="--step", value=1, what="poses")
    with pytest.raises(InputError):
        ResourceLimits(max_memory_gb=0.0)


def test_the_default_memory_limit_fits_the_machine() -> None:
    from robot_app.resources import machine_memory_bytes

    limit = ResourceLimits().memory_bytes
    total = machine_memory_bytes()
    assert 0 < limit <= 8 * GB and (total is None or limit <= total / 2)


def test_workers_and_trial_time() -> None:
    limits = ResourceLimits()
    check_workers(limits, 2, "synthetic")
    with pytest.raises(InputError):
        check_workers(limits, 0, "synthetic")
    with pytest.raises(ResourceError) as workers:
        check_workers(limits, 10_000, "sim")
    assert (workers.value.key, workers.value.value) == ("--workers", 10_000)
    assert workers.value.expected.endswith("worker processes")  # the CPU count, not the memory, limits them
    check_workers(ResourceLimits(allow_large=True, max_memory_gb=1e4), 10_000, "sim")
    check_trial_time(limits, kind="pick_place", source="sim", to_run=100, workers=2, key="trials", value=100)
    with pytest.raises(ResourceError) as time:
        check_trial_time(limits, kind="pick_place", source="sim", to_run=10**5, workers=1, key="t", value=1)
    assert (time.value.key, time.value.value) == ("t", 1)


def test_format_bytes() -> None:
    assert format_bytes(3 * 1024**2) == "3 MB" and format_bytes(1.5 * GB) == "1.5 GB"
    assert format_bytes(3e6 * GB) == "3.0e+06 GB"


def test_the_full_search_estimate_bounds_what_it_allocates() -> None:
    from robot_app.vision.full_search import find_peaks, full_search

    class Flat:
        def evaluate(self, transforms: np.ndarray) -> np.ndarray:
            return np.zeros(len(transforms))

    x, y, step = (-0.255, 0.255), (-0.195, 0.195), 0.001
    cells, evaluations, estimate = full_search_estimate(x, y, step, 1)
    tracemalloc.start()
    result = full_search(Flat(), x, y, step)
    find_peaks(result, 0.06, 0.2)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert result.fitness.size == cells and result.evaluations == evaluations
    assert peak <= estimate <= 10 * peak  # an upper bound of the right size


def test_the_model_estimate_bounds_what_make_model_allocates() -> None:
    from robot_app.vision.camera import ModelCamera, PinholeCamera
    from robot_app.vision.photo_model import ModelSettings, make_model
    from robot_app.vision.synthetic import render_model_photo
    from robot_app.vision.synthetic_catalogue import synthetic_cloth

    camera = ModelCamera(PinholeCamera.from_fov((480, 360), np.deg2rad(48)), 0.40)
    photo, background = render_model_photo(synthetic_cloth(3), camera, rng=np.random.default_rng(0))
    settings = ModelSettings()
    reach = settings.band_gap + settings.band_width + 2 * settings.point_spacing
    fx = float(camera.camera.camera_matrix[0, 0])
    estimate, _ = model_make_estimate((480, 360), (fx, fx), 0.40, settings.point_spacing, reach)
    tracemalloc.start()
    make_model(photo, camera, background, settings)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert peak <= estimate <= 20 * peak
