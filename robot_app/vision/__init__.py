"""Recognition: pure numpy/OpenCV, never imports pybullet."""

from robot_app.vision.camera import (
    ModelCamera,
    PinholeCamera,
    StereoRig,
    load_model_camera,
    load_rig,
    save_model_camera,
    save_rig,
)
from robot_app.vision.cloth_model import ClothModel
from robot_app.vision.decide import (
    Decision,
    DecisionSettings,
    Evidence,
    RivalSettings,
    RivalVerdict,
    confidence,
    decide,
)
from robot_app.vision.exposure import ExposureSettings, sheet_gains
from robot_app.vision.fitness import FitnessEvaluator, KernelFitness
from robot_app.vision.fitness_scores import FitnessSettings
from robot_app.vision.full_search import FitnessPeak, FullSearchResult, find_peaks, full_search
from robot_app.vision.ga import GAResult, GASettings, GeneticAlgorithm, SearchBoundsSettings
from robot_app.vision.hue import (
    DARK,
    LIGHT,
    circular_mean_hue,
    colour_codes,
    colours_match,
    hue_distance,
    to_hsv,
    to_hue,
)
from robot_app.vision.kernel_warm_up import warm_up
from robot_app.vision.outline import ProjectedOutline, draw_outline, model_outline, project_outline
from robot_app.vision.photo_model import ModelSettings, load_photo, make_model
from robot_app.vision.plots import plot_full_search, save_preview
from robot_app.vision.poses import AvoidedPoses, PoseLimits
from robot_app.vision.propose import Candidate, Proposal, ProposalSettings, Proposer
from robot_app.vision.recognition import Peak, Recognition
from robot_app.vision.recognizer import RecognitionSettings, Recognizer
from robot_app.vision.refinement import Refinement, RefinementSettings, Refiner, cma_search, compass_search
from robot_app.vision.sampling import ModelSamples, sample_model
from robot_app.vision.stereo_depth import DepthCheckSettings, DepthMeasurement, StereoDepth
from robot_app.vision.synthetic import (
    SyntheticCloth,
    model_photo_transform,
    occluder_covering,
    render_model_photo,
    render_stereo_pair,
)
from robot_app.vision.synthetic_catalogue import CATALOGUE_SIZE, synthetic_cloth
from robot_app.vision.tracking_window import TrackingSettings
from robot_app.vision.verify import Verification, VerificationSettings, Verifier

__all__ = [
    "CATALOGUE_SIZE",
    "DARK",
    "LIGHT",
    "AvoidedPoses",
    "Candidate",
    "ClothModel",
    "Decision",
    "DecisionSettings",
    "DepthCheckSettings",
    "DepthMeasurement",
    "Evidence",
    "ExposureSettings",
    "FitnessEvaluator",
    "FitnessPeak",
    "FitnessSettings",
    "FullSearchResult",
    "GAResult",
    "GASettings",
    "GeneticAlgorithm",
    "KernelFitness",
    "ModelCamera",
    "ModelSamples",
    "ModelSettings",
    "Peak",
    "PinholeCamera",
    "PoseLimits",
    "ProjectedOutline",
    "Proposal",
    "ProposalSettings",
    "Proposer",
    "Recognition",
    "RecognitionSettings",
    "Recognizer",
    "Refinement",
    "RefinementSettings",
    "Refiner",
    "RivalSettings",
    "RivalVerdict",
    "SearchBoundsSettings",
    "StereoDepth",
    "StereoRig",
    "SyntheticCloth",
    "TrackingSettings",
    "Verification",
    "VerificationSettings",
    "Verifier",
    "circular_mean_hue",
    "cma_search",
    "colour_codes",
    "colours_match",
    "compass_search",
    "confidence",
    "decide",
    "draw_outline",
    "find_peaks",
    "full_search",
    "hue_distance",
    "load_model_camera",
    "load_photo",
    "load_rig",
    "make_model",
    "model_outline",
    "model_photo_transform",
    "occluder_covering",
    "plot_full_search",
    "project_outline",
    "render_model_photo",
    "render_stereo_pair",
    "sample_model",
    "save_model_camera",
    "save_preview",
    "save_rig",
    "sheet_gains",
    "synthetic_cloth",
    "to_hsv",
    "to_hue",
    "warm_up",
]
