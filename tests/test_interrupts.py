"""Ctrl-C and SIGTERM: real processes are signalled, then the exit code and the disk are checked.

pick-place stops after the current control step (summary.json says 'interrupted', the
phases so far are kept, the video is playable or absent); trial keeps its finished rows
and resumes; fullsearch leaves nothing half-written. Exit code 128 + signal: 130, 143.
"""

from __future__ import annotations

import json
import os
import queue
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pytest

from robot_app.errors import InterruptError
from robot_app.interrupts import (
    SignalInterrupt,
    interruptible,
    signals_raise_interrupts,
    stop_at_safe_points,
)
from tests.cli_inputs import (
    FAST_GA,
    Counted,
    Inputs,
    counted_trial,
    files_under,
    make_inputs,
    process_env,
    run_process,
)


@dataclass
class Process:
    """A running `robot-app` with its stdout read line by line in the background."""

    popen: subprocess.Popen[str]
    lines: queue.Queue[str]
    seen: list[str]

    def wait_for(self, predicate: Callable[[str], bool], timeout: float = 240.0) -> str:
        """Blocks until a stdout line satisfies `predicate`; returns it."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            try:
                line = self.lines.get(timeout=0.2)
            except queue.Empty:
                if self.popen.poll() is not None:
                    break
                continue
            self.seen.append(line)
            if predicate(line):
                return line
        raise AssertionError(f"no such line on stdout; seen {self.seen}; stderr {self.finish(5)[1]}")

    def finish(self, timeout: float = 120.0) -> tuple[int, str]:
        """Waits for the exit; returns (exit code, stderr)."""
        code = self.popen.wait(timeout=timeout)
        result: list[str] = []
        reader = threading.Thread(target=lambda: result.append(self.popen.stderr.read()), daemon=True)  # type: ignore[union-attr]
        reader.start()
        reader.join(timeout=30)
        assert result, "stderr is still open: a child process outlived the command"
        return code, result[0]


def start(*args: object, cwd: Path) -> Process:
    popen = subprocess.Popen(
        [sys.executable, "-m", "robot_app.cli", *(str(a) for a in args)],
        cwd=cwd,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=process_env(),
    )
    lines: queue.Queue[str] = queue.Queue()

    def pump() -> None:
        assert popen.stdout is not None
        for line in popen.stdout:
            lines.put(line)

    threading.Thread(target=pump, daemon=True).start()
    return Process(popen, lines, [])


def wait_for_file(
    path: Path, predicate: Callable[[Path], bool], process: Process, timeout: float = 240.0
) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if path.exists() and predicate(path):
            return
        if process.popen.poll() is not None:
            raise AssertionError(f"the process ended first: {process.finish(5)}")
        time.sleep(0.1)
    raise AssertionError(f"{path} did not appear")


def no_temporaries(folder: Path) -> bool:
    return not any(".tmp" in name or "robot_app-probe" in name for name in files_under(folder))


# --- clear-table ---------------------------------------------------------------------------------


def test_ctrl_c_during_clear_table_writes_the_job_so_far(tmp_path) -> None:
    folder = tmp_path / "job"
    # two cloths and their two models: the survey of the whole catalogue's 20 models cost ~16 s
    # before the first pick, and the stop at a safe point is the same for any pile
    small = ("--set", "known=[3,12]", "--set", "pile.cloths=[3,12]")
    process = start("clear-table", "--out", folder, "--set", "loop.vision_latency=0.06", *small, cwd=tmp_path)
    process.wait_for(lambda line: line.lstrip().startswith("No.") and " observe " in line)  # a pick began
    process.popen.send_signal(signal.SIGINT)
    code, stderr = process.finish()
    assert code == 130, stderr
    assert "Traceback" not in stderr
    assert stderr.strip().splitlines()[-1].startswith("interrupted: stopped"), stderr
    summary = json.loads((folder / "summary.json").read_text())
    assert summary["status"] == "interrupted" and summary["cleared"] is False
    assert summary["surveys"] >= 1  # the survey before the stop is kept
    assert isinstance(summary["slides_held"], int) and summary["slides_held"] >= 0
    assert sorted(p.name for p in folder.iterdir()) == [
        "cloths.csv",
        "config.yaml",
        "picks.csv",
        "summary.json",
        "surveys.csv",
    ]
    assert no_temporaries(folder.parent)


# --- pick-place ----------------------------------------------------------------------------------


def _check_interrupted_episode(folder: Path, video: Path, code: int, stderr: str, number: int) -> dict:
    name = signal.Signals(number).name
    assert code == 128 + number, stderr
    assert "Traceback" not in stderr
    lines = stderr.strip().splitlines()
    assert lines[0].startswith(f"{name}: stopping at the next safe point"), stderr
    assert lines[-1].startswith(f"interrupted: stopped by {name} during "), stderr
    summary = json.loads((folder / "summary.json").read_text())
    assert summary["outcome"] == "interrupted" and summary["success"] is False
    assert name in summary["reason"]
    phases = [p["phase"] for p in summary["phases"]]
    assert phases and phases[0] == "observe"
    assert summary["reason"].endswith(f"during {phases[-1]}")  # the phase it stopped in, kept
    rows = (folder / "phases.csv").read_text().strip().splitlines()
    assert len(rows) == 1 + len(phases)
    assert sorted(p.name for p in folder.iterdir()) == [
        "config.yaml",
        "phases.csv",
        "recognitions.csv",
        "summary.json",
    ]
    if video.exists():  # a video is whole: it plays to its last frame
        import imageio.v2 as imageio

        with imageio.get_reader(str(video)) as reader:
            frames = sum(1 for _ in reader)
        assert frames >= 1
    assert no_temporaries(folder.parent)
    return summary


def test_ctrl_c_during_pick_place_keeps_the_episode_so_far(tmp_path) -> None:
    folder, video = tmp_path / "run", tmp_path / "episode.mp4"
    process = start("pick-place", "--out", folder, "--video", video, cwd=tmp_path)
    process.wait_for(lambda line: line.lstrip().startswith("search"))  # the cloth was found
    process.popen.send_signal(signal.SIGINT)
    code, stderr = process.finish()
    summary = _check_interrupted_episode(folder, video, code, stderr, signal.SIGINT)
    assert [p["phase"] for p in summary["phases"]][:2] == ["observe", "search"]
    assert summary["recognitions"] >= 1
    assert video.is_file()  # frames were recorded before the stop: the video is kept, playable


def test_sigterm_while_the_cell_is_being_built(tmp_path) -> None:
    folder, video = tmp_path / "run", tmp_path / "episode.mp4"
    process = start("pick-place", "--out", folder, "--video", video, cwd=tmp_path)
    process.wait_for(lambda line: line.startswith("pick-place: cloth"))  # setup has begun
    process.popen.send_signal(signal.SIGTERM)
    code, stderr = process.finish()
    _check_interrupted_episode(folder, video, code, stderr, signal.SIGTERM)


@pytest.mark.slow
def test_a_second_ctrl_c_stops_at_once_and_leaves_no_half_files(tmp_path) -> None:
    folder, video = tmp_path / "run", tmp_path / "episode.mp4"
    process = start("pick-place", "--out", folder, "--video", video, cwd=tmp_path)
    process.wait_for(lambda line: line.startswith("pick-place: cloth"))
    process.popen.send_signal(signal.SIGINT)
    process.popen.send_signal(signal.SIGINT)
    code, stderr = process.finish()
    assert code == 130 and "Traceback" not in stderr
    assert stderr.strip().splitlines()[-1].startswith("interrupted:")
    # either the first signal's safe stop won the race (whole results) or nothing was written
    if folder.exists():
        assert json.loads((folder / "summary.json").read_text())["outcome"] == "interrupted"
    assert no_temporaries(tmp_path)


# --- trial ------------------------------------------------------------------------------------------


def _gone(pid: int, grace: float = 5.0) -> bool:
    """The process `pid` has ended (or is a zombie) within `grace` seconds."""
    deadline = time.monotonic() + grace
    while time.monotonic() < deadline:
        try:
            state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
        except (FileNotFoundError, ProcessLookupError, IndexError):
            return True
        if state in ("Z", "X"):
            return True
        time.sleep(0.1)
    return False


def _rows(table: Path) -> list[list[str]]:
    import csv

    with table.open(newline="") as stream:
        return list(csv.reader(stream))


# Many trials of a small GA: the sweep must still be running when the signal comes, however
# fast the machine (at 40 an idle machine finished them between the third row and the signal).
SWEEP_TRIALS = 4000
SMALL_TRIALS = (
    "kind: recognition\nname: small\n"
    f"trials: {SWEEP_TRIALS}\n"
    "scene: {cloth_ids: [3, 4]}\n"
    "recognition: {propose: {ga: {population: 40, generations: 20}, coarse_generations: 10, restarts: 0}}\n"
)


@pytest.mark.parametrize(("number", "workers"), [(signal.SIGINT, 1), (signal.SIGTERM, 2)])
def test_an_interrupted_trial_keeps_its_rows_and_resumes(tmp_path, number, workers) -> None:
    folder, config = tmp_path / "sweep", tmp_path / "small.yaml"
    config.write_text(SMALL_TRIALS)
    args = ("trial", config, "--out", folder, "--workers", workers, "--no-progress")
    process = start(*args, cwd=tmp_path)
    table = folder / "trials.csv"
    wait_for_file(table, lambda path: len(path.read_text().splitlines()) >= 3, process)
    children = subprocess.run(
        ["ps", "--ppid", str(process.popen.pid), "-o", "pid="], capture_output=True, text=True, check=False
    ).stdout.split()
    process.popen.send_signal(number)
    code, stderr = process.finish(timeout=60)
    name = signal.Signals(number).name
    assert code == 128 + number, stderr
    assert any(line.startswith(f"interrupted: stopped by {name}") for line in stderr.splitlines()), stderr
    rows = _rows(table)
    header, body = rows[0], rows[1:]
    assert 2 <= len(body) < SWEEP_TRIALS and all(len(row) == len(header) for row in body)
    assert [int(row[0]) for row in body] == sorted(int(row[0]) for row in body)
    summary = json.loads((folder / "summary.json").read_text())
    assert summary["status"] == "interrupted" and summary["finished"] == len(body)
    for pid in children:  # the worker processes were stopped, not left running their trials
        assert _gone(int(pid)), Path(f"/proc/{pid}/cmdline").read_bytes()
    assert no_temporaries(folder)
    # resume (with fewer trials and one worker, to be quick): the finished rows are kept, not rerun
    done = run_process("trial", config, "--out", folder, "--trials", "8", "--no-progress", cwd=tmp_path)
    assert done.code == 0, done.err
    resumed = _rows(table)[1:]
    finished = {int(row[0]) for row in body}
    assert [int(row[0]) for row in resumed] == sorted(finished | set(range(8)))
    assert [row for row in resumed if int(row[0]) in finished] == body
    assert json.loads((folder / "summary.json").read_text())["status"] == "finished"


# --- fullsearch and paper ------------------------------------------------------------------------


@pytest.fixture(scope="module")
def inputs(tmp_path_factory: pytest.TempPathFactory) -> Inputs:
    return make_inputs(tmp_path_factory.mktemp("interrupts"))


def test_sigterm_during_a_full_search_leaves_nothing(inputs, tmp_path) -> None:
    out = tmp_path / "fs"
    args = ("fullsearch", *inputs.recognize_args(), "--out", out, "--step", "0.001", "--yaw-step-deg", "5")
    process = start(*args, *FAST_GA, cwd=tmp_path)
    process.wait_for(lambda line: "full search" in line, timeout=120)
    process.popen.send_signal(signal.SIGTERM)
    code, stderr = process.finish()
    assert code == 143, stderr
    assert stderr.strip().splitlines()[0].startswith("interrupted: stopped by SIGTERM"), stderr
    assert list(tmp_path.iterdir()) == []  # no results folder, no temporaries


@pytest.mark.slow
def test_ctrl_c_during_paper_keeps_the_finished_figures(tmp_path) -> None:
    out = tmp_path / "paper"
    process = start("paper", "--quick", "--out", out, "--no-progress", cwd=tmp_path)
    wait_for_file(out / "fig13_a_surface.png", lambda path: True, process)
    process.popen.send_signal(signal.SIGINT)
    code, stderr = process.finish()
    assert code == 130, stderr
    assert stderr.strip().splitlines()[0].startswith("interrupted: stopped by SIGINT; finished: fig13_a")
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "interrupted" and summary["finished"][0] == "fig13_a"
    assert (out / "fig13_a_map.png").stat().st_size > 0 and no_temporaries(out)


# --- the mechanism, in this process -----------------------------------------------------------------


def test_the_first_signal_only_asks_the_loop_to_stop(capfd) -> None:
    handler = signal.getsignal(signal.SIGINT)
    with stop_at_safe_points() as stop:
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(0.05)
        assert stop.requested and stop.signal_number == signal.SIGTERM
        with pytest.raises(InterruptError) as caught:
            stop.check()
        assert caught.value.exit_code == 143 and caught.value.signal_number == signal.SIGTERM
        with pytest.raises(SignalInterrupt) as again:  # the second one stops at once
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(1.0)
        assert again.value.signal_number == signal.SIGINT
    assert signal.getsignal(signal.SIGINT) is handler  # restored
    assert "SIGTERM: stopping at the next safe point" in capfd.readouterr().err


def test_signals_raise_interrupts_carry_the_signal() -> None:
    previous = signal.getsignal(signal.SIGTERM)
    with signals_raise_interrupts(), pytest.raises(SignalInterrupt) as caught:
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(1.0)
    assert caught.value.signal_number == signal.SIGTERM and isinstance(caught.value, KeyboardInterrupt)
    assert signal.getsignal(signal.SIGTERM) is previous


def test_an_interrupted_command_exits_with_128_plus_the_signal() -> None:
    @interruptible
    def command(number: int) -> None:
        raise SignalInterrupt(number)

    for number, code in ((signal.SIGINT, 130), (signal.SIGTERM, 143)):
        with pytest.raises(InterruptError) as caught:
            command(number)
        assert caught.value.exit_code == code
    with pytest.raises(InterruptError) as caught:  # a plain KeyboardInterrupt is Ctrl-C
        interruptible(lambda: (_ for _ in ()).throw(KeyboardInterrupt()))()
    assert caught.value.exit_code == 130


def test_a_sweep_interrupted_in_process_writes_its_summary(tmp_path) -> None:
    from robot_app.experiments import parse_trial_config, run_sweep
    from robot_app.experiments.trials import SweepInterruptedError

    config = parse_trial_config({"name": "t", "trials": 6})
    with pytest.raises(SweepInterruptedError) as caught:
        run_sweep(config, counted_trial, Counted, tmp_path / "s", progress=False)
    assert caught.value.exit_code == 143
    summary = json.loads((tmp_path / "s" / "summary.json").read_text())
    assert summary["status"] == "interrupted" and summary["finished"] == 3


def test_an_interrupted_model_make_leaves_no_model(inputs, tmp_path, monkeypatch, capsys) -> None:
    from robot_app.cli import main
    from robot_app.vision.photo_model import ClothModel

    def save_then_interrupt(self: ClothModel, path: Path) -> None:
        Path(path).write_bytes(b"half a model")
        raise SignalInterrupt(signal.SIGTERM)  # SIGTERM arrives while the file is being written

    monkeypatch.setattr(ClothModel, "save", save_then_interrupt)

    out = tmp_path / "m.npz"
    args = ["model", "make", str(inputs.photo), "--camera", str(inputs.camera), "--out", str(out)]
    assert main(args) == 143
    err = capsys.readouterr().err
    assert err.startswith("interrupted: stopped by SIGTERM") and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []  # neither the model nor its temporary
