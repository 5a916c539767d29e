"""Typed configuration: pydantic models, YAML loading and `--set key=value` overrides.

Every subsystem declares its own settings as a `StrictModel` next to the code that uses
them; `load_config` reads a YAML file into any such model, applies dotted overrides and
turns pydantic's validation errors into one `ConfigError` that names each bad key and
what would be valid.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, TypeVar

import yaml
from pydantic import BaseModel, ConfigDict, ValidationError

from robot_app.errors import ConfigError

ModelT = TypeVar("ModelT", bound=BaseModel)


class StrictModel(BaseModel):
    """Base of all config sections: unknown keys are errors, values are immutable."""

    model_config = ConfigDict(extra="forbid", frozen=True, validate_default=True)


def read_yaml(path: str | Path) -> dict[str, Any]:
    """Reads a YAML mapping from `path`; an empty file is an empty mapping."""
    file = Path(path)
    if not file.is_file():
        raise ConfigError(f"config file not found: {file}")
    try:
        data = yaml.safe_load(file.read_text())
    except yaml.YAMLError as err:
        raise ConfigError(f"{file} is not valid YAML: {err}") from err
    if data is None:
        return {}
    if not isinstance(data, dict):
        raise ConfigError(f"{file} must hold a mapping at the top level, got {type(data).__name__}")
    return data


def parse_override(text: str) -> tuple[list[str], Any]:
    """Splits 'a.b.c=value' into (['a', 'b', 'c'], value), the value parsed as YAML."""
    key, sep, raw = text.partition("=")
    if not sep or not key.strip():
        raise ConfigError(f"override {text!r} must look like key.path=value")
    try:
        value = yaml.safe_load(raw) if raw.strip() else ""
    except yaml.YAMLError as err:
        raise ConfigError(f"override {text!r}: value is not valid YAML: {err}") from err
    return [part for part in key.strip().split(".")], value


def apply_overrides(data: dict[str, Any], overrides: list[str] | tuple[str, ...]) -> dict[str, Any]:
    """Returns a copy of `data` with each 'a.b=value' override set (nested dicts made)."""
    result: dict[str, Any] = _deep_copy(data)
    for text in overrides:
        path, value = parse_override(text)
        node = result
        for part in path[:-1]:
            child = node.get(part)
            if child is None:
                child = {}
                node[part] = child
            elif not isinstance(child, dict):
                raise ConfigError(f"override {text!r}: {part!r} is a value, not a section")
            node = child
        node[path[-1]] = value
    return result


def validate(model_cls: type[ModelT], data: dict[str, Any], source: str = "config") -> ModelT:
    """Validates `data` into `model_cls`, raising `ConfigError` naming every bad key."""
    try:
        return model_cls.model_validate(data)
    except ValidationError as err:
        raise ConfigError(format_validation_error(err, source)) from err


def load_config(
    model_cls: type[ModelT],
    path: str | Path | None = None,
    overrides: list[str] | tuple[str, ...] = (),
) -> ModelT:
    """Loads `path` (or the model's defaults if None), applies overrides, validates."""
    data = read_yaml(path) if path is not None else {}
    source = str(path) if path is not None else "defaults"
    return validate(model_cls, apply_overrides(data, overrides), source)


def dump_config(config: BaseModel, path: str | Path) -> None:
    """Writes the resolved config as YAML (round-trips through `load_config`)."""
    Path(path).write_text(yaml.safe_dump(config.model_dump(mode="json"), sort_keys=False))


def format_validation_error(err: ValidationError, source: str) -> str:
    """One readable line per problem: 'key.path: what was wrong (got value)'."""
    lines = [f"invalid {source}:"]
    for problem in err.errors():
        key = ".".join(str(part) for part in problem["loc"]) or "<top level>"
        if problem["type"] == "extra_forbidden":
            lines.append(f"  {key}: unknown key")
        else:
            lines.append(f"  {key}: {problem['msg']} (got {problem.get('input')!r})")
    return "\n".join(lines)


def _deep_copy(data: dict[str, Any]) -> dict[str, Any]:
    return {k: _deep_copy(v) if isinstance(v, dict) else v for k, v in data.items()}


__all__ = [
    "StrictModel",
    "apply_overrides",
    "dump_config",
    "format_validation_error",
    "load_config",
    "parse_override",
    "read_yaml",
    "validate",
]
