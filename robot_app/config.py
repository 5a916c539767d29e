"""Typed configuration: pydantic models, YAML loading and `--set key=value` overrides.

Every subsystem declares its own settings as a `StrictModel` next to the code that uses
them; `load_config` reads a YAML file into any such model, applies dotted overrides and
turns pydantic's validation errors into one `ConfigError` that names each bad key and
what would be valid. A check across keys (a model validator) raises `SettingValueError`
to name the key it is about: pydantic itself would name only the section.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, TypeVar

import yaml
from pydantic import BaseModel, ConfigDict, ValidationError

from robot_app.console import warn_input
from robot_app.errors import ConfigError, ConfigProblem
from robot_app.outputs import atomic_write_text

ModelT = TypeVar("ModelT", bound=BaseModel)


class StrictModel(BaseModel):
    """Base of all config sections: unknown keys are errors, values are immutable."""

    model_config = ConfigDict(extra="forbid", frozen=True, validate_default=True)


class SettingValueError(ValueError):
    """A settings validator's complaint about one key of its section.

    Raised in a model validator (a check across keys), it makes the `ConfigProblem`
    name `key` below the section and carry `value`, where pydantic would name only the
    section and the whole section's input.

    Args:
        key: the key within the validated section, dotted if deeper ('search.min_value').
        message: what was wrong and what would be valid.
        value: the value given for `key`.
    """

    def __init__(self, key: str, message: str, value: Any) -> None:
        super().__init__(message)
        self.key = key
        self.value = value


def read_yaml(path: str | Path) -> dict[str, Any]:
    """Reads a YAML mapping from `path`; an empty file is an empty mapping (with a warning)."""
    file = Path(path)
    if file.is_dir():
        raise ConfigError(
            f"config file {file} is a folder, not a YAML file", path=file, expected="a YAML file"
        )
    if not file.is_file():
        raise ConfigError(f"config file not found: {file}", path=file, expected="an existing YAML file")
    try:
        data = yaml.safe_load(file.read_text())
    except (yaml.YAMLError, UnicodeDecodeError) as err:
        problem = str(err).replace("\n", " ")
        raise ConfigError(f"{file} is not valid YAML: {problem}", path=file, expected="YAML text") from err
    except OSError as err:
        raise ConfigError(f"cannot read config file {file}: {err.strerror}", path=file) from err
    if data is None:
        warn_input(f"config file {file} is empty: every setting keeps its default", path=file)
        return {}
    if not isinstance(data, dict):
        raise ConfigError(
            f"{file} must hold a mapping at the top level, got {type(data).__name__}",
            path=file,
            value=data,
            expected="key: value lines",
        )
    return data


def parse_override(text: str) -> tuple[list[str], Any]:
    """Splits 'a.b.c=value' into (['a', 'b', 'c'], value), the value parsed as YAML."""
    key, sep, raw = text.partition("=")
    if not sep or not key.strip():
        raise ConfigError(
            f"--set {text!r} must look like key.path=value",
            key=key.strip() or None,
            expected="key.path=value",
        )
    try:
        value = yaml.safe_load(raw) if raw.strip() else ""
    except yaml.YAMLError as err:
        raise ConfigError(
            f"--set {text!r}: the value is not valid YAML",
            key=key.strip(),
            value=raw,
            expected="a YAML value",
        ) from err
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
                raise ConfigError(
                    f"--set {text!r}: {part!r} is a value, not a section", key=".".join(path), value=value
                )
            node = child
        node[path[-1]] = value
    return result


def validate(model_cls: type[ModelT], data: dict[str, Any], source: str = "config") -> ModelT:
    """Validates `data` into `model_cls`, raising `ConfigError` naming every bad key."""
    try:
        return model_cls.model_validate(data)
    except ValidationError as err:
        problems = validation_problems(err)
        raise ConfigError(format_validation_error(err, source), problems=problems) from err


def load_config(
    model_cls: type[ModelT],
    path: str | Path | None = None,
    overrides: list[str] | tuple[str, ...] = (),
) -> ModelT:
    """Loads `path` (or the model's defaults if None), applies overrides, validates."""
    data = read_yaml(path) if path is not None else {}
    source = str(path) if path is not None else "settings"
    if overrides:
        source += " with --set " + " ".join(overrides) if path is not None else " (--set)"
    try:
        return validate(model_cls, apply_overrides(data, overrides), source)
    except ConfigError as err:
        if path is not None and err.path is None:
            err.path = Path(path)
        raise


def dump_config(config: BaseModel, path: str | Path) -> None:
    """Writes the resolved config as YAML, atomically (round-trips through `load_config`)."""
    atomic_write_text(path, yaml.safe_dump(config.model_dump(mode="json"), sort_keys=False))


def validation_problems(err: ValidationError) -> tuple[ConfigProblem, ...]:
    """Each bad key of a pydantic validation error: dotted key, what was wrong, value given."""
    problems = []
    for problem in err.errors():
        parts = [str(part) for part in problem["loc"]]
        value = problem.get("input")
        cause = problem.get("ctx", {}).get("error")
        if isinstance(cause, SettingValueError):  # a check across keys names its key
            parts.append(cause.key)
            value = cause.value
        key = ".".join(parts) or "<top level>"
        if problem["type"] == "extra_forbidden":
            problems.append(ConfigProblem(key, "unknown key", value))
        else:
            problems.append(ConfigProblem(key, str(problem["msg"]), value))
    return tuple(problems)


def format_validation_error(err: ValidationError, source: str) -> str:
    """The first line names the first bad key (the one a user reads); one line per further problem.

    'key.path: what was wrong (got value) [in source]'.
    """
    lines = []
    for i, problem in enumerate(validation_problems(err)):
        got = "" if problem.problem == "unknown key" else f" (got {problem.value!r})"
        where = f" [in {source}]" if i == 0 else ""
        lines.append(f"{'' if i == 0 else '  '}{problem.key}: {problem.problem}{got}{where}")
    return "\n".join(lines)


def _deep_copy(data: dict[str, Any]) -> dict[str, Any]:
    return {k: _deep_copy(v) if isinstance(v, dict) else v for k, v in data.items()}


__all__ = [
    "SettingValueError",
    "StrictModel",
    "apply_overrides",
    "dump_config",
    "format_validation_error",
    "load_config",
    "parse_override",
    "read_yaml",
    "validate",
    "validation_problems",
]
