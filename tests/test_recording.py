"""Episode recordings (`--record F.rrd`, trials' `record:`), read back with rerun's own reader.

The recording tests need the optional `viewer` extra (rerun-sdk) and are skipped without
it; the tests of what happens without the extra block the import and run everywhere.
"""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from collections import defaultdict
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml

from robot_app.experiments.experiment_config import parse_trial_config
from robot_app.experiments.recording import INSTALL_HINT
from tests.cli_inputs import assert_one_line_error, files_under, process_env, run_cli

REPO = Path(__file__).resolve().parents[1]
FAST_TRIAL = {
    "kind": "pick_place",
    "name": "recorded",
    "scene": {"cloth_ids": [3]},
    "pick_place": {"world": {"cameras": {"image_size": [320, 240]}}},
}


# --- without the extra ------------------------------------------------------------------------------

BLOCK_RERUN = (
    "import sys; sys.modules['rerun'] = None; from robot_app.cli import main; sys.exit(main(sys.argv[1:]))"
)


def test_record_without_the_viewer_extra_is_one_line_with_the_install_hint(tmp_path) -> None:
    done = subprocess.run(
        [
            sys.executable,
            "-c",
            BLOCK_RERUN,
            "pick-place",
            "--record",
            tmp_path / "e.rrd",
            "--out",
            tmp_path / "r",
        ],
        capture_output=True,
        text=True,
        env=process_env(),
        timeout=120,
        check=False,
    )
    assert done.returncode == 2, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: --record"), done.stderr
    assert INSTALL_HINT in lines[0] and "rerun-sdk" in lines[0]
    assert done.stdout == ""  # refused before the episode began
    assert files_under(tmp_path) == []


def test_trial_record_without_the_extra(tmp_path, capsys, monkeypatch) -> None:
    monkeypatch.setitem(sys.modules, "rerun", None)  # `import rerun` fails as if not installed
    explicit = tmp_path / "all.yaml"
    explicit.write_text(yaml.safe_dump(FAST_TRIAL | {"record": "all"}))
    run = run_cli(capsys, "trial", explicit, "--trials", "1", "--out", tmp_path / "out", "--no-progress")
    assert_one_line_error(run, 2, "record", INSTALL_HINT)
    assert not (tmp_path / "out").exists()
    # left at its default (failures), the missing extra is a warning, not an error
    from robot_app.experiments.pick_place_trial import recordings_folder

    with pytest.warns(UserWarning, match="no recordings"):
        assert recordings_folder(parse_trial_config(dict(FAST_TRIAL)), tmp_path) is None
    assert recordings_folder(parse_trial_config(FAST_TRIAL | {"record": "none"}), tmp_path) is None


def test_record_does_not_change_what_a_trial_resumes() -> None:
    plain = parse_trial_config(dict(FAST_TRIAL))
    assert plain.record == "failures"  # type: ignore[union-attr]
    assert parse_trial_config(FAST_TRIAL | {"record": "none"}).config_hash() == plain.config_hash()
    with pytest.raises(Exception) as bad:
        parse_trial_config(FAST_TRIAL | {"record": "sometimes"})
    assert getattr(bad.value, "key", None) == "record"


# --- with the extra: read back what was recorded ------------------------------------------------------


class Column:
    """One temporal component of an entity: its values with their cell_time [ns] and vision_cycle."""

    def __init__(self) -> None:
        self.rows: list[tuple[int, int | None, object]] = []

    def add(self, times: list[int], cycles: list[int | None], values: list[object]) -> None:
        self.rows.extend(zip(times, cycles, values, strict=True))
        self.rows.sort(key=lambda row: row[0])

    @property
    def values(self) -> list:
        return [value for _, _, value in self.rows]

    @property
    def times(self) -> np.ndarray:
        return np.array([time for time, _, _ in self.rows], dtype=np.int64)

    @property
    def cycles(self) -> list[int | None]:
        return [cycle for _, cycle, _ in self.rows]


def _read(path: Path) -> dict[str, dict[str, Column]]:
    """Per entity path and temporal component, the values in time order (rerun's chunk reader)."""
    from rerun.chunk import RrdReader

    entities: dict[str, dict[str, Column]] = defaultdict(lambda: defaultdict(Column))
    for chunk in RrdReader(path).store().stream():
        batch = chunk.to_record_batch()
        names = [
            n for n in batch.schema.names if not n.startswith("rerun.") and n not in chunk.timeline_names
        ]
        if chunk.is_static:
            for name in names:
                entities[chunk.entity_path].setdefault(f"static {name}", Column())
            continue
        times = batch.column("cell_time").cast("int64").to_pylist()
        cycles = (
            batch.column("vision_cycle").to_pylist()
            if "vision_cycle" in chunk.timeline_names
            else [None] * len(times)
        )
        for name in names:
            entities[chunk.entity_path][name].add(times, cycles, batch.column(name).to_pylist())
    return entities


def _csv(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as stream:
        return list(csv.DictReader(stream))


def test_an_episode_recording_holds_what_the_robot_saw_and_did(tmp_path, capsys) -> None:
    pytest.importorskip("rerun")
    record, out = tmp_path / "episode.rrd", tmp_path / "run"
    run = run_cli(capsys, "pick-place", "--record", record, "--out", out, "--seed", "1")
    assert run.code in (0, 1), run.err
    assert f"recording: {record}" in run.out
    assert [p for p in files_under(tmp_path) if p.startswith(".")] == []  # no temporary left
    recognitions, phases = _csv(out / "recognitions.csv"), _csv(out / "phases.csv")
    summary = json.loads((out / "summary.json").read_text())
    n = len(recognitions)
    assert n >= 3
    data = _read(record)

    expected = {
        "/cameras/left", "/cameras/right", "/cameras/left/image", "/cameras/right/image",
        "/cameras/left/outline/recognised", "/cameras/right/outline/true",
        "/cloth/recognised", "/cloth/filtered", "/cloth/true", "/cloth/grasp_point",
        "/cell/table", "/cell/sheet", "/cell/box", "/cell/tcp", "/cell/tcp_path", "/cell/cloths/No.3",
        "/cell/robot/link_s1", "/cell/robot/finger_left", "/signals/recognition/fitness",
        "/signals/recognition/confidence", "/signals/filter/nis", "/signals/error/x_mm",
        "/signals/joints/position", "/signals/joints/velocity_of_limit",
        "/log/phases", "/log/recognitions", "/log/outcome",
    }  # fmt: skip
    assert expected <= set(data) | {p.rsplit("/", 1)[0] for p in data}

    # one image and one recognised pose per row of recognitions.csv, on both timelines
    csv_times = [float(r["time"]) for r in recognitions]
    for side in ("left", "right"):
        images = data[f"/cameras/{side}/image"]["EncodedImage:blob"]
        assert len(images.values) == n
        assert images.cycles == list(range(n))  # the n-th image is the n-th row
        assert images.times * 1e-9 == pytest.approx(csv_times, abs=1e-6)
        jpeg = np.frombuffer(bytes(images.values[-1][0]), np.uint8)
        assert cv2.imdecode(jpeg, cv2.IMREAD_COLOR).shape == (240, 320, 3)
    for name in ("cloth/recognised", "cloth/true", "cameras/left", "cameras/right"):
        poses = data[f"/{name}"]["Transform3D:translation"]
        assert len(poses.values) == n and poses.cycles == list(range(n))
    poses = data["/cloth/recognised"]["Transform3D:translation"]
    # the timelines are monotonic: cell time never goes back (two searches can look at one
    # instant), the vision cycle counts up
    assert np.all(np.diff(poses.times) >= 0) and np.all(np.diff(poses.cycles) == 1)
    recognised = np.array([t[0] for t in poses.values])
    csv_xyz = np.array([[float(r[k]) for k in "xyz"] for r in recognitions])
    assert recognised == pytest.approx(csv_xyz, abs=1e-5)
    error = [v[0] for v in data["/signals/error/x_mm"]["Scalars:scalars"].values]
    assert error == pytest.approx([float(r["error_x_mm"]) for r in recognitions], abs=1e-6)
    # the recognised outline lies on the image where the search found the cloth (later,
    # tracking down to the grasp, the cloth fills the view and its outline leaves the image)
    found = next(i for i, r in enumerate(recognitions) if r["mode"] == "search" and r["found"] == "True")
    outlines = data["/cameras/right/outline/recognised"]["LineStrips2D:strips"]
    strip = np.array(outlines.values[outlines.cycles.index(found)][0])
    assert strip.shape[1] == 2 and np.all((strip >= -1) & (strip <= [321, 241]))

    # joints: one sample per commanded control step, in time order, shares within the limits
    joint = data["/signals/joints/position_of_range"]["Scalars:scalars"]
    assert len(joint.values) == summary["commanded_samples"]
    assert np.all(np.diff(joint.times) > 0)
    shares = np.array(joint.values)  # (samples, 7): one series per joint, -1 and 1 its limits
    assert shares.shape == (summary["commanded_samples"], 7)
    assert np.all(np.abs(shares) <= 1.0 + 1e-3) and np.ptp(shares[:, 1]) > 0.05  # S2 moved, within range
    # phases and the outcome as text
    assert len(data["/log/phases"]["TextLog:text"].values) == len(phases)
    outcome = data["/log/outcome"]["TextLog:text"].values
    assert len(outcome) == 1 and summary["outcome"] in outcome[0][0]
    assert ("SUCCESS" in outcome[0][0]) == summary["success"]
    # the robot moved in 3D: the TCP went from the observation pose down to the cloth and on to the box
    tcp = np.array([p[0] for p in data["/cell/tcp"]["Points3D:positions"].values])
    assert tcp[:, 2].max() - tcp[:, 2].min() > 0.3


def test_record_path_is_checked_before_the_episode(tmp_path, capsys) -> None:
    pytest.importorskip("rerun")
    for target, words in (
        (tmp_path, ("--record", "is a folder")),
        (tmp_path / "episode.mp4", ("--record", ".rrd")),
        (Path("/proc/robot_app_out/e.rrd"), ("--record", "cannot write")),
    ):
        run = run_cli(capsys, "pick-place", "--record", target, "--out", tmp_path / "results")
        assert_one_line_error(run, 2, *words)
        assert run.out == ""
    assert files_under(tmp_path) == []


def test_a_trial_keeps_the_recordings_of_its_failures(tmp_path, capsys) -> None:
    pytest.importorskip("rerun")
    config = tmp_path / "failing.yaml"
    # point 0 runs out of time before the grasp (a failure), point 1 places the cloth
    sweep = {"key": "pick_place.loop.max_episode_time", "values": [1.0, 60.0]}
    config.write_text(yaml.safe_dump(FAST_TRIAL | {"sweep": sweep}))
    run = run_cli(capsys, "trial", config, "--trials", "2", "--out", tmp_path / "out", "--no-progress")
    assert run.code == 0, run.err
    rows = {int(r["point"]): r for r in _csv(tmp_path / "out" / "trials.csv")}
    assert rows[0]["success"] == "False" and rows[0]["outcome"] == "timeout"
    assert rows[1]["success"] == "True" and rows[1]["recording"] == ""
    kept = tmp_path / "out" / rows[0]["recording"]
    assert kept.is_file() and kept.suffix == ".rrd"
    assert sorted(p.name for p in (tmp_path / "out" / "recordings").iterdir()) == [kept.name]
    assert "/log/outcome" in _read(kept)


def test_recorded_bodies_are_where_pybullet_has_the_links() -> None:
    from robot_app.control.limits import JointLimits
    from robot_app.experiments.recording_scene import cell_layout, robot_bodies
    from robot_app.sim import World

    rng = np.random.default_rng(7)
    with World() as world:
        bodies = robot_bodies(world)
        layout = cell_layout(world, JointLimits.from_urdf(world.config.robot.urdf), bodies)
        # links on fixed joints ride on their body: the last link carries flange, cameras and palm
        arm = {f"link_{j}" for j in ("s1", "s2", "s3", "e1", "e2", "w1", "w2")}
        assert set(layout.links) == {"base_link", *arm, "finger_left", "finger_right"}
        assert len(layout.links["link_w2"]) >= 5
        robot = world.robot
        for opening in (0.0, 0.05, 0.08):
            robot.reset_joints(rng.uniform(robot.lower_limits, robot.upper_limits))
            robot.set_gripper(opening)
            world.step(240)  # the fingers move to the opening (the arm is held where it is)
            poses, tcp = bodies.poses(robot.q(), robot.gripper_opening())
            assert poses.pop("base_link") == pytest.approx(np.eye(4))  # (pybullet's base pose is its COM)
            assert tcp == pytest.approx(robot.frame_pose("tcp")[:3, 3], abs=2e-4)
            for link, pose in poses.items():
                truth = robot.frame_pose(link)
                assert pose[:3, 3] == pytest.approx(truth[:3, 3], abs=2e-4), link
                assert pose[:3, :3] == pytest.approx(truth[:3, :3], abs=1e-3), link


def test_ctrl_c_keeps_a_whole_recording_of_the_episode_so_far(tmp_path) -> None:
    pytest.importorskip("rerun")
    import signal

    from tests.test_interrupts import no_temporaries, start

    record, folder = tmp_path / "episode.rrd", tmp_path / "run"
    process = start("pick-place", "--out", folder, "--record", record, cwd=tmp_path)
    process.wait_for(lambda line: line.lstrip().startswith("search"))  # the cloth was found
    process.popen.send_signal(signal.SIGINT)
    code, stderr = process.finish()
    assert code == 130, stderr
    assert f"recording (up to the stop): {record}" in stderr
    assert no_temporaries(tmp_path)
    data = _read(record)  # a whole file: rerun reads it to its end
    recognitions = _csv(folder / "recognitions.csv")
    assert len(data["/cameras/right/image"]["EncodedImage:blob"].values) == len(recognitions) >= 1
    outcome = data["/log/outcome"]["TextLog:text"].values
    assert len(outcome) == 1 and "interrupted" in outcome[0][0]


def test_buffered_rows_arrive_whole_and_in_order(tmp_path) -> None:
    rr = pytest.importorskip("rerun")
    from robot_app.experiments.recording_columns import TimedColumns

    recording = rr.RecordingStream("robot_app_test", recording_id="columns")
    recording.save(str(tmp_path / "columns.rrd"))
    columns = TimedColumns(rr, recording)
    strips = [[np.zeros((4, 2)), np.ones((3, 2))], [], [np.full((5, 2), 2.0)]]  # no outline in view at 1
    for n, (time, rows) in enumerate(zip((0.5, 0.25, 0.75), strips, strict=True)):
        columns.add("outline", "strips", time, rows, cycle=n)
        columns.add("fitness", "scalar", time, 0.1 * n, cycle=n)
        columns.add("mesh", "mesh", time, np.full((6, 3), float(n)))
    with pytest.raises(ValueError, match="vision cycle"):
        columns.add("fitness", "scalar", 1.0, 0.5)  # a row without a cycle among rows with one
    assert columns.pending == 9
    columns.flush()
    recording.flush()
    recording.disconnect()
    data = _read(tmp_path / "columns.rrd")
    assert data["/fitness"]["Scalars:scalars"].values == [[0.1], [0.0], [0.2]]  # in time order
    assert data["/fitness"]["Scalars:scalars"].cycles == [1, 0, 2]
    assert [len(v) for v in data["/outline"]["LineStrips2D:strips"].values] == [0, 2, 1]
    assert [len(v) for v in data["/mesh"]["Mesh3D:vertex_positions"].values] == [6, 6, 6]
