"""Typed trial configs: what a sweep of recognition or pick-and-place trials runs.

A trial config is one YAML file. Its `kind` selects the model (`recognition` or
`pick_place`); every other key is checked by pydantic, so an unknown key, a wrong type
or an out-of-range value is a `ConfigError` naming the key and what is allowed.

An optional `sweep` varies one setting over a list of values: trial i runs at sweep
point i % len(values) on scene i // len(values), so every value sees the same scenes
(common random numbers) and extending `trials` never renumbers finished trials.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import Field, field_validator, model_validator

from robot_app.config import StrictModel, apply_overrides, read_yaml, validate
from robot_app.errors import ConfigError

CLOTH_COUNT = 12
"""Number of sample cloths in the catalogue (No.1 - No.12, paper Fig. 10)."""

ClothId = Annotated[int, Field(ge=1, le=CLOTH_COUNT)]

NOT_IN_HASH = ("trials", "record")
"""Config keys that do not decide a trial's result (a sweep resumed with other values goes on)."""


class TrialSceneSettings(StrictModel):
    """The static scene of one trial, drawn from the trial's seed.

    Attributes:
        cloth_ids: target cloths; trial scene k uses cloth_ids[k % len(cloth_ids)].
        x_range_m: range of the target centre's x in the recognition area [m].
        y_range_m: range of the target centre's y [m].
        yaw_range_deg: range of the target's yaw [deg].
        occlusion_fraction: share of the target hidden by the blue occluder [0-0.9].
        distractor: a second cloth beside the target: None, a cloth id, or "random".
        absent_target: leave the target out (only the distractor, if any, is there).
        drop_height_m: height the soft cloth is dropped from, to wrinkle it [m].
    """

    cloth_ids: list[ClothId] = Field(default_factory=lambda: list(range(1, CLOTH_COUNT + 1)), min_length=1)
    x_range_m: tuple[float, float] = (-0.10, 0.10)
    y_range_m: tuple[float, float] = (-0.08, 0.08)
    yaw_range_deg: tuple[float, float] = (-180.0, 180.0)
    occlusion_fraction: float = Field(default=0.0, ge=0.0, le=0.9)
    distractor: ClothId | Literal["random"] | None = None
    absent_target: bool = False
    drop_height_m: float = Field(default=0.0, ge=0.0, le=0.5)

    @field_validator("x_range_m", "y_range_m")
    @classmethod
    def _position_range(cls, value: tuple[float, float]) -> tuple[float, float]:
        low, high = value
        if not -0.255 <= low <= high <= 0.255:
            raise ValueError("must be [low, high] with -0.255 <= low <= high <= 0.255 m (the 510 mm area)")
        return value

    @field_validator("distractor", mode="before")
    @classmethod
    def _distractor_value(cls, value: Any) -> Any:
        valid_id = isinstance(value, int) and not isinstance(value, bool) and 1 <= value <= CLOTH_COUNT
        if value is None or value == "random" or valid_id:
            return value
        raise ValueError(f"must be null, 'random' or a cloth No. 1-{CLOTH_COUNT}")

    @model_validator(mode="after")
    def _distractor_not_a_target(self) -> TrialSceneSettings:
        if isinstance(self.distractor, int) and self.distractor in self.cloth_ids:
            raise ValueError(
                f"distractor No.{self.distractor} is also in cloth_ids; it must differ from every target"
            )
        return self

    @field_validator("yaw_range_deg")
    @classmethod
    def _yaw_range(cls, value: tuple[float, float]) -> tuple[float, float]:
        low, high = value
        if not -180.0 <= low <= high <= 180.0:
            raise ValueError("must be [low, high] with -180 <= low <= high <= 180 deg")
        return value


class SweepSettings(StrictModel):
    """One setting varied over values, e.g. key 'recognition.generations'.

    Attributes:
        key: dotted config key under `recognition.`, `scene.` or `pick_place.`.
        values: the values, each validated as if set with `--set key=value`.
    """

    key: str
    values: list[Any] = Field(min_length=1, max_length=100)

    @field_validator("key")
    @classmethod
    def _key_section(cls, value: str) -> str:
        if value.split(".")[0] not in ("recognition", "scene", "pick_place") or "." not in value:
            raise ValueError("must be a dotted key under recognition., scene. or pick_place.")
        return value


class _TrialConfigBase(StrictModel):
    """Keys shared by every trial kind.

    Attributes:
        name: label used in reports and the default results folder.
        trials: number of trials (scenes x sweep points).
        seed: base seed; trial i's seed derives from (seed, i) only.
        source: image source: `synthetic` (fast renderer) or `sim` (pybullet world).
        scene: the scene section.
        sweep: optional one-key sweep.
    """

    name: str = Field(default="trial", min_length=1, max_length=80, pattern=r"^[A-Za-z0-9_.-]+$")
    trials: int = Field(default=100, ge=1, le=1_000_000)
    seed: int = Field(default=0, ge=0, le=2**63 - 1)
    source: Literal["synthetic", "sim"] = "synthetic"
    scene: TrialSceneSettings = Field(default_factory=TrialSceneSettings)
    sweep: SweepSettings | None = None

    @model_validator(mode="after")
    def _sweep_points_valid(self) -> _TrialConfigBase:
        if self.sweep is not None:
            for index in range(len(self.sweep.values)):
                self.at_point(index)
        return self

    @property
    def point_count(self) -> int:
        """Number of sweep points (1 without a sweep)."""
        return 1 if self.sweep is None else len(self.sweep.values)

    def at_point(self, point: int) -> _TrialConfigBase:
        """The config with the sweep key set to its `point`-th value (and no sweep)."""
        if self.sweep is None:
            return self
        if not 0 <= point < len(self.sweep.values):
            raise ValueError(f"sweep point {point} out of range [0, {len(self.sweep.values)})")
        data = self.model_dump(mode="json")
        data.pop("sweep")
        value = self.sweep.values[point]
        data = apply_overrides(data, [f"{self.sweep.key}={json.dumps(value)}"])
        return validate(type(self), data, f"sweep {self.sweep.key}={value!r}")

    def sweep_label(self, point: int) -> str:
        """Human label of a sweep point, e.g. 'recognition.generations=50' ('' without sweep)."""
        if self.sweep is None:
            return ""
        return f"{self.sweep.key}={json.dumps(self.sweep.values[point])}"

    def config_hash(self) -> str:
        """Stable hash of everything that decides the trials' results, except `trials`.

        Leaving `trials` out lets a finished sweep be extended by resuming with more;
        `record` (which episodes keep a recording) does not change a result either.
        """
        data = self.model_dump(mode="json")
        for key in NOT_IN_HASH:
            data.pop(key, None)
        text = json.dumps(data, sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()[:16]


class RecognitionTrialConfig(_TrialConfigBase):
    """A static scene seen from the observation pose; recognise; compare with ground truth.

    Attributes:
        recognition: overrides of the recogniser's settings (population, generations,
            acceptance threshold, ...), checked against its settings model at start.
        peaks: also record the second fitness peak (for the two-cloth experiment).
        tolerance_mm: a found target counts as a success if |x|, |y| errors are within [mm].
        tolerance_deg: ... and the yaw error is within [deg] (paper: ±10 mm, ±10°).
    """

    kind: Literal["recognition"] = "recognition"
    recognition: dict[str, Any] = Field(default_factory=dict)
    peaks: bool = False
    tolerance_mm: float = Field(default=10.0, gt=0.0, le=500.0)
    tolerance_deg: float = Field(default=10.0, gt=0.0, le=180.0)


class PickPlaceTrialConfig(_TrialConfigBase):
    """A full pick-and-place episode per trial (the closed loop of control/pick_place.py).

    Attributes:
        recognition: overrides of the recogniser's settings.
        pick_place: overrides of the pick-and-place loop's settings.
        record: which episodes keep a Rerun recording in the results folder's
            `recordings/` (its `recording` column names the file): `none`, `failures`
            (the default: every failed episode can be replayed) or `all`. Needs the
            `viewer` extra; without it the default is skipped with a warning.
    """

    kind: Literal["pick_place"] = "pick_place"
    source: Literal["synthetic", "sim"] = "sim"
    recognition: dict[str, Any] = Field(default_factory=dict)
    pick_place: dict[str, Any] = Field(default_factory=dict)
    record: Literal["none", "failures", "all"] = "failures"


TrialConfig = Annotated[RecognitionTrialConfig | PickPlaceTrialConfig, Field(discriminator="kind")]
"""Any trial config; `kind` says which."""

TRIAL_KINDS: dict[str, type[_TrialConfigBase]] = {
    "recognition": RecognitionTrialConfig,
    "pick_place": PickPlaceTrialConfig,
}


AnyTrialConfig = RecognitionTrialConfig | PickPlaceTrialConfig
"""The union as a plain type, for signatures."""


def parse_trial_config(data: dict[str, Any], source: str = "config") -> AnyTrialConfig:
    """Validates a mapping into the trial config its `kind` names.

    Raises:
        ConfigError: unknown kind, unknown key, wrong type or out-of-range value.
    """
    kind = data.get("kind", "recognition")
    model = TRIAL_KINDS.get(kind) if isinstance(kind, str) else None
    if model is None:
        raise ConfigError(
            f"kind: must be one of {sorted(TRIAL_KINDS)} (got {kind!r}) [in {source}]",
            key="kind",
            value=kind,
            expected=f"one of {sorted(TRIAL_KINDS)}",
        )
    result = validate(model, data, source)
    if not isinstance(result, RecognitionTrialConfig | PickPlaceTrialConfig):  # pragma: no cover
        raise ConfigError(f"kind: {kind!r} is not a trial kind [in {source}]", key="kind", value=kind)
    return result


def load_trial_config(path: str | Path, overrides: list[str] | tuple[str, ...] = ()) -> AnyTrialConfig:
    """Reads a trial config YAML, applies `--set key=value` overrides and validates it.

    A config without `name` is named after its file (configs/occlusion.yaml -> occlusion).
    """
    data = read_yaml(path)
    data.setdefault("name", Path(path).stem)
    return parse_trial_config(apply_overrides(data, overrides), str(path))


__all__ = [
    "CLOTH_COUNT",
    "NOT_IN_HASH",
    "AnyTrialConfig",
    "PickPlaceTrialConfig",
    "RecognitionTrialConfig",
    "SweepSettings",
    "TrialConfig",
    "TrialSceneSettings",
    "load_trial_config",
    "parse_trial_config",
]
