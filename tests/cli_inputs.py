"""Small input files for the command-line tests: a model, a rig, a stereo pair, a model photo.

Made from the synthetic renderer in a few seconds; shared by the bad-input and interrupt
suites (not a conftest: the tests import what they use).
"""

from __future__ import annotations

import os
import struct
import subprocess
import sys
import zlib
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from robot_app.cli import main
from robot_app.geometry import make_transform, rotation_about_z
from robot_app.vision.camera import ModelCamera, PinholeCamera, StereoRig, save_model_camera, save_rig
from robot_app.vision.photo_model import make_model
from robot_app.vision.synthetic import render_model_photo, render_stereo_pair
from robot_app.vision.synthetic_catalogue import synthetic_cloth

FAST_GA = [
    "--set",
    "propose.ga.population=40",
    "--set",
    "propose.ga.generations=20",
    "--set",
    "propose.coarse_generations=10",
]
TRUTH = make_transform(rotation_about_z(0.5), [0.03, -0.02, 0.58])
REPO = Path(__file__).resolve().parents[1]


@dataclass(frozen=True)
class Inputs:
    """Paths of the shared input files."""

    folder: Path
    model: Path
    rig: Path
    left: Path
    right: Path
    photo: Path
    background: Path
    camera: Path

    def recognize_args(self, **change: Path | str) -> list[str]:
        chosen: dict[str, Path | str] = {
            "model": self.model,
            "rig": self.rig,
            "left": self.left,
            "right": self.right,
        }
        chosen.update(change)
        return [item for key, value in chosen.items() for item in (f"--{key}", str(value))]


def make_inputs(folder: Path) -> Inputs:
    """Writes the shared input files into `folder`."""
    model_camera = ModelCamera(PinholeCamera.from_fov((480, 360), np.deg2rad(48)), 0.40)
    cloth = synthetic_cloth(3)
    photo, background = render_model_photo(cloth, model_camera, rng=np.random.default_rng(0))
    cv2.imwrite(str(folder / "photo.png"), photo)
    cv2.imwrite(str(folder / "background.png"), background)
    save_model_camera(model_camera, folder / "camera.yaml")
    make_model(photo, model_camera, background, name="cloth3").save(folder / "model.npz")
    camera = PinholeCamera.from_fov((320, 240), np.deg2rad(48))
    save_rig(StereoRig(camera, camera, make_transform(np.eye(3), [-0.1, 0.0, 0.0])), folder / "rig.yaml")
    left, right = render_stereo_pair(
        StereoRig(camera, camera, make_transform(np.eye(3), [-0.1, 0.0, 0.0])),
        [(cloth, TRUTH)],
        rng=np.random.default_rng(3),
    )
    cv2.imwrite(str(folder / "left.png"), left)
    cv2.imwrite(str(folder / "right.png"), right)
    return Inputs(
        folder,
        folder / "model.npz",
        folder / "rig.yaml",
        folder / "left.png",
        folder / "right.png",
        folder / "photo.png",
        folder / "background.png",
        folder / "camera.yaml",
    )


def png_chunk(kind: bytes, body: bytes, *, good_crc: bool = True) -> bytes:
    crc = zlib.crc32(kind + body) & 0xFFFFFFFF
    return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", crc if good_crc else crc ^ 1)


def png_with_bad_ancillary_chunk(source: Path, target: Path) -> None:
    """A copy of a PNG with a tEXt chunk whose checksum is wrong: libpng warns, and reads it."""
    data = source.read_bytes()
    target.write_bytes(data[:33] + png_chunk(b"tEXt", b"Comment\x00x", good_crc=False) + data[33:])


def png_header_only(target: Path, width: int, height: int) -> None:
    """A tiny 'PNG' whose header claims width x height pixels (a decompression bomb's header)."""
    ihdr = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    target.write_bytes(b"\x89PNG\r\n\x1a\n" + png_chunk(b"IHDR", ihdr) + png_chunk(b"IEND", b""))


@dataclass(frozen=True)
class Run:
    """What a command did: exit code, stdout, stderr."""

    code: int
    out: str
    err: str

    @property
    def first_err(self) -> str:
        lines = self.err.strip().splitlines()
        return lines[0] if lines else ""


def run_cli(capsys, *args: object) -> Run:
    """Runs `robot-app args...` in this process, as the console script would."""
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return Run(code, out, err)


def process_env() -> dict[str, str]:
    """The environment for a `robot-app` child process: this checkout first on the path."""
    path = os.pathsep.join(p for p in (str(REPO), os.environ.get("PYTHONPATH", "")) if p)
    return os.environ | {"PYTHONPATH": path, "PYTHONUNBUFFERED": "1"}


def run_process(*args: object, timeout: float = 300.0, cwd: Path | None = None) -> Run:
    """Runs `robot-app args...` as a separate process (file-descriptor level output)."""
    done = subprocess.run(
        [sys.executable, "-m", "robot_app.cli", *(str(a) for a in args)],
        capture_output=True,
        text=True,
        timeout=timeout,
        cwd=cwd,
        env=process_env(),
        check=False,
    )
    return Run(done.returncode, done.stdout, done.stderr)


def assert_one_line_error(run: Run, code: int, *names: str) -> None:
    """Exit `code`, no traceback, the first stderr line an error naming each of `names`."""
    assert run.code == code, (run.code, run.err)
    assert "Traceback" not in run.err
    assert run.first_err.startswith("error: "), run.err
    for name in names:
        assert name in run.first_err, (name, run.first_err)


def files_under(folder: Path) -> list[str]:
    """Every path under `folder`, relative, sorted (hidden temporaries included)."""
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


@dataclass(frozen=True)
class Counted:
    """Outcome of `counted_trial`."""

    value: int


def counted_trial(_config: object, scene_index: int, _seed: int) -> Counted:
    """A trial that is 'interrupted by SIGTERM' when it reaches scene 3."""
    from robot_app.interrupts import SignalInterrupt

    if scene_index == 3:
        raise SignalInterrupt(15)
    return Counted(scene_index)
