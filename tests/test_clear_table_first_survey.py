"""`experiments.first_survey` (scripts/bench_survey.py): the job's first survey of a laid-out
pile in the realistic cell, and the truth it is judged by (poses, share of each cloth in view)."""

from __future__ import annotations

import numpy as np

from robot_app.config import load_config
from robot_app.experiments.clear_table import ClearTableConfig, FirstSurvey, first_survey
from robot_app.sim.fresh_process import run_in_fresh_process

CONFIG = "configs/clear_table.yaml"


def _survey_here(overrides: tuple[str, ...]) -> FirstSurvey:
    return first_survey(load_config(ClearTableConfig, CONFIG, ["seed=5", *overrides]))


def test_the_first_survey_names_the_cloths_where_they_lie() -> None:
    """Two cloths apart and a third half under one of them: the two in full view are
    identified within 10 mm of where they truly lie, and the truth says how much of each the
    camera sees (all of the free ones, part of the covered one)."""
    survey = run_in_fresh_process(
        _survey_here,
        ("pile.cloths=[3,12,11]", "pile.layout=[[0.45,-0.12,0.0],[0.62,0.12,0.0],[0.5,-0.05,0.4]]"),
    )
    assert set(survey.truth) == {"No.3", "No.12", "No.11"}
    assert survey.visible["No.12"] > 0.9
    assert 0.1 < survey.visible["No.3"] < 0.85  # under the tartan No.11
    assert survey.visible["No.11"] > 0.9
    found = {d.name: d for d in survey.identification.detections}
    for name in ("No.12", "No.11"):
        pose = survey.transform_camera_to_world @ found[name].transform_model_to_camera
        assert np.linalg.norm(pose[:2, 3] - survey.truth[name][:2, 3]) < 0.01, name
