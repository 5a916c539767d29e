"""The `pick_place` trial kind: one full closed-loop episode per trial.

The trial config's `pick_place` section holds overrides of the episode's config
(`PickPlaceConfig`: world, loop, filter, trajectory, ...); its `scene` section chooses
the target (cloth_ids[k % n]), the blue paper, the distractor and the drop height, and
`absent_target` asks for a cloth that is not on the table. The simulator places the
cloths itself (inside the recognition range), so `x_range_m`, `y_range_m` and
`yaw_range_deg` do not apply here. The trial's seed seeds the scene and the GA.

With `record: failures` (the default) or `all`, each episode is recorded (Rerun, the
`viewer` extra) into the results folder's `recordings/`; a successful episode's
recording is deleted under `failures`, and the row's `recording` column names the file
that was kept, so a failed trial of a thousand can be replayed (`rerun FILE.rrd`).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from robot_app.config import apply_overrides, validate
from robot_app.console import warn_input
from robot_app.errors import InputError
from robot_app.experiments.experiment_config import CLOTH_COUNT, PickPlaceTrialConfig
from robot_app.experiments.recording import require_rerun

RECORDINGS_FOLDER = "recordings"

NAN = float("nan")


@dataclass(frozen=True)
class PickPlaceOutcome:
    """One episode (a CSV row).

    Attributes:
        cloth_id: the cloth the robot was asked to pick.
        present: that cloth was on the table.
        outcome: how the loop ended (its Outcome value).
        success: in the box (>= 90% of its nodes) without collisions, or correctly
            reported absent.
        loop_reason: the loop's reason text.
        placed_fraction: share of the cloth's nodes inside the box.
        grasp_attempts: grasps tried.
        observe_returns: returns to the observation pose.
        collisions: arm contacts with the table or box.
        recognitions: recognitions run during the episode.
        error_x_mm, error_y_mm, error_z_mm, error_yaw_deg: error of the first recognition
            against the simulator's truth (NaN if unknown).
        sim_time_s: simulated duration [s].
        episode_wall_s: wall time of the loop [s].
        recording: the episode's recording, relative to the results folder ("" if none kept).
    """

    cloth_id: int
    present: bool
    outcome: str
    success: bool
    loop_reason: str
    placed_fraction: float
    grasp_attempts: int
    observe_returns: int
    collisions: int
    recognitions: int
    error_x_mm: float
    error_y_mm: float
    error_z_mm: float
    error_yaw_deg: float
    sim_time_s: float
    episode_wall_s: float
    recording: str = ""


def episode_config(config: PickPlaceTrialConfig, scene_index: int, seed: int) -> Any:
    """The `PickPlaceConfig` of one trial.

    Raises:
        ConfigError: a `pick_place` override the episode's config does not accept.
    """
    from robot_app.experiments.pick_place_episode import PickPlaceConfig

    rng = np.random.default_rng(seed)
    scene = config.scene
    wanted = scene.cloth_ids[scene_index % len(scene.cloth_ids)]
    others = [k for k in range(1, CLOTH_COUNT + 1) if k != wanted]
    distractor = scene.distractor
    if distractor == "random":
        distractor = int(others[int(rng.integers(len(others)))])
    on_table = int(others[int(rng.integers(len(others)))]) if scene.absent_target else wanted
    if scene.absent_target and distractor == on_table:
        distractor = None
    scene_data = {
        "target": on_table,
        "occluder": scene.occlusion_fraction > 0,
        "occluded_fraction": scene.occlusion_fraction,
        "distractor": distractor,
        "drop_height": scene.drop_height_m,
    }
    settings = [f"{key}={json.dumps(value)}" for key, value in scene_data.items()]
    data = apply_overrides(dict(config.pick_place), [f"scene.{s}" for s in settings])
    data = apply_overrides(data, [f"recognition.{k}={json.dumps(v)}" for k, v in config.recognition.items()])
    data = apply_overrides(data, [f"seed={seed % 2**31}", f"model_cloth={wanted}"])
    return validate(PickPlaceConfig, data, "pick_place episode config (config keys 'pick_place', 'scene')")


def check_pick_place_config(config: PickPlaceTrialConfig) -> None:
    """Validates the episode config of the first trial up front."""
    episode_config(config, 0, 0)


def recordings_folder(config: PickPlaceTrialConfig, out_dir: str | Path) -> Path | None:
    """Where the trials of `config` keep their recordings, or None (`record: none`).

    Raises:
        InputError: `record` was set in the config but rerun-sdk is not installed. Left at
            its default (`failures`) without the extra, a warning says no recordings are kept.
    """
    if config.record == "none":
        return None
    try:
        require_rerun(key="record")
    except InputError as err:
        if "record" in config.model_fields_set:
            raise
        warn_input(f"no recordings of failed episodes: {err}", key="record")
        return None
    return Path(out_dir) / RECORDINGS_FOLDER


def run_pick_place_trial(
    config: PickPlaceTrialConfig, scene_index: int, seed: int, recordings: Path | None = None
) -> PickPlaceOutcome:
    """One closed-loop episode in a fresh simulated cell; deterministic in its seed.

    Args:
        config: the trial config at its sweep point.
        scene_index: the trial's scene (its target is `scene.cloth_ids[scene_index % n]`).
        seed: the trial's seed.
        recordings: folder for the episode's recording (see `recordings_folder`), or None.
    """
    from robot_app.experiments.pick_place_episode import run_episode

    path = None
    if recordings is not None and config.record != "none":
        path = Path(recordings) / f"scene{scene_index:06d}-{config.config_hash()[:8]}.rrd"
    episode = run_episode(episode_config(config, scene_index, seed), record_path=path)
    result = episode.result
    kept = ""
    if path is not None and path.is_file():
        if config.record == "failures" and result.success:
            path.unlink()
        else:
            kept = f"{RECORDINGS_FOLDER}/{path.name}"
    first = result.recognitions[0] if result.recognitions else None

    def error(name: str) -> float:
        value = getattr(first, name, None) if first is not None else None
        return NAN if value is None else float(value)

    return PickPlaceOutcome(
        cloth_id=episode.target,
        present=episode.present,
        outcome=str(result.outcome.value),
        success=bool(result.success),
        loop_reason=result.reason,
        placed_fraction=NAN if result.placed_fraction is None else float(result.placed_fraction),
        grasp_attempts=int(result.grasp_attempts),
        observe_returns=int(result.observe_returns),
        collisions=int(result.collisions),
        recognitions=len(result.recognitions),
        error_x_mm=error("error_x_mm"),
        error_y_mm=error("error_y_mm"),
        error_z_mm=error("error_z_mm"),
        error_yaw_deg=error("error_yaw_deg"),
        sim_time_s=float(result.sim_time),
        episode_wall_s=float(result.wall_s),
        recording=kept,
    )


__all__ = [
    "RECORDINGS_FOLDER",
    "PickPlaceOutcome",
    "check_pick_place_config",
    "episode_config",
    "recordings_folder",
    "run_pick_place_trial",
]
