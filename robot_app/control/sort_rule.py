"""The sort rule: which collection box each known cloth goes into.

A rule names, for some boxes, the cloths that belong there (by model name, e.g. "No.17",
or a catalogue number); every other known cloth goes into the `default` box:

```yaml
sort:
  default: colours
  boxes:
    whites: [6, 17, 18]
```
"""

from __future__ import annotations

from typing import Any

from pydantic import Field, field_validator, model_validator

from robot_app.config import StrictModel
from robot_app.errors import ConfigError


def cloth_name(number: int) -> str:
    """The model name of catalogue cloth No.`number`."""
    return f"No.{number}"


class SortSettings(StrictModel):
    """Cloth identity -> box name.

    Attributes:
        default: the box of every cloth no entry of `boxes` names.
        boxes: box name -> the cloths that go there (catalogue numbers or model names).
    """

    default: str = Field("box", min_length=1)
    boxes: dict[str, tuple[str, ...]] = Field(default_factory=dict)

    @field_validator("boxes", mode="before")
    @classmethod
    def _names(cls, value: Any) -> Any:
        """Catalogue numbers become model names ("No.n")."""
        if not isinstance(value, dict):
            return value
        return {
            box: [cloth_name(c) if isinstance(c, int) and not isinstance(c, bool) else c for c in cloths]
            if isinstance(cloths, list | tuple)
            else cloths
            for box, cloths in value.items()
        }

    @model_validator(mode="after")
    def _each_cloth_once(self) -> SortSettings:
        seen: dict[str, str] = {}
        for box, cloths in self.boxes.items():
            for cloth in cloths:
                if cloth in seen and seen[cloth] != box:
                    raise ValueError(f"{cloth} is sorted into two boxes: {seen[cloth]} and {box}")
                seen[cloth] = box
        return self

    def box_for(self, name: str) -> str:
        """The box the cloth `name` (e.g. "No.17") goes into."""
        for box, cloths in self.boxes.items():
            if name in cloths:
                return box
        return self.default

    def check_boxes(self, box_names: tuple[str, ...], key: str = "sort") -> None:
        """Every box the rule names exists in the cell.

        Raises:
            ConfigError: a box the rule sorts into is not one of `box_names`.
        """
        for box in (self.default, *self.boxes):
            if box not in box_names:
                raise ConfigError(
                    f"{key}: box {box!r} is not in the cell (world.boxes: {', '.join(box_names)})",
                    key=key,
                    value=box,
                    expected=", ".join(box_names),
                )

    def check_cloths(self, cloth_names: tuple[str, ...], key: str = "sort") -> None:
        """Every cloth the rule names is one the job could meet (a misspelt name or a number
        outside the catalogue would otherwise be silently never sorted).

        Raises:
            ConfigError: a cloth of `boxes` is not one of `cloth_names`.
        """
        for box, cloths in self.boxes.items():
            for cloth in cloths:
                if cloth not in cloth_names:
                    raise ConfigError(
                        f"{key}.boxes.{box}: {cloth} is not a cloth of the catalogue "
                        f"({cloth_names[0]}-{cloth_names[-1]})",
                        key=f"{key}.boxes.{box}",
                        value=cloth,
                        expected=", ".join(cloth_names),
                    )


__all__ = ["SortSettings", "cloth_name"]
