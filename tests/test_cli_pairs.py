"""`robot-app recognize --pairs`: one JSON line per row, failed rows named, exit 1 at the end."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from robot_app.cli import main
from robot_app.commands.recognize_pairs import read_pairs
from robot_app.errors import InputError
from robot_app.geometry import make_transform, rotation_about_z
from robot_app.vision.camera import ModelCamera, PinholeCamera, StereoRig, save_rig
from robot_app.vision.photo_model import make_model
from robot_app.vision.synthetic import render_model_photo, render_stereo_pair
from robot_app.vision.synthetic_catalogue import synthetic_cloth

FAST = ["--set", "propose.ga.population=60", "--set", "propose.ga.generations=40",
        "--set", "propose.coarse_generations=20", "--set", "propose.restarts=0"]  # fmt: skip
TRUTH = make_transform(rotation_about_z(0.5), [0.03, -0.02, 0.58])


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("pairs")
    model_camera = ModelCamera(PinholeCamera.from_fov((640, 480), np.deg2rad(48)), 0.40)
    cloth = synthetic_cloth(3)
    photo, background = render_model_photo(cloth, model_camera)
    make_model(photo, model_camera, background).save(root / "model.npz")
    camera = PinholeCamera.from_fov((320, 240), np.deg2rad(48))
    rig = StereoRig(camera, camera, make_transform(np.eye(3), [-0.1, 0.0, 0.0]))
    save_rig(rig, root / "rig.yaml")
    (root / "images").mkdir()
    for k in range(2):
        left, right = render_stereo_pair(rig, [(cloth, TRUTH)], rng=np.random.default_rng(k))
        cv2.imwrite(str(root / "images" / f"l{k}.png"), left)
        cv2.imwrite(str(root / "images" / f"r{k}.png"), right)
    return root


def run(folder: Path, csv_text: str, capsys: pytest.CaptureFixture[str]) -> tuple[int, list[str], str]:
    (folder / "pairs.csv").write_text(csv_text)
    args = ["recognize", "--model", str(folder / "model.npz"), "--rig", str(folder / "rig.yaml")]
    code = main([*args, "--pairs", str(folder / "pairs.csv"), "--seed", "1", *FAST])
    captured = capsys.readouterr()
    return code, captured.out.splitlines(), captured.err


def test_every_row_prints_one_line_in_order_and_a_missing_image_names_its_row(folder, capsys) -> None:
    absolute = folder / "images" / "r1.png"
    rows = ["images/l0.png,images/r0.png", "images/missing.png,images/r0.png", f"images/l1.png,{absolute}"]
    text = "left,right\n" + "\n".join(rows) + "\n"
    code, lines, err = run(folder, text, capsys)
    records = [json.loads(line) for line in lines]
    assert code == 1 and [r["row"] for r in records] == [1, 2, 3]
    assert "error" in records[1] and "missing.png" in records[1]["error"]
    for record in (records[0], records[2]):
        assert record["found"] and np.allclose(record["position"], TRUTH[:3, 3], atol=0.004)
        assert 0.0 <= record["confidence"] <= 1.0 and 0.0 <= record["visible_fraction"] <= 1.0
    assert "3 pairs, 1 failed" in err and "1 of 3 pairs failed" in err  # on stderr, not stdout


def test_all_rows_good_exits_0(folder, capsys) -> None:
    code, lines, _ = run(folder, "left,right\nimages/l0.png,images/r0.png\n", capsys)
    assert code == 0 and len(lines) == 1 and json.loads(lines[0])["row"] == 1


@pytest.mark.parametrize(
    ("text", "reason"),
    [("a,b\nx.png,y.png\n", "left,right"), ("left,right\nimages/l0.png,\n", "row 1")],
)
def test_a_malformed_pairs_file_is_bad_input_before_any_work(folder, capsys, text: str, reason: str) -> None:
    code, lines, err = run(folder, text, capsys)
    assert code == 2 and lines == [] and reason in err


def test_pairs_and_left_right_together_are_bad_input(folder, capsys) -> None:
    (folder / "pairs.csv").write_text("left,right\nimages/l0.png,images/r0.png\n")
    args = ["recognize", "--model", str(folder / "model.npz"), "--rig", str(folder / "rig.yaml")]
    assert main([*args, "--pairs", str(folder / "pairs.csv"), "--left", "x.png"]) == 2
    assert main(args) == 2
    capsys.readouterr()


def test_read_pairs_resolves_relative_paths_against_the_csv_folder(tmp_path: Path) -> None:
    (tmp_path / "p.csv").write_text("right,left\nb.png,a.png\n")
    (row,) = read_pairs(tmp_path / "p.csv")
    assert row.left == tmp_path / "a.png" and row.right == tmp_path / "b.png" and row.row == 1
    with pytest.raises(InputError) as err:
        read_pairs(tmp_path / "none.csv")
    assert err.value.path == tmp_path / "none.csv"
