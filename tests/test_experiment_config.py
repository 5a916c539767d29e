"""Typed trial configs: every shipped config loads; bad keys, types and ranges are named."""

from __future__ import annotations

from pathlib import Path

import pytest

from robot_app.cli import main
from robot_app.errors import ConfigError
from robot_app.experiments.experiment_config import (
    PickPlaceTrialConfig,
    RecognitionTrialConfig,
    load_trial_config,
    parse_trial_config,
)

CONFIGS = Path(__file__).resolve().parents[1] / "configs"
OWN_CONFIGS = ["default", "recognition_1000", "occlusion", "two_cloths", "absent_target", "ga_sweep"]


@pytest.mark.parametrize("name", OWN_CONFIGS)
def test_shipped_configs_load(name: str) -> None:
    config = load_trial_config(CONFIGS / f"{name}.yaml")
    assert isinstance(config, RecognitionTrialConfig)
    assert config.name == name
    for point in range(config.point_count):
        assert config.at_point(point).sweep is None


def test_recognition_1000_covers_all_cloths() -> None:
    config = load_trial_config(CONFIGS / "recognition_1000.yaml")
    assert config.trials == 1000 and sorted(config.scene.cloth_ids) == list(range(1, 13))


def _error(data: dict, *overrides: str) -> ConfigError:
    with pytest.raises(ConfigError) as info:
        from robot_app.config import apply_overrides

        parse_trial_config(apply_overrides(data, list(overrides)), "test.yaml")
    return info.value


def test_unknown_key_is_named() -> None:
    error = _error({"kind": "recognition", "scene": {"clothes": [1]}})
    assert error.key == "scene.clothes" and error.problems[0].problem == "unknown key"
    assert "test.yaml" in str(error).splitlines()[0]


def test_wrong_type_is_named() -> None:
    error = _error({}, "trials=many")
    assert (error.key, error.value) == ("trials", "many") and "integer" in error.problems[0].problem


@pytest.mark.parametrize(
    ("override", "key", "allowed"),
    [
        ("scene.occlusion_fraction=0.95", "scene.occlusion_fraction", "less than or equal to 0.9"),
        ("scene.cloth_ids=[0, 3]", "scene.cloth_ids.0", "greater than or equal to 1"),
        ("scene.cloth_ids=[13]", "scene.cloth_ids.0", "less than or equal to 12"),
        ("trials=0", "trials", "greater than or equal to 1"),
        ("scene.x_range_m=[-0.4, 0.1]", "scene.x_range_m", "510 mm"),
        ("scene.yaw_range_deg=[90, -90]", "scene.yaw_range_deg", "low <= high"),
        ("source=camera", "source", "'synthetic' or 'sim'"),
        ("scene.distractor=banana", "scene.distractor", "random"),
    ],
)
def test_out_of_range_values_name_key_and_allowed(override: str, key: str, allowed: str) -> None:
    error = _error({}, override)
    assert error.key == key and allowed in error.problems[0].problem


def test_distractor_must_not_be_a_target() -> None:
    error = _error({"scene": {"cloth_ids": [3, 4], "distractor": 4}})
    assert error.key == "scene" and "distractor No.4" in error.problems[0].problem


def test_unknown_kind_lists_the_kinds() -> None:
    error = _error({"kind": "juggling"})
    assert (error.key, error.value) == ("kind", "juggling")
    assert error.expected is not None and "pick_place" in error.expected and "recognition" in error.expected


def test_kind_selects_the_model() -> None:
    assert isinstance(parse_trial_config({"kind": "pick_place"}), PickPlaceTrialConfig)
    assert isinstance(parse_trial_config({}), RecognitionTrialConfig)
    assert _error({"kind": "pick_place", "peaks": True}).key == "peaks"


def test_sweep_key_and_values_are_checked() -> None:
    assert _error({"sweep": {"key": "trials", "values": [1]}}).key == "sweep.key"
    assert _error({"sweep": {"key": "scene.occlusion_fraction", "values": []}}).key == "sweep.values"
    error = _error({"sweep": {"key": "scene.occlusion_fraction", "values": [0.1, 2.0]}})
    assert error.key == "scene.occlusion_fraction" and "0.9" in str(error)


def test_sweep_points_and_labels() -> None:
    config = parse_trial_config({"sweep": {"key": "scene.occlusion_fraction", "values": [0.0, 0.3]}})
    assert config.point_count == 2
    assert config.at_point(1).scene.occlusion_fraction == 0.3
    assert config.sweep_label(1) == "scene.occlusion_fraction=0.3"
    with pytest.raises(ValueError, match="out of range"):  # the sweep's own loops never ask for it
        config.at_point(2)


def test_overrides_and_hash() -> None:
    base = load_trial_config(CONFIGS / "default.yaml")
    more = load_trial_config(CONFIGS / "default.yaml", ["trials=5000"])
    other = load_trial_config(CONFIGS / "default.yaml", ["scene.occlusion_fraction=0.2"])
    assert more.trials == 5000 and more.config_hash() == base.config_hash()
    assert other.scene.occlusion_fraction == 0.2 and other.config_hash() != base.config_hash()
    with pytest.raises(ConfigError) as no_value:
        load_trial_config(CONFIGS / "default.yaml", ["trials"])
    assert no_value.value.key == "trials" and no_value.value.expected == "key.path=value"


def test_cli_bad_config_exits_2_naming_the_key(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    config = tmp_path / "bad.yaml"
    config.write_text("kind: recognition\nscene:\n  occlusion_fraction: 1.5\n")
    code = main(["trial", str(config), "--out", str(tmp_path / "out"), "--no-progress"])
    assert code == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and "scene.occlusion_fraction" in err
    assert not (tmp_path / "out").exists()
    assert main(["trial", str(tmp_path / "missing.yaml")]) == 2
    assert main(["trial", str(config), "--backend", "slurm"]) == 2


def test_recognition_overrides_are_checked_before_any_trial(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "out"
    bad_key = "recognition.propose.ga.generationz=3"
    code = main(["trial", str(CONFIGS / "default.yaml"), "--out", str(out), "--set", bad_key])
    assert code == 2 and "ga.generationz: unknown key" in capsys.readouterr().err
    code = main(["trial", str(CONFIGS / "ga_sweep.yaml"), "--out", str(out), "--set", "sweep.values=[10, 0]"])
    assert code == 2 and "ga.generations" in capsys.readouterr().err
    assert not (out / "trials.csv").exists()
