"""The clear-table results folder: config.yaml, cloths.csv, picks.csv, surveys.csv, summary.json.

`cloths.csv` has one row per cloth: every cloth of the pile (with where the simulator
found it at the end) and every cloth the robot identified that was not in the pile (a
misidentification). `summary.json` holds `cleared` (every known cloth in its box, judged
by the simulator), the `cause` when not, and what the robot did and noticed.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from robot_app.config import dump_config
from robot_app.experiments.clear_table import ClearTableConfig, ClearTableEpisode
from robot_app.outputs import atomic_write_csv, atomic_write_text, output_folder


def cloth_rows(episode: ClearTableEpisode) -> list[dict[str, object]]:
    """One row per cloth (see the module docstring), in drop order, then the others."""
    records = {r.name: r for r in episode.result.cloths}
    left = episode.result.left
    rows: list[dict[str, object]] = []
    for v in episode.verdict.cloths:
        r = records.pop(v.name, None)
        rows.append(
            {
                "identity": v.name,
                "known": v.known,
                "in_pile": True,
                "order": r.order if r is not None else None,
                "attempts": r.attempts if r is not None else 0,
                "box": v.expected,
                "sim_time_s": round(r.sim_time, 3) if r is not None else 0.0,
                "outcome": r.outcome.value if r is not None else "never identified",
                "final_place": v.final,
                "correct": v.correct,
                "notes": " | ".join((*(r.notes if r is not None else ()), *left.get(v.name, ()))),
                "over_rim": round(v.over_rim, 3),
            }
        )
    for r in records.values():  # identified by the robot, yet not in the pile
        rows.append(
            {
                "identity": r.name,
                "known": True,
                "in_pile": False,
                "order": r.order,
                "attempts": r.attempts,
                "box": r.box,
                "sim_time_s": round(r.sim_time, 3),
                "outcome": r.outcome.value,
                "final_place": "",
                "correct": r.order is None,
                "notes": " | ".join((*r.notes, *left.get(r.name, ()))),
                "over_rim": 0.0,
            }
        )
    return rows


def _millimetres(metres: float | None) -> float | str | None:
    if metres is None:
        return None
    return "inf" if np.isinf(metres) else round(1000 * metres, 1)


def pick_rows(episode: ClearTableEpisode) -> list[dict[str, object]]:
    """One row per pick attempt."""
    rows = []
    for k, a in enumerate(episode.result.attempts, start=1):
        check = a.box_check
        truth = [t for t in episode.lifts if a.start_time <= t.time <= a.end_time]
        rows.append(
            {
                "attempt": k,
                "identity": a.name,
                "box": a.box,
                "start_time": round(a.start_time, 3),
                "end_time": round(a.end_time, 3),
                "outcome": a.result.outcome.value,
                "reason": a.result.reason,
                "lift_check": a.lift_check,
                "weighed_g": None if a.weighed is None else round(1000 * a.weighed, 1),
                "expected_g": None if a.expected_weight is None else round(1000 * a.expected_weight, 1),
                "came_along": " ".join(f"{n} (memory)" if n in a.remembered else n for n in a.came_along),
                "named_by": a.named_by,
                "laid_back_too": " ".join(a.laid_back_too),
                "put_back": a.put_back,
                "dropped": a.dropped,
                "box_confirmed": None if check is None else check.confirmed,
                "box_changed": None if check is None else round(check.changed, 3),
                "box_model_share": None if check is None else round(check.model_share, 3),
                "grasp_clearance_mm": _millimetres(a.grasp_clearance),
                "limit_violations": a.result.limit_report.violations,
                "collisions": a.result.collisions,
                # the simulator's truth (as the verdict counts double picks): cloths that left
                # the table with each grasp of this attempt
                "lifted_truth": " | ".join(" ".join(f"No.{n}" for n in t.lifted) for t in truth),
                # ... and of those, the ones anchored to the fingers (the rest was dragged along)
                "held_truth": " | ".join(" ".join(f"No.{n}" for n in t.held) for t in truth),
            }
        )
    return rows


def survey_rows(episode: ClearTableEpisode) -> list[dict[str, object]]:
    """One row per survey."""
    return [
        {
            "survey": k,
            "time": round(s.time, 3),
            "wall_s": round(s.wall_s, 3),
            "detections": " ".join(
                f"{name}:{conf:.2f}@({x:.3f},{y:.3f},{z:.3f})" for name, conf, x, y, z in s.detections
            ),
            "above": " ".join(f"{up}>{low}" for up, low in s.above),
            "unknown_regions": " ".join(f"({x:.3f},{y:.3f})" for x, y in s.unknown),
            "chosen": s.chosen or "",
        }
        for k, s in enumerate(episode.result.surveys, start=1)
    ]


def summary(config: ClearTableConfig, episode: ClearTableEpisode) -> dict[str, Any]:
    """The episode's summary (JSON-friendly)."""
    r, v = episode.result, episode.verdict
    placed = [c for c in r.cloths if c.order is not None]
    per_cloth = [c.sim_time for c in placed]
    known = sum(1 for c in v.cloths if c.known)
    return {
        "status": "interrupted" if r.interrupted else "finished",
        "cleared": v.cleared,
        "cause": v.cause,
        "robot_cleared": r.cleared,
        "stop_reason": r.stop_reason,
        "seed": config.seed,
        "pile": [f"No.{n}" for n in episode.pile],
        "max_overlap": episode.max_overlap,
        "same_family": episode.same_family,
        "known_cloths_in_pile": known,
        "in_right_box": sum(1 for c in v.cloths if c.known and c.correct),
        "wrong_box": v.wrong_box,
        "unknown_cloths_in_pile": v.unknown_cloths,
        "unknown_regions_reported": [list(xy) for xy in r.unknown],
        "left_in_their_colours": {name: list(notes) for name, notes in r.left.items()},
        "double_picks": v.double_picks,
        "double_picks_detected": v.double_picks_detected,
        "double_picks_noticed_after": v.double_picks_noticed_after,
        "wrong_lifts": v.wrong_lifts,
        "wrong_lifts_detected": v.wrong_lifts_detected,
        "false_alarms": v.false_alarms,
        "drops": v.drops,
        "drops_detected": v.drops_detected,
        "cloths_flung": [f"No.{n}" for n in v.flung],
        "cloths_over_the_rim": [c.name for c in v.cloths if c.over_rim > 0],
        "pick_attempts": len(r.attempts),
        "surveys": len(r.surveys),
        "survey_wall_s": sum(s.wall_s for s in r.surveys),
        "sim_time_s": r.sim_time,
        "sim_time_per_known_cloth_s": r.sim_time / max(known, 1),
        "attempt_time_per_placed_cloth_s": {"median": float(np.median(per_cloth)) if per_cloth else None},
        "wall_s": r.wall_s,
        "limit_violations": r.limit_report.violations,
        "commanded_samples": r.limit_report.samples,
        "limits": {k: float(x) if isinstance(x, float) else x for k, x in r.limit_report._asdict().items()},
        "collisions": r.collisions,
        "slides_held": episode.slides_held,
    }


def write_clear_table(out_dir: str | Path, config: ClearTableConfig, episode: ClearTableEpisode) -> Path:
    """Writes the results folder (each file whole: temporary name, then renamed)."""
    folder = Path(out_dir)
    with output_folder(folder):
        dump_config(config, folder / "config.yaml")
        atomic_write_csv(folder / "cloths.csv", cloth_rows(episode))
        atomic_write_csv(folder / "picks.csv", pick_rows(episode))
        atomic_write_csv(folder / "surveys.csv", survey_rows(episode))
        atomic_write_text(
            folder / "summary.json", json.dumps(summary(config, episode), indent=2, default=str)
        )
    return folder


__all__ = ["cloth_rows", "pick_rows", "summary", "survey_rows", "write_clear_table"]
