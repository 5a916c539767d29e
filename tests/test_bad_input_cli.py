"""Bad input over every subcommand, driven as a user would: images, rig/camera/model files,
configs and --set, seeds, messages and warnings.

Each case checks the exit code, that the first line on stderr is an error (or warning)
naming the file, key or value, that no traceback is printed, and what is on disk.
Output paths and resource limits are in test_output_paths_cli.py, interrupts in
test_interrupts.py.
"""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import pytest
import yaml

from robot_app.cli import main
from robot_app.errors import CalibrationError, ConfigError, InputError
from tests.cli_inputs import (
    FAST_GA,
    Inputs,
    assert_one_line_error,
    make_inputs,
    png_header_only,
    png_with_bad_ancillary_chunk,
    run_cli,
    run_process,
)


@pytest.fixture(scope="module")
def inputs(tmp_path_factory: pytest.TempPathFactory) -> Inputs:
    return make_inputs(tmp_path_factory.mktemp("bad_input"))


def _rig_variant(inputs: Inputs, folder: Path, name: str, **change: object) -> Path:
    data = yaml.safe_load(inputs.rig.read_text())
    for key, value in change.items():
        node = data
        *parents, last = key.split(".")
        for part in parents:
            node = node[part]
        node[last] = value
    path = folder / name
    path.write_text(yaml.safe_dump(data))
    return path


# --- images ---------------------------------------------------------------------------------


def test_a_missing_image_is_named(inputs, capsys, tmp_path) -> None:
    missing = tmp_path / "nope.png"
    run = run_cli(capsys, "recognize", *inputs.recognize_args(left=missing), *FAST_GA)
    assert_one_line_error(run, 2, "not found", str(missing))


def test_a_folder_given_as_an_image_is_called_a_folder_not_missing(inputs, capsys, tmp_path) -> None:
    run = run_cli(capsys, "recognize", *inputs.recognize_args(right=tmp_path), *FAST_GA)
    assert_one_line_error(run, 2, "is a folder", str(tmp_path))


def test_a_text_file_given_as_an_image(inputs, capsys) -> None:
    run = run_cli(capsys, "recognize", *inputs.recognize_args(left=inputs.rig), *FAST_GA)
    assert_one_line_error(run, 2, "not a readable image", str(inputs.rig))


def test_a_truncated_png(inputs, capsys, tmp_path) -> None:
    cut = tmp_path / "cut.png"
    data = inputs.left.read_bytes()
    cut.write_bytes(data[: len(data) // 3])
    run = run_cli(capsys, "recognize", *inputs.recognize_args(left=cut), *FAST_GA)
    assert_one_line_error(run, 2, "not a readable image", str(cut))


def test_a_huge_image_is_refused_by_its_header_before_decoding(inputs, capsys, tmp_path) -> None:
    bomb = tmp_path / "bomb.png"
    png_header_only(bomb, 100_000, 100_000)  # 60 bytes claiming 10^10 pixels
    run = run_cli(capsys, "recognize", *inputs.recognize_args(left=bomb), *FAST_GA)
    assert_one_line_error(run, 2, "--left", "100000x100000", "GB", "--max-memory-gb")
    # with the limit raised on purpose, the file is still not a readable image: no crash, no traceback
    run = run_cli(capsys, "recognize", *inputs.recognize_args(left=bomb), "--max-memory-gb", "1e5")
    assert_one_line_error(run, 2, "not a readable image")


def test_a_grayscale_stereo_pair_is_usable_with_a_warning(inputs, capsys, tmp_path) -> None:
    gray = {}
    for side in ("left", "right"):
        gray[side] = tmp_path / f"gray_{side}.png"
        image = cv2.imread(str(getattr(inputs, side)))
        cv2.imwrite(str(gray[side]), cv2.cvtColor(image, cv2.COLOR_BGR2GRAY))
    run = run_cli(capsys, "recognize", *inputs.recognize_args(**gray), "--json", *FAST_GA)
    assert run.code == 0, run.err
    assert run.first_err.startswith("warning: ") and "grayscale" in run.first_err
    assert str(gray["left"]) in run.first_err
    assert "found" in json.loads(run.out)  # still a result


def test_a_colour_file_with_three_equal_channels_is_grayscale_too(inputs, capsys, tmp_path) -> None:
    flat = tmp_path / "flat.png"
    image = cv2.cvtColor(cv2.imread(str(inputs.left)), cv2.COLOR_BGR2GRAY)
    cv2.imwrite(str(flat), cv2.merge([image, image, image]))  # stored as RGB, no colour
    run = run_cli(capsys, "recognize", *inputs.recognize_args(left=flat), "--json", *FAST_GA)
    assert run.code == 0 and run.first_err.startswith("warning: ") and "flat.png" in run.first_err


def test_libpng_warnings_stay_off_the_terminal(inputs, capfd, tmp_path) -> None:
    noisy = tmp_path / "noisy.png"
    png_with_bad_ancillary_chunk(inputs.left, noisy)  # libpng: "tEXt: CRC error"
    code = main(["recognize", *inputs.recognize_args(left=noisy), "--json", *FAST_GA])
    out, err = capfd.readouterr()  # file-descriptor level: what a terminal would show
    assert code == 0 and "libpng" not in err and err.strip() == ""
    assert json.loads(out)["frame"] == "right_camera"


def test_model_make_refuses_a_grayscale_photo(inputs, capsys, tmp_path) -> None:
    gray = tmp_path / "gray.png"
    cv2.imwrite(str(gray), cv2.cvtColor(cv2.imread(str(inputs.photo)), cv2.COLOR_BGR2GRAY))
    out = tmp_path / "m.npz"
    run = run_cli(capsys, "model", "make", gray, "--camera", inputs.camera, "--out", out)
    assert_one_line_error(run, 2, "grayscale", str(gray))
    assert "border" not in run.err  # the old, misleading reason
    run = run_cli(
        capsys, "model", "make", inputs.photo, "--camera", inputs.camera, "--background", gray, "--out", out
    )
    assert_one_line_error(run, 2, "grayscale", "background")
    assert not out.exists()


# --- rig, camera and model files ----------------------------------------------------------


def test_a_rig_folder_is_called_a_folder(inputs, capsys, tmp_path) -> None:
    run = run_cli(capsys, "recognize", *inputs.recognize_args(rig=tmp_path), *FAST_GA)
    assert_one_line_error(run, 2, "stereo rig", "is a folder")


def test_a_camera_matrix_with_nan_says_so(inputs, capsys, tmp_path) -> None:
    matrix = yaml.safe_load(inputs.rig.read_text())["left"]["camera_matrix"]
    matrix[0][2] = float("nan")
    rig = _rig_variant(inputs, tmp_path, "nan.yaml", **{"left.camera_matrix": matrix})
    run = run_cli(capsys, "recognize", *inputs.recognize_args(rig=rig), *FAST_GA)
    assert_one_line_error(run, 2, "finite")
    assert "got (3, 3)" not in run.err  # used to answer the shape it had asked for


@pytest.mark.parametrize(
    ("change", "words"),
    [
        ({"image_size": "wide"}, ("image_size", "wide")),
        ({"image_size": [320.5, 240]}, ("image_size",)),
        ({"left": 5}, ("malformed",)),
        ({"T": [1, 2]}, ("T",)),
        ({"R": [[1, 0, 0], [0, 1, 0], [0, 0, -1]]}, ("not a rotation",)),
        ({"left.dist_coeffs": [0, 0, 0, 0, 0, 0, 0]}, ("dist_coeffs",)),
    ],
)
def test_a_malformed_rig_is_one_line(inputs, capsys, tmp_path, change, words) -> None:
    rig = _rig_variant(inputs, tmp_path, "bad.yaml", **change)
    run = run_cli(capsys, "recognize", *inputs.recognize_args(rig=rig), *FAST_GA)
    assert_one_line_error(run, 2, str(rig), *words)


def test_a_zero_baseline_rig_is_warned_about(inputs, capsys, tmp_path) -> None:
    rig = _rig_variant(inputs, tmp_path, "zero.yaml", T=[0.0, 0.0, 0.0])
    run = run_cli(capsys, "recognize", *inputs.recognize_args(rig=rig), "--json", *FAST_GA)
    assert run.code == 0, run.err
    assert run.first_err.startswith("warning: ") and "baseline" in run.first_err and str(rig) in run.first_err


def test_a_short_distortion_vector_is_warned_about(inputs, capsys, tmp_path) -> None:
    rig = _rig_variant(inputs, tmp_path, "short.yaml", **{"right.dist_coeffs": [0.01, -0.002]})
    run = run_cli(capsys, "recognize", *inputs.recognize_args(rig=rig), "--json", *FAST_GA)
    assert run.code == 0, run.err
    assert run.first_err.startswith("warning: ") and "right.dist_coeffs has 2 coefficients" in run.first_err


def test_a_model_camera_file_with_a_short_distortion_vector_warns(inputs, capsys, tmp_path) -> None:
    data = yaml.safe_load(inputs.camera.read_text()) | {"dist_coeffs": [0.0, 0.0]}
    camera = tmp_path / "short_camera.yaml"
    camera.write_text(yaml.safe_dump(data))
    out = tmp_path / "m.npz"
    run = run_cli(capsys, "model", "make", inputs.photo, "--camera", camera, "--out", out)
    assert run.code == 0, run.err
    assert run.first_err.startswith("warning: ") and "dist_coeffs has 2" in run.first_err
    assert out.is_file()


@pytest.mark.parametrize(
    ("data", "words"),
    [
        ("distance: [1, 2]\n", ("missing key 'image_size'",)),
        ("not: [a camera", ("not a YAML camera file",)),
        ("- 1\n- 2\n", ("not a YAML camera file",)),
    ],
)
def test_a_malformed_camera_file_is_one_line(inputs, capsys, tmp_path, data, words) -> None:
    camera = tmp_path / "camera.yaml"
    camera.write_text(data)
    out = tmp_path / "m.npz"
    run = run_cli(capsys, "model", "make", inputs.photo, "--camera", camera, "--out", out)
    assert_one_line_error(run, 2, *words)
    assert not out.exists()


@pytest.mark.parametrize("content", [b"", b"PK\x03\x04 not really a zip", b"\x93NUMPY garbage"])
def test_a_file_that_is_not_a_model(inputs, capsys, tmp_path, content) -> None:
    fake = tmp_path / "fake.npz"
    fake.write_bytes(content)
    run = run_cli(capsys, "model", "show", fake)
    assert_one_line_error(run, 2, "not a cloth model", str(fake))
    run = run_cli(capsys, "recognize", *inputs.recognize_args(model=fake), *FAST_GA)
    assert_one_line_error(run, 2, "not a cloth model")


def test_a_model_folder_is_called_a_folder(capsys, tmp_path) -> None:
    run = run_cli(capsys, "model", "show", tmp_path)
    assert_one_line_error(run, 2, "cloth model", "is a folder")


# --- configs and --set -----------------------------------------------------------------------


@pytest.mark.parametrize(
    ("setting", "words"),
    [
        ("propose.ga.populaton=50", ("propose.ga.populaton", "unknown key")),
        ("propose.ga.population=2", ("propose.ga.population", "(got 2)")),
        ("propose.ga.population=many", ("propose.ga.population", "many")),
        ("ga", ("--set 'ga'", "key.path=value")),
        ("propose.ga.population=[1,", ("--set", "not valid YAML")),
        ("propose.ga.population.x=1", ("propose.ga.population", "{'x': 1}")),
    ],
)
def test_bad_set_values_name_the_key_first(inputs, capsys, setting, words) -> None:
    run = run_cli(capsys, "recognize", *inputs.recognize_args(), "--set", setting)
    assert_one_line_error(run, 2, *words)
    assert not run.first_err.startswith("error: invalid")  # no "invalid defaults:" heading


@pytest.mark.parametrize(
    ("text", "words"),
    [("ga: [unclosed\n", ("not valid YAML",)), ("- a\n- b\n", ("mapping",)), ("\x00\x01", ("YAML",))],
)
def test_a_bad_config_file_is_one_line(inputs, capsys, tmp_path, text, words) -> None:
    config = tmp_path / "bad.yaml"
    config.write_text(text)
    run = run_cli(capsys, "recognize", *inputs.recognize_args(), "--config", config)
    assert_one_line_error(run, 2, str(config), *words)


def test_a_config_folder_is_called_a_folder(inputs, capsys, tmp_path) -> None:
    run = run_cli(capsys, "recognize", *inputs.recognize_args(), "--config", tmp_path)
    assert_one_line_error(run, 2, "is a folder")


def test_an_empty_config_file_is_used_with_a_warning(inputs, capsys, tmp_path) -> None:
    config = tmp_path / "empty.yaml"
    config.write_text("# nothing set yet\n")
    run = run_cli(capsys, "recognize", *inputs.recognize_args(), "--config", config, "--json", *FAST_GA)
    assert run.code == 0, run.err
    assert run.first_err.startswith("warning: ") and "empty" in run.first_err and str(config) in run.first_err


def test_a_trial_config_of_an_unknown_kind_names_the_key(capsys, tmp_path) -> None:
    config = tmp_path / "odd.yaml"
    config.write_text("kind: weather\ntrials: 2\n")
    run = run_cli(capsys, "trial", config, "--out", tmp_path / "out")
    assert_one_line_error(run, 2, "kind", "weather")
    assert not (tmp_path / "out").exists()


def test_a_bad_pick_place_setting_fails_before_the_cell_is_built(capsys, tmp_path) -> None:
    run = run_cli(capsys, "pick-place", "--set", "loop.vision_rate_hz=1000", "--out", tmp_path / "r")
    assert_one_line_error(run, 2, "loop.vision_rate_hz", "1000")
    assert not (tmp_path / "r").exists()


def test_sim_show_with_an_unknown_cloth_is_one_line(capsys, tmp_path) -> None:
    run = run_cli(capsys, "sim", "show", "--target", "99", "--out", tmp_path / "pics")
    assert_one_line_error(run, 2, "target", "99")
    assert not (tmp_path / "pics").exists()


def test_sim_model_photo_with_an_unknown_cloth_is_one_line(capsys, tmp_path) -> None:
    run = run_cli(capsys, "sim", "model-photo", "0", "--out", tmp_path / "photo")
    assert_one_line_error(run, 2, "cloth number", "0")
    assert not (tmp_path / "photo").exists()


def test_an_unknown_option_is_one_line(inputs, capsys) -> None:
    run = run_cli(capsys, "recognize", *inputs.recognize_args(), "--sed", "3")
    assert_one_line_error(run, 2, "--sed")


# --- seeds --------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "command",
    [
        ["recognize", "{recognize}"],
        ["fullsearch", "{recognize}", "--out", "{tmp}/fs"],
        ["pick-place", "--out", "{tmp}/pp"],
        ["sim", "show", "--out", "{tmp}/pics"],
    ],
)
def test_a_negative_seed_is_a_one_line_error(inputs, capsys, tmp_path, command) -> None:
    args: list[str] = []
    for part in command:
        if part == "{recognize}":
            args += inputs.recognize_args()
        else:
            args.append(part.format(tmp=tmp_path))
    run = run_cli(capsys, *args, "--seed", "-1")
    assert_one_line_error(run, 2, "--seed", "-1")
    assert len(run.err.strip().splitlines()) == 1
    assert list(tmp_path.iterdir()) == []  # nothing written


@pytest.mark.parametrize("setting", ["propose.ga.seed=-3", "seed=-3"])
def test_a_negative_seed_in_settings_is_a_config_error(inputs, capsys, tmp_path, setting) -> None:
    if setting.startswith("propose."):
        run = run_cli(capsys, "recognize", *inputs.recognize_args(), "--set", setting)
        key = "propose.ga.seed"
    else:
        run = run_cli(capsys, "pick-place", "--set", setting, "--out", tmp_path / "pp")
        key = "seed"
    assert_one_line_error(run, 2, key, "-3")


def test_a_seed_that_is_not_a_number(inputs, capsys) -> None:
    run = run_cli(capsys, "recognize", *inputs.recognize_args(), "--seed", "abc")
    assert_one_line_error(run, 2, "--seed")


# --- the first line is ours, tracebacks only when asked -------------------------------------------


def test_pybullet_banner_is_not_printed(tmp_path) -> None:
    run = run_process("sim", "show", "--target", "99", "--out", tmp_path / "pics")
    assert run.code == 2 and "pybullet build time" not in run.err + run.out
    assert run.first_err.startswith("error: target"), run.err
    run = run_process("sim", "rig", "--out", tmp_path / "rig.yaml")
    assert run.code == 0 and run.err == "" and "pybullet build time" not in run.out
    assert (tmp_path / "rig.yaml").is_file()


def test_robot_app_debug_shows_the_traceback(inputs, monkeypatch, tmp_path) -> None:
    monkeypatch.setenv("ROBOT_APP_DEBUG", "1")
    with pytest.raises(InputError) as missing:
        main(["recognize", *inputs.recognize_args(left=tmp_path / "missing.png")])
    assert (missing.value.path, missing.value.key) == (tmp_path / "missing.png", "--left")
    with pytest.raises(ConfigError) as population:
        main(["recognize", *inputs.recognize_args(), "--set", "propose.ga.population=1"])
    assert (population.value.key, population.value.value) == ("propose.ga.population", 1)


def test_errors_carry_their_data(inputs, tmp_path) -> None:
    from robot_app.vision.camera import load_rig

    rig = _rig_variant(inputs, tmp_path, "wide.yaml", image_size="wide")
    with pytest.raises(CalibrationError) as caught:
        load_rig(rig)
    assert caught.value.key == "image_size" and caught.value.value == "wide" and caught.value.path == rig


def test_a_failed_pick_exits_1_not_0(monkeypatch, capsys, tmp_path) -> None:
    # typer returns a command's `typer.Exit(1)` as a value; it used to be dropped (exit 0)
    import typer

    from robot_app import cli

    def failing() -> None:
        raise typer.Exit(1)

    app = typer.Typer()
    app.command("fails")(failing)
    app.command("other")(lambda: None)
    monkeypatch.setattr(cli, "app", app)
    assert cli.main(["fails"]) == 1


def test_running_out_of_memory_anyway_is_one_line(inputs, capsys, monkeypatch) -> None:
    # the guards' estimates are upper bounds, but if memory still runs out: no traceback
    from robot_app.vision.recognizer import Recognizer

    def exhausted(*_args: object, **_kwargs: object) -> None:
        raise MemoryError

    monkeypatch.setattr(Recognizer, "recognize", exhausted)
    run = run_cli(capsys, "recognize", *inputs.recognize_args(), *FAST_GA)
    assert_one_line_error(run, 1, "out of memory", "--max-memory-gb")


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["demo", "--gui"], ("--gui", "display")),
        (["demo", "--seconds", "-1"], ("--seconds", "-1")),
        (["recognize", "--max-memory-gb", "0"], ("--max-memory-gb", "0")),
        (["trial", "missing.yaml"], ("config file not found", "missing.yaml")),
        (["model", "make"], ("'photo'", "robot-app model make --help")),
    ],
)
def test_other_bad_arguments_are_one_line(capsys, monkeypatch, args, words) -> None:
    monkeypatch.delenv("DISPLAY", raising=False)
    run = run_cli(capsys, *args)
    assert_one_line_error(run, 2, *words)


# --- clear-table -----------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("setting", "names"),
    [
        ("pile.count=[9,9]", ("pile", "2-6")),
        ("sort.boxes.greys=[3]", ("sort", "greys")),
        ("known=[0]", ("known", "1-20")),
    ],
)
def test_clear_table_bad_settings_are_one_line_errors_before_any_work(
    capsys, tmp_path, setting, names
) -> None:
    out = tmp_path / "job"
    run = run_cli(capsys, "clear-table", "--set", setting, "--out", out)
    assert_one_line_error(run, 2, *names)
    assert not out.exists()


def test_clear_table_out_naming_a_file_is_refused_and_the_file_kept(capsys, tmp_path) -> None:
    file = tmp_path / "results"
    file.write_text("keep me")
    run = run_cli(capsys, "clear-table", "--out", file)
    assert_one_line_error(run, 2, str(file))
    assert file.read_text() == "keep me"
