"""What `robot-app paper` runs (`PaperConfig`), and everything checked before it runs.

`check_paper` validates the workers, the report folder (new, empty, or a report of the
same settings, which is resumed), the folders of its two trial sweeps, and the size of
the Fig. 13 full searches and of the sweeps, so a rejected run writes nothing.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from pydantic import Field

from robot_app.config import StrictModel, apply_overrides, read_yaml, validate
from robot_app.errors import ConfigError, OutputError
from robot_app.experiments.experiment_config import (
    CLOTH_COUNT,
    ClothId,
    RecognitionTrialConfig,
    parse_trial_config,
)
from robot_app.experiments.identification_trial import IdentificationOutcome
from robot_app.experiments.recognition_trial import RecognitionOutcome
from robot_app.experiments.trials import check_sweep
from robot_app.outputs import check_output_folder
from robot_app.resources import (
    MAX_FULL_SEARCH_EVALUATIONS,
    ResourceLimits,
    check_workers,
    full_search_estimate,
)
from robot_app.vision.recognizer import RecognitionSettings


class Fig13Settings(StrictModel):
    """The full search and GA of Fig. 13.

    Attributes:
        step_m: grid step of the full search [m] (paper: every pixel).
        yaw_step_deg: the yaw grid of the full search [deg].
        population: GA individuals.
        generations: GA generations (paper: 100).
    """

    step_m: float = Field(default=0.002, ge=0.0005, le=0.02)
    yaw_step_deg: float = Field(default=10.0, ge=1.0, le=90.0)
    population: int = Field(default=100, ge=4, le=2000)
    generations: int = Field(default=100, ge=1, le=2000)


class PaperConfig(StrictModel):
    """What `robot-app paper` runs.

    Attributes:
        source: image source, synthetic or sim.
        seed: base seed of every scene and GA run.
        fig13: full search and GA settings of Fig. 13.
        fig12_trials: recognitions for the error histograms (paper: 1000).
        identification_cloths: cloths of the identification matrix (paper: all 12).
        recognition: overrides of the recogniser's settings for all recognitions.
        tolerance_mm: the paper's position bound [mm] drawn on the histograms.
        tolerance_deg: the paper's angle bound [deg].
    """

    source: str = Field(default="synthetic", pattern="^(synthetic|sim)$")
    seed: int = Field(default=2016, ge=0)
    fig13: Fig13Settings = Field(default_factory=Fig13Settings)
    fig12_trials: int = Field(default=1000, ge=12, le=100_000)
    identification_cloths: list[ClothId] = Field(
        default_factory=lambda: list(range(1, CLOTH_COUNT + 1)), min_length=2
    )
    recognition: dict[str, Any] = Field(default_factory=dict)
    tolerance_mm: float = Field(default=10.0, gt=0)
    tolerance_deg: float = Field(default=10.0, gt=0)


QUICK = {
    "fig13": {"step_m": 0.006, "yaw_step_deg": 30.0, "population": 60, "generations": 40},
    "fig12_trials": 24,
    "identification_cloths": [2, 3, 4, 9],
    "recognition": {},
}
"""The `--quick` version: a small run for tests (about a minute)."""


def load_paper_config(
    quick: bool = False, source: str = "synthetic", overrides: list[str] | None = None
) -> PaperConfig:
    """The paper settings, quick or full, with `--set key=value` overrides.

    Raises:
        ConfigError: an unknown key or a bad value, named.
    """
    data: dict[str, Any] = {"source": source, **(QUICK if quick else {})}
    return validate(PaperConfig, apply_overrides(data, overrides or []), "paper settings")


def sweep_configs(settings: PaperConfig) -> tuple[RecognitionTrialConfig, RecognitionTrialConfig]:
    """The trial configs of Fig. 12 and of the identification matrix."""
    common: dict[str, Any] = {"source": settings.source, "recognition": settings.recognition}
    fig12_data = {"name": "fig12", "trials": settings.fig12_trials, "seed": settings.seed, **common}
    fig12_data |= {"tolerance_mm": settings.tolerance_mm, "tolerance_deg": settings.tolerance_deg}
    ids = list(settings.identification_cloths)
    ident_data = {"name": "identification", "trials": len(ids) ** 2, "seed": settings.seed + 1}
    configs = (
        parse_trial_config(fig12_data, "fig12"),
        parse_trial_config({**ident_data, "scene": {"cloth_ids": ids}, **common}, "identification"),
    )
    if not all(isinstance(c, RecognitionTrialConfig) for c in configs):  # pragma: no cover
        raise ConfigError("the paper's trials must be recognition trials")
    return configs  # type: ignore[return-value]


def check_paper(settings: PaperConfig, out: Path, workers: int, limits: ResourceLimits) -> None:
    """Everything `run_paper` checks before it writes anything: workers, the report folder
    (new, empty, or a report of these same settings, which is resumed), the sweeps'
    folders, and the full searches' and sweeps' sizes.

    Raises:
        InputError, OutputError, ResourceError: named, before any work.
    """
    check_workers(limits, workers, settings.source)
    config_file = out / "config.yaml"
    resumable = False
    if config_file.is_file():
        try:
            previous = validate(PaperConfig, read_yaml(config_file), str(config_file))
        except ConfigError:
            previous = None
        if previous != settings:
            raise OutputError(
                f"--out {out} holds a report of other settings ({config_file} differs); "
                "choose another --out (or rerun with the same settings to resume)",
                path=out,
                key="--out",
                value=str(out),
            )
        resumable = True
    check_output_folder(out, key="--out", resumable=resumable)
    fig13 = settings.fig13
    yaws = len(np.arange(-180.0, 180.0, fig13.yaw_step_deg))
    bounds = RecognitionSettings().propose.bounds
    cells, evaluations, memory = full_search_estimate(bounds.x, bounds.y, fig13.step_m, yaws)
    limits.check_memory(
        memory, key="fig13.step_m", value=fig13.step_m, what=f"a full-search grid of {cells:,} cells"
    )
    limits.check_count(
        3 * evaluations,
        MAX_FULL_SEARCH_EVALUATIONS,
        key="fig13.step_m",
        value=f"{fig13.step_m} (fig13.yaw_step_deg {fig13.yaw_step_deg})",
        what="poses over the three Fig. 13 full searches",
    )
    fig12_config, ident_config = sweep_configs(settings)
    check_sweep(
        fig12_config,
        RecognitionOutcome,
        out / "fig12",
        workers=workers,
        limits=limits,
        trials_key="fig12_trials",
    )
    check_sweep(
        ident_config, IdentificationOutcome, out / "identification", workers=workers, limits=limits,
        trials_key="identification_cloths",
    )  # fmt: skip


__all__ = ["QUICK", "Fig13Settings", "PaperConfig", "check_paper", "load_paper_config", "sweep_configs"]
