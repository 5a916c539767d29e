"""`robot-app recognize` / `fullsearch` on files: JSON contract and exit code 2 for bad input."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml

from robot_app.cli import main
from robot_app.geometry import make_transform, rotation_about_z
from robot_app.vision.camera import ModelCamera, PinholeCamera, StereoRig, save_rig
from robot_app.vision.photo_model import make_model
from robot_app.vision.synthetic import render_model_photo, render_stereo_pair
from robot_app.vision.synthetic_catalogue import synthetic_cloth

FAST = [
    "--set",
    "propose.ga.population=60",
    "--set",
    "propose.ga.generations=60",
    "--set",
    "propose.coarse_generations=30",
]
TRUTH = make_transform(rotation_about_z(0.5), [0.03, -0.02, 0.58])


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("cli_vision")
    model_camera = ModelCamera(PinholeCamera.from_fov((640, 480), np.deg2rad(48)), 0.40)
    cloth = synthetic_cloth(3)
    photo, background = render_model_photo(cloth, model_camera)
    make_model(photo, model_camera, background, name="small_colourful").save(folder / "model.npz")
    camera = PinholeCamera.from_fov((320, 240), np.deg2rad(48))
    rig = StereoRig(camera, camera, make_transform(np.eye(3), [-0.1, 0.0, 0.0]))
    save_rig(rig, folder / "rig.yaml")
    left, right = render_stereo_pair(rig, [(cloth, TRUTH)], rng=np.random.default_rng(3))
    cv2.imwrite(str(folder / "left.png"), left)
    cv2.imwrite(str(folder / "right.png"), right)
    cv2.imwrite(str(folder / "small.png"), cv2.resize(right, (160, 120)))
    data = yaml.safe_load((folder / "rig.yaml").read_text())
    data["R"] = (2 * np.eye(3)).tolist()
    (folder / "bad_rig.yaml").write_text(yaml.safe_dump(data))
    np.savez(folder / "not_a_model.npz", points=np.zeros((3, 3)))
    return {p.stem: p for p in folder.iterdir()}


def args(files: dict[str, Path], **change: Path) -> list[str]:
    chosen = {"model": files["model"], "rig": files["rig"], "left": files["left"], "right": files["right"]}
    chosen.update(change)
    return [item for key, value in chosen.items() for item in (f"--{key}", str(value))]


def test_recognize_prints_the_design_json(files, capsys) -> None:
    assert main(["recognize", *args(files), "--seed", "1", "--json", *FAST]) == 0
    out = capsys.readouterr().out.strip()
    assert len(out.splitlines()) == 1
    record = json.loads(out)
    keys = {
        "found",
        "fitness",
        "position",
        "quaternion_xyzw",
        "yaw_deg",
        "frame",
        "generations",
        "evaluations",
    }
    assert keys | {"time_s"} <= record.keys()
    assert record["frame"] == "right_camera" and record["found"] is True
    assert np.allclose(record["position"], TRUTH[:3, 3], atol=[0.003, 0.003, 0.015])
    assert abs(record["yaw_deg"] - np.rad2deg(0.5)) < 2.0
    assert main(["recognize", *args(files), "--seed", "1", "--json", *FAST]) == 0
    again = json.loads(capsys.readouterr().out)
    assert again["position"] == record["position"]  # same seed, same result


@pytest.mark.parametrize(
    ("change", "reason"),
    [
        ({"left": Path("/nonexistent/left.png")}, "not found"),
        ({"right": "small"}, "160x120"),
        ({"rig": "bad_rig"}, "not a rotation"),
        ({"model": "not_a_model"}, "not a cloth model"),
        ({"model": "rig"}, "not a cloth model"),
    ],
)
def test_bad_input_exits_2_with_one_line(files, capsys, change, reason) -> None:
    resolved = {k: files[v] if isinstance(v, str) else v for k, v in change.items()}
    assert main(["recognize", *args(files, **resolved), *FAST]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("error:") and reason in err


def test_bad_setting_exits_2(files, capsys) -> None:
    assert main(["recognize", *args(files), "--set", "propose.ga.population=1"]) == 2
    assert "ga.population" in capsys.readouterr().err


def test_fullsearch_writes_plots_and_summary(files, tmp_path, capsys) -> None:
    out = tmp_path / "fs"
    code = main(["fullsearch", *args(files), "--out", str(out), "--step", "0.01", "--seed", "2", *FAST])
    assert code == 0
    summary = json.loads((out / "summary.json").read_text())
    assert (out / "fullsearch_2d.png").stat().st_size > 0 and (out / "fullsearch_3d.png").stat().st_size > 0
    best = np.array(summary["full_search"]["best_position"])
    assert summary["full_search"]["evaluations"] > 0 and np.all(np.isfinite(best))
    assert summary["ga"]["found"] is True
