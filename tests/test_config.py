from pathlib import Path

import pytest
from pydantic import Field

from robot_app.config import StrictModel, apply_overrides, dump_config, load_config
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
    with pytest.raises(ConfigError, match=r"inner\.bogus: unknown key"):
        load_config(Outer, None, ["inner.bogus=1"])
    with pytest.raises(ConfigError, match=r"inner\.rate_hz"):
        load_config(Outer, None, ["inner.rate_hz=fast"])
    with pytest.raises(ConfigError, match=r"less than or equal to 100"):
        load_config(Outer, None, ["inner.rate_hz=1000"])
    with pytest.raises(ConfigError, match="not found"):
        load_config(Outer, tmp_path / "missing.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("- a list\n")
    with pytest.raises(ConfigError, match="mapping"):
        load_config(Outer, bad)


def test_override_syntax_errors() -> None:
    with pytest.raises(ConfigError):
        apply_overrides({}, ["novalue"])
    with pytest.raises(ConfigError, match="is a value"):
        apply_overrides({"a": 1}, ["a.b=2"])
