"""Property-based tests of the parsers users feed: --set overrides, config files, trial
configs, stereo rig and model camera files.

Whatever the input, a parser either returns a valid object or raises the input error
of its kind (ConfigError, CalibrationError, InputError) with a message: never another
exception, which the CLI would show as a traceback. Valid inputs round-trip.
"""

from __future__ import annotations

import contextlib
import math
import tempfile
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from robot_app.config import apply_overrides, load_config, parse_override, validate
from robot_app.console import InputWarning
from robot_app.errors import CalibrationError, ConfigError, InputError
from robot_app.experiments import parse_trial_config
from robot_app.geometry import make_transform
from robot_app.vision.camera import PinholeCamera, StereoRig, load_model_camera, load_rig, save_rig
from robot_app.vision.recognizer import RecognitionSettings

SETTINGS = settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])

scalars = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(min_value=-(10**12), max_value=10**12),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=12),
)
yaml_data = st.recursive(
    scalars,
    lambda inner: st.one_of(
        st.lists(inner, max_size=4), st.dictionaries(st.text(min_size=1, max_size=8), inner, max_size=4)
    ),
    max_leaves=12,
)
identifiers = st.from_regex(r"[a-z_][a-z0-9_]{0,7}", fullmatch=True)
dotted_keys = st.lists(identifiers, min_size=1, max_size=4).map(".".join)


def _write(folder: Path, name: str, text: str) -> Path:
    path = folder / name
    path.write_text(text)
    return path


@pytest.fixture(scope="module")
def folder() -> Any:
    with tempfile.TemporaryDirectory() as name:
        yield Path(name)


# --- --set overrides and config files ---------------------------------------------------------------


@SETTINGS
@given(text=st.text(max_size=40))
def test_any_set_text_parses_or_is_a_config_error(text: str) -> None:
    try:
        path, _value = parse_override(text)
    except ConfigError as err:
        assert str(err).startswith("--set ")
    else:
        assert path and all(isinstance(p, str) for p in path)


@SETTINGS
@given(key=dotted_keys, value=yaml_data)
def test_an_override_puts_its_value_at_its_key(key: str, value: Any) -> None:
    text = yaml.safe_dump(value, default_flow_style=True, width=10**6).strip()
    if text.endswith("\n...") or text.endswith(" ..."):
        text = text.rsplit("...", 1)[0].strip()
    data = apply_overrides({}, [f"{key}={text}"])
    node: Any = data
    for part in key.split("."):
        node = node[part]
    expected = yaml.safe_load(text) if text else ""
    same = node == expected or (isinstance(node, float) and math.isnan(node) and math.isnan(expected))
    assert same


@SETTINGS
@given(data=yaml_data, overrides=st.lists(st.text(max_size=30), max_size=3))
def test_any_config_file_loads_or_is_a_config_error(folder: Path, data: Any, overrides: list[str]) -> None:
    path = _write(folder, "config.yaml", yaml.safe_dump(data))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            loaded = load_config(RecognitionSettings, path, overrides)
        except ConfigError as err:
            assert str(err).strip() and err.path == path
        else:
            assert isinstance(loaded, RecognitionSettings)
    assert all(issubclass(w.category, InputWarning) for w in caught)


@SETTINGS
@given(text=st.text(max_size=200))
def test_any_text_as_a_config_file_loads_or_is_a_config_error(folder: Path, text: str) -> None:
    path = folder / "raw.yaml"
    path.write_bytes(text.encode("utf-8", "surrogatepass"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InputWarning)
        with contextlib.suppress(ConfigError):  # anything else fails the test
            load_config(RecognitionSettings, path)


known_values = st.one_of(scalars, st.lists(scalars, max_size=3))
ga_sections = st.fixed_dictionaries(
    {},
    optional={
        "population": known_values,
        "generations": known_values,
        "seed": known_values,
        "islands": known_values,
        "crossover_rate": known_values,
    },
)


@SETTINGS
@given(ga=ga_sections, threshold=known_values)
def test_known_keys_with_any_values_name_the_bad_key_first(ga: dict[str, Any], threshold: Any) -> None:
    try:
        validate(RecognitionSettings, {"propose": {"ga": ga}, "decide": {"threshold": threshold}}, "property")
    except ConfigError as err:
        assert err.problems and str(err).startswith(f"{err.problems[0].key}: ")
        assert err.key == err.problems[0].key


@SETTINGS
@given(
    data=st.dictionaries(
        st.sampled_from(["kind", "trials", "seed", "name", "scene", "sweep", "x"]), yaml_data
    )
)
def test_any_trial_config_parses_or_is_a_config_error(data: dict[str, Any]) -> None:
    try:
        parse_trial_config(data, "property")
    except ConfigError as err:
        assert str(err).strip()


# --- rig and camera files ---------------------------------------------------------------------------


def _valid_rig_data() -> dict[str, Any]:
    camera = PinholeCamera.from_fov((320, 240), np.deg2rad(48))
    rig = StereoRig(camera, camera, make_transform(np.eye(3), [-0.1, 0.0, 0.0]))
    return rig.to_dict()


rig_paths = st.sampled_from(
    [
        ("image_size",),
        ("left",),
        ("left", "camera_matrix"),
        ("left", "dist_coeffs"),
        ("right", "camera_matrix"),
        ("right", "dist_coeffs"),
        ("R",),
        ("T",),
        ("transform_right_camera_to_hand",),
    ]
)


@SETTINGS
@given(changes=st.lists(st.tuples(rig_paths, yaml_data), min_size=1, max_size=3))
def test_any_rig_file_loads_or_is_a_calibration_error(folder: Path, changes: list[Any]) -> None:
    data = _valid_rig_data()
    for path, value in changes:
        node = data
        for part in path[:-1]:
            if not isinstance(node.get(part), dict):
                node[part] = {}
            node = node[part]
        node[path[-1]] = value
    file = _write(folder, "rig.yaml", yaml.safe_dump(data))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            rig = load_rig(file)
        except InputError as err:  # CalibrationError is one
            assert str(err).strip() and err.exit_code == 2
        else:
            assert isinstance(rig, StereoRig) and np.all(np.isfinite(rig.transform_left_to_right))
    assert all(issubclass(w.category, InputWarning) for w in caught)


rotations = st.tuples(*(st.floats(-1.0, 1.0) for _ in range(4))).filter(lambda q: sum(v * v for v in q) > 0.1)


@SETTINGS
@given(
    quaternion=rotations,
    baseline=st.tuples(*(st.floats(-0.3, 0.3) for _ in range(3))),
    focal=st.floats(100.0, 2000.0),
    size=st.tuples(st.integers(8, 4000), st.integers(8, 4000)),
    distortion=st.lists(st.floats(-0.5, 0.5), min_size=5, max_size=5),
)
def test_a_valid_rig_round_trips(folder: Path, quaternion, baseline, focal, size, distortion) -> None:
    from scipy.spatial.transform import Rotation

    assume(np.linalg.norm(baseline) > 1e-2)
    R = Rotation.from_quat(np.asarray(quaternion) / np.linalg.norm(quaternion)).as_matrix()
    K = [[focal, 0.0, size[0] / 2], [0.0, focal, size[1] / 2], [0.0, 0.0, 1.0]]
    camera = PinholeCamera(np.array(K), size, np.array(distortion))
    rig = StereoRig(camera, camera, make_transform(R, baseline))
    save_rig(rig, folder / "valid.yaml")
    with warnings.catch_warnings():
        warnings.simplefilter("error", InputWarning)  # nothing suspicious about a valid rig
        again = load_rig(folder / "valid.yaml")
    assert again.image_size == rig.image_size
    assert np.allclose(again.transform_left_to_right, rig.transform_left_to_right, atol=1e-9)
    assert np.allclose(again.left.dist_coeffs, rig.left.dist_coeffs)


camera_keys = st.sampled_from(["image_size", "camera_matrix", "dist_coeffs", "distance", "extra"])


@SETTINGS
@given(changes=st.dictionaries(camera_keys, yaml_data, min_size=1, max_size=3))
def test_any_model_camera_file_loads_or_is_a_calibration_error(folder: Path, changes: dict[str, Any]) -> None:
    data = {
        "image_size": [640, 480],
        "camera_matrix": [[700.0, 0.0, 320.0], [0.0, 700.0, 240.0], [0.0, 0.0, 1.0]],
        "distance": 0.4,
    } | changes
    file = _write(folder, "camera.yaml", yaml.safe_dump(data))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InputWarning)
        try:
            camera = load_model_camera(file)
        except CalibrationError as err:
            assert str(err).strip()
        else:
            assert camera.distance > 0 and math.isfinite(camera.distance)
