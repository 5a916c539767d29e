from pathlib import Path

import pytest
from pydantic import Field, model_validator

from robot_app.config import SettingValueError, StrictModel, apply_overrides, dump_config, load_config
from robot_app.errors import ConfigError


class Inner(StrictModel):
    rate_hz: float = Field(10.0, gt=0, le=100)


class Outer(StrictModel):
    name: str = "x"
    inner: Inner = Inner()


def test_defaults_and_overrides(tmp_path: Path) -> None:
    cfg = load_config(Outer, None, ["inner.rate_hz=20", "name=abc"])
    assert cfg.inner.rate_hz == 20.0 and cfg.name == "abc"
    path = tmp_path / "c.yaml"
    dump_config(cfg, path)
    assert load_config(Outer, path) == cfg


def test_unknown_key_wrong_type_and_range_name_the_key(tmp_path: Path) -> None:
    with pytest.raises(ConfigError) as unknown:
        load_config(Outer, None, ["inner.bogus=1"])
    assert unknown.value.key == "inner.bogus" and unknown.value.problems[0].problem == "unknown key"
    with pytest.raises(ConfigError) as wrong_type:
        load_config(Outer, None, ["inner.rate_hz=fast"])
    assert (wrong_type.value.key, wrong_type.value.value) == ("inner.rate_hz", "fast")
    with pytest.raises(ConfigError) as out_of_range:
        load_config(Outer, None, ["inner.rate_hz=1000", "name=[1]"])
    keys = {problem.key: problem.value for problem in out_of_range.value.problems}
    assert keys == {"inner.rate_hz": 1000, "name": [1]}
    assert (
        str(out_of_range.value).splitlines()[0].startswith(out_of_range.value.key)
    )  # the first line names it
    with pytest.raises(ConfigError) as missing:
        load_config(Outer, tmp_path / "missing.yaml")
    assert missing.value.path == tmp_path / "missing.yaml"
    with pytest.raises(ConfigError) as folder:
        load_config(Outer, tmp_path)
    assert folder.value.path == tmp_path and "folder" in str(folder.value)
    bad = tmp_path / "bad.yaml"
    bad.write_text("- a list\n")
    with pytest.raises(ConfigError) as not_mapping:
        load_config(Outer, bad)
    assert not_mapping.value.path == bad and not_mapping.value.value == ["a list"]
    in_file = tmp_path / "in_file.yaml"
    in_file.write_text("inner:\n  rate_hz: -1\n")
    with pytest.raises(ConfigError) as from_file:
        load_config(Outer, in_file)
    assert (from_file.value.path, from_file.value.key, from_file.value.value) == (
        in_file,
        "inner.rate_hz",
        -1,
    )


def test_override_syntax_errors() -> None:
    with pytest.raises(ConfigError) as no_value:
        apply_overrides({}, ["novalue"])
    assert no_value.value.key == "novalue" and no_value.value.expected == "key.path=value"
    with pytest.raises(ConfigError) as not_a_section:
        apply_overrides({"a": 1}, ["a.b=2"])
    assert (not_a_section.value.key, not_a_section.value.value) == ("a.b", 2)


class Window(StrictModel):
    low: float = 0.0
    high: float = 1.0

    @model_validator(mode="after")
    def _ordered(self) -> "Window":
        if not self.low < self.high:
            raise SettingValueError("high", "high must be above low", self.high)
        return self


class Holder(StrictModel):
    window: Window = Window()


def test_a_check_across_keys_names_its_key_below_the_section() -> None:
    with pytest.raises(ConfigError) as crossed:
        load_config(Holder, None, ["window.low=2", "window.high=1"])
    assert (crossed.value.key, crossed.value.value) == ("window.high", 1)
    assert str(crossed.value).startswith("window.high:")
    with pytest.raises(ConfigError) as alone:
        load_config(Window, None, ["high=-1"])
    assert (alone.value.key, alone.value.value) == ("high", -1)
