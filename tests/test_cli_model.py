"""`robot-app model make/show`: end to end on rendered files, and bad input exits 2."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from robot_app.cli import main
from robot_app.vision.camera import ModelCamera, PinholeCamera, save_model_camera
from robot_app.vision.cloth_model import ClothModel
from robot_app.vision.synthetic import render_model_photo
from robot_app.vision.synthetic_catalogue import synthetic_cloth


@pytest.fixture
def files(tmp_path):
    camera = ModelCamera(PinholeCamera.from_fov((480, 360), np.deg2rad(48)), 0.40)
    save_model_camera(camera, tmp_path / "cam.yaml")
    photo, background = render_model_photo(synthetic_cloth(0), camera, rng=np.random.default_rng(0))
    cv2.imwrite(str(tmp_path / "photo.png"), photo)
    cv2.imwrite(str(tmp_path / "bg.png"), background)
    return tmp_path


def _run(capsys, *args: str) -> tuple[int, str, str]:
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


def test_model_make_writes_a_loadable_model_and_a_preview(files, capsys):
    code, out, _ = _run(
        capsys, "model", "make", files / "photo.png", "--camera", files / "cam.yaml",
        "--out", files / "m.npz", "--background", files / "bg.png", "--preview", files / "p.png",
        "--set", "point_spacing=0.008",
    )  # fmt: skip
    model = ClothModel.load(files / "m.npz")
    assert code == 0 and f"{model.extent[0] * 1e3:.0f} x {model.extent[1] * 1e3:.0f} mm" in out
    assert model.extent == pytest.approx((0.2, 0.15), abs=0.0015)
    assert model.name == "photo" and model.metadata["settings"]["point_spacing"] == 0.008
    assert model.metadata["sources"]["background"].endswith("bg.png")
    preview = cv2.imread(str(files / "p.png"))
    assert preview.shape == (360, 3 * 480, 3)
    code, out, _ = _run(capsys, "model", "show", files / "m.npz")
    assert code == 0 and json.loads(out)["n_in"] == model.n_in


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["model", "make", "{d}/missing.png", "--camera", "{d}/cam.yaml", "--out", "{d}/m.npz"], "not found"),
        (["model", "make", "{d}/cam.yaml", "--camera", "{d}/cam.yaml", "--out", "{d}/m.npz"], "readable"),
        (["model", "make", "{d}/photo.png", "--camera", "{d}/photo.png", "--out", "{d}/m.npz"], "camera"),
        (["model", "make", "{d}/bg.png", "--camera", "{d}/cam.yaml", "--out", "{d}/m.npz"], "no cloth"),
        (["model", "make", "{d}/photo.png", "--camera", "{d}/cam.yaml", "--out", "{d}/m.npz",
          "--set", "point_spacing=-1"], "point_spacing"),
        (["model", "make", "{d}/photo.png", "--camera", "{d}/cam.yaml", "--out", "{d}/no/m.npz"], "folder"),
        (["model", "show", "{d}/photo.png"], "not a cloth model"),
        (["model", "show", "{d}/other.npz"], "not a cloth model"),
    ],
)  # fmt: skip
def test_bad_input_exits_2_with_a_one_line_reason(files, capsys, args, message):
    np.savez(files / "other.npz", points=np.zeros(3))
    code, _, err = _run(capsys, *(a.format(d=files) for a in args))
    assert code == 2
    lines = err.strip().splitlines()
    assert lines[0].startswith("error: ") and message in err


def test_a_camera_file_of_the_wrong_size_is_bad_input(files, capsys):
    small = ModelCamera(PinholeCamera.from_fov((320, 240), np.deg2rad(48)), 0.40)
    save_model_camera(small, files / "small.yaml")
    code, _, err = _run(
        capsys,
        "model",
        "make",
        files / "photo.png",
        "--camera",
        files / "small.yaml",
        "--out",
        files / "m.npz",
    )
    assert code == 2 and "320x240" in err
