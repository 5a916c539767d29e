"""Experiments: config-driven trials (local processes or Ray) and the paper's report."""

from robot_app.experiments.experiment_config import (
    AnyTrialConfig,
    PickPlaceTrialConfig,
    RecognitionTrialConfig,
    SweepSettings,
    TrialConfig,
    TrialSceneSettings,
    load_trial_config,
    parse_trial_config,
)
from robot_app.experiments.kinds import run_trials, trial_kind
from robot_app.experiments.paper import PaperConfig, PaperReport, load_paper_config, run_paper
from robot_app.experiments.paper_report import PaperFigures, paper_table_markdown, write_paper_report
from robot_app.experiments.recognition_trial import RecognitionOutcome, run_recognition_trial
from robot_app.experiments.results_table import ResultsTable, read_table
from robot_app.experiments.summary import ErrorStats, error_stats
from robot_app.experiments.trial_result import TrialResult, execute_trial, trial_seed
from robot_app.experiments.trials import SweepInterruptedError, SweepResult, run_sweep

__all__ = [
    "AnyTrialConfig",
    "ErrorStats",
    "PaperConfig",
    "PaperFigures",
    "PaperReport",
    "PickPlaceTrialConfig",
    "RecognitionOutcome",
    "RecognitionTrialConfig",
    "ResultsTable",
    "SweepInterruptedError",
    "SweepResult",
    "SweepSettings",
    "TrialConfig",
    "TrialResult",
    "TrialSceneSettings",
    "error_stats",
    "execute_trial",
    "load_paper_config",
    "load_trial_config",
    "paper_table_markdown",
    "parse_trial_config",
    "read_table",
    "run_paper",
    "run_recognition_trial",
    "run_sweep",
    "run_trials",
    "trial_kind",
    "trial_seed",
    "write_paper_report",
]
