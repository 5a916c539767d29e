"""Recognition: a cloth model, a stereo rig and a stereo pair -> the cloth's pose, or "not there".

The recogniser composes the stages and holds no search logic of its own:

1. exposure: the green sheet in each image gives the channel gains that map the scene's
   exposure and white balance onto the model photo's, and the shading of shadows over
   the cell (`exposure.scene_exposure`);
2. propose (`propose.Proposer`): the paper's GA on the hue fitness, with restarts; each
   run's best is climbed and polished by the refine stage (3.), and the best is also
   tried moved by a periodic print's periods and symmetry turns (`print_periods`: the
   neighbouring peaks);
3. refine (`refinement.Refiner`): compass search and CMA-ES on the continuous pose;
4. verify (`verify.Verifier`): the model photo's texture against both images at the best
   pose, its half and quarter turns and the other runs' ends whose search fitness is
   within `verify.ambiguity_margin`; of those whose texture agrees better than the
   best's, the most confident is kept (and polished if it was not the polished one); if
   a half-plane of the model disagrees with the image (a folded-over corner,
   `refinement.disagreeing_corner`), the kept pose is polished again with those points
   hidden (`refine.corner_disagreement`); where the pose still scores poorly after the
   depth check (5.), it is also polished with each of a few corners hidden
   (`refine.corner_hypotheses`, one-shot only: a fold pulls the hue fitness's peak off the
   truth, where no corner disagrees enough), and the best end replaces it if it is a fold
   that scores better with its own disagreeing corner hidden and there scores as a flat
   cloth does (`refine.corner_hypothesis_explained`); the propose stage asks the verify stage
   whether a run ended on a look-alike (`verify.look_alike_below`) and searches elsewhere;
   where the hue fitness barely holds the kept pose's yaw (a print of nearly one hue on a
   round outline) and the texture is compared by correlation, the pose is moved in the cloth
   plane to where the texture agrees best (`texture_polish.py`, `refine.texture_*`; one-shot
   only);
5. stereo depth (`stereo_depth.StereoDepth`): the plane the pair shows around the pose,
   without the model's size; a small depth offset is taken, and a pose whose plane is
   not the pair's is searched again on the stereo plane (`plane_search.search_in_plane`,
   its shortlist ranked by the decision);
6. occluder read and align (`_read_and_aligned`): a plain sheet of a hue the model has over
   the final pose (its cells disagree, are plain and go on past the outline,
   `occluder_read.py`) is read as hidden in the evidence, its pixels hidden to the search
   fitness and the texture too; where it hides more than `depth.research.occluder_min_share`,
   a one-shot pose is searched again on its plane with those pixels hidden and the better
   ranked kept. Where the texture agrees poorly at the final pose, the verification looks
   for the best agreement within a few millimetres and degrees (`verify.Verifier.aligned`: a
   fine-grained print needs sub-millimetre alignment; the pose is kept); one-shot and
   check only: a tracked pose's evidence is its own, so a drift off the cloth shows;
7. decide (`decide.decide`): `found` = confidence >= `decide.threshold`, the one
   acceptance threshold.

Multi-step recognition (`Recognizer.track`) proposes from the kept poses moved by the
camera motion (Sec. II-E), with colour codes only where the tracking window reaches
(`tracking_window.py`), then verifies (every `propose.tracking.verify_every`-th frame)
and decides the same way; it has no depth check.
"""

from __future__ import annotations

import functools
import gc
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Any, TypeVar, cast

import numpy as np
import numpy.typing as npt
from pydantic import model_validator

from robot_app.arrays import FloatArray
from robot_app.config import SettingValueError, StrictModel
from robot_app.geometry import rotation_about_z
from robot_app.vision.camera import StereoRig
from robot_app.vision.cloth_model import ClothModel
from robot_app.vision.decide import (
    DecisionSettings,
    Evidence,
    RivalContext,
    RivalSettings,
    RivalVerdict,
    decide,
    judge,
    logit,
    overlapping,
    ranking,
)
from robot_app.vision.exposure import ExposureSettings, scene_exposure
from robot_app.vision.fitness import FitnessEvaluator, KernelFitness
from robot_app.vision.fitness_scores import FitnessSettings
from robot_app.vision.pixel_codes import checked_image
from robot_app.vision.plane_search import onto_plane, search_in_plane
from robot_app.vision.poses import moved
from robot_app.vision.propose import HALF_TURN, Candidate, ProposalSettings, Proposer
from robot_app.vision.recognition import Peak, Recognition
from robot_app.vision.refinement import (
    CORNER_HYPOTHESES_KEPT,
    RefinementSettings,
    Refiner,
    corner_cuts,
    disagreeing_corner,
)
from robot_app.vision.stereo_depth import DepthCheckSettings, DepthMeasurement, StereoDepth
from robot_app.vision.texture_polish import texture_polish, yaw_weakly_held
from robot_app.vision.verify import Verification, VerificationSettings, Verifier

_Method = TypeVar("_Method", bound=Callable[..., "Recognition"])
CORNER_ROUNDS = 2  # find the disagreeing corner and polish without it, this often at most
_QUARTER_TURN = np.eye(4)
_QUARTER_TURN[:3, :3] = rotation_about_z(np.pi / 2)


class RecognitionSettings(StrictModel):
    """The recogniser's settings: one tree, one section per stage, validated once.

    Attributes:
        fitness: the reported fitness (eqs. 9-11): by default pixels with saturation or
            value below 40 have a tone (DARK / LIGHT) instead of a hue, as `ModelSettings`
            gives a model's black and white parts. `FitnessSettings()` with
            `normalisation: model` is the paper's fitness exactly.
        search: the fitness the propose and refine stages optimise and the decision
            weighs: beyond `fitness`, a point on a foreign hue (an occluder, another cloth)
            is hidden (`hidden_foreign`) with a small `hidden_penalty`, the view floor is
            0.3 (`min_view_fraction`: a cloth 45 % under a sheet that also reaches past an
            image edge has less than half its points seen; with 0.5 a smaller, farther pose
            squeezed onto the visible part won in 5 of 96 such scenes), an S_out point on a
            foreign hue scores 0 and on the model's own hues -1.25 (balances the outermost
            S_out ring against the outermost S_in ring: median depth error 4.2 -> 1.0 mm).
            Its tone thresholds must be those of `fitness` (one pixel code per image).
        exposure: the green sheet as the exposure reference.
        propose: the GA search, one-shot and tracking.
        refine: the local polish.
        verify: the appearance check and the ambiguity margin.
        depth: the stereo depth check of the final pose.
        decide: the confidence and THE acceptance threshold.
        rivals: the rival test of an accepted one-shot recognition (`decide.py`'s rivals; only with
            rivals given, `Recognizer.set_rivals`).
        pause_garbage_collector: switch Python's cyclic garbage collector off during a
            recognition (it runs again afterwards; a recognition makes no reference
            cycles). A full collection inside a recognition costs 10-20 ms.
    """

    fitness: FitnessSettings = FitnessSettings(min_saturation=40, min_value=40)
    search: FitnessSettings = FitnessSettings(
        min_saturation=40,
        min_value=40,
        score_out_foreign=0.0,
        hidden_foreign=True,
        hidden_penalty=0.05,
        min_view_fraction=0.3,
        score_out_other=-1.25,
    )
    exposure: ExposureSettings = ExposureSettings()
    propose: ProposalSettings = ProposalSettings()
    refine: RefinementSettings = RefinementSettings()
    verify: VerificationSettings = VerificationSettings()
    depth: DepthCheckSettings = DepthCheckSettings()
    decide: DecisionSettings = DecisionSettings()
    rivals: RivalSettings = RivalSettings()
    pause_garbage_collector: bool = True

    @model_validator(mode="after")
    def _one_pixel_code(self) -> RecognitionSettings:
        keys = ("min_saturation", "min_value", "value_split")
        differ = [k for k in keys if getattr(self.search, k) != getattr(self.fitness, k)]
        if differ:
            raise SettingValueError(
                f"search.{differ[0]}",
                f"search.{differ[0]} must equal fitness.{differ[0]} (one pixel code per image)",
                getattr(self.search, differ[0]),
            )
        return self


def _collector_paused(method: _Method) -> _Method:
    """Runs a `Recognizer` method with Python's cyclic garbage collector off (if it was on
    and the recognizer's `settings.pause_garbage_collector` says so)."""

    @functools.wraps(method)
    def paused(self: Recognizer, *args: Any, **kwargs: Any) -> Recognition:
        if not self.settings.pause_garbage_collector or not gc.isenabled():
            return method(self, *args, **kwargs)
        gc.disable()
        try:
            return method(self, *args, **kwargs)
        finally:
            gc.enable()

    return cast(_Method, paused)


@dataclass(frozen=True)
class _Verified:
    pose: FloatArray
    search_fitness: float
    verification: Verification
    score: float  # `decide.ranking`: how the alternatives are ranked (the logit without the outline)


@dataclass(frozen=True)
class _PairRival:
    """A rival recogniser bound to the pair at hand (`decide.Rival`)."""

    recognizer: Recognizer
    image_left_bgr: npt.NDArray[np.uint8]
    image_right_bgr: npt.NDArray[np.uint8]
    seed: int | None
    restarts: int | None

    @property
    def model(self) -> ClothModel:
        return self.recognizer.model

    def recognize_alone(self) -> Recognition:
        r = self.recognizer
        restarts = self.restarts
        return r._recognize_alone(self.image_left_bgr, self.image_right_bgr, self.seed, False, restarts)


class Recognizer:
    """Recognises one cloth model in stereo pairs; keeps the best poses for tracking."""

    def __init__(
        self, model: ClothModel, rig: StereoRig, settings: RecognitionSettings | None = None
    ) -> None:
        self.model = model
        self.rig = rig
        self.settings = settings if settings is not None else RecognitionSettings()
        s = self.settings
        self.evaluator = FitnessEvaluator(model, rig, s.fitness, s.search)
        self.refiner = Refiner(s.refine)
        self.proposer = Proposer(self.evaluator, s.propose, self.refiner, s.propose.ga.seed)
        self.verifier = Verifier(model, self.evaluator, s.search, s.verify)
        self.depth = StereoDepth(model, rig, s.depth)
        self._frames_since_verified = 0
        self._last_verification: Verification | None = None
        self._rivals: tuple[Recognizer, ...] = ()

    @property
    def rivals(self) -> tuple[Recognizer, ...]:
        """The rivals the decision asks (`set_rivals`), of hue bands overlapping the model's."""
        return self._rivals

    def set_rivals(self, catalogue: Sequence[Recognizer]) -> None:
        """The catalogue the cloth could be confused with (`decide.py`, rivals): each a recogniser of
        another model on the same rig; only those whose main colours share a hue band with
        this model's are kept (this model's own is left out by name). An empty catalogue:
        the single-model decision. Asking a rival runs its one-shot search, which replaces
        the poses it keeps for tracking: do not give a recogniser that tracks as a rival.
        The rival test is of one-shot recognitions (`recognize`), not of `check` or `track`.

        Raises:
            ValueError: a rival on another rig.
        """
        if any(r.rig is not self.rig for r in catalogue):
            raise ValueError("every rival must be a recogniser on the same rig")
        s = self.settings
        kept = overlapping(
            self.model, [r.model for r in catalogue], s.fitness.hue_threshold_in, s.rivals.coverage
        )
        self._rivals = tuple(catalogue[k] for k in kept)

    @property
    def population(self) -> FloatArray | None:
        """(P, 4, 4) poses kept for tracking, best first (None before the first recognition)."""
        return self.proposer.kept_poses

    def reset(self) -> None:
        """Forgets the tracked poses and reseeds the random generator."""
        self.proposer.reset()
        self._last_verification = None

    def _take(
        self,
        image_left_bgr: npt.NDArray[np.uint8],
        image_right_bgr: npt.NDArray[np.uint8],
        regions: tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]] | None = None,
    ) -> None:
        """Exposure gains and shading of both images, then the pair into the evaluator (colour codes
        only inside `regions`, if given), the verifier and the depth check."""
        s = self.settings
        left = checked_image(image_left_bgr, self.rig.left, "left")
        right = checked_image(image_right_bgr, self.rig.right, "right")
        exposures = (
            scene_exposure(left, self.model, s.exposure),
            scene_exposure(right, self.model, s.exposure),
        )
        gains = (exposures[0].gains, exposures[1].gains)
        shading = (exposures[0].shading, exposures[1].shading)
        self.evaluator.update(left, right, gains, regions, shading)
        self.verifier.update(left, right, gains, shading)
        if s.depth.enabled:
            self.depth.update(left, right)

    @_collector_paused
    def recognize(
        self,
        image_left_bgr: npt.NDArray[np.uint8],
        image_right_bgr: npt.NDArray[np.uint8],
        *,
        seed: int | None = None,
        report_peaks: bool = False,
    ) -> Recognition:
        """One-shot recognition: propose, verify the alternatives, refine the chosen, decide.

        Args:
            image_left_bgr, image_right_bgr: the stereo pair, (H, W, 3) uint8 of the rig's size.
            seed: seed of this run (default: the recognizer's own generator).
            report_peaks: also find the best pose of each distinct peak.

        Raises:
            InputError: images of the wrong type or size.
        """
        start = time.perf_counter()
        result = self._recognize_alone(image_left_bgr, image_right_bgr, seed, report_peaks)
        s = self.settings.rivals
        if not (s.enabled and self._rivals and result.found and result.confidence < s.decisive_confidence):
            return result
        verdict = self._ask_rivals(result, image_left_bgr, image_right_bgr, seed)
        return replace(
            result,
            found=not verdict.winner,
            rival=verdict.winner,
            rivals_asked=len(verdict.asked),
            time_s=time.perf_counter() - start,
        )

    def _ask_rivals(
        self,
        result: Recognition,
        image_left_bgr: npt.NDArray[np.uint8],
        image_right_bgr: npt.NDArray[np.uint8],
        seed: int | None,
    ) -> RivalVerdict:
        """`decide.judge` of `result`; a rival asked recognises itself in the pair (alone, the same seed)."""
        camera = self.rig.right
        width, height = camera.image_size
        framed = self.evaluator.codes[1].reshape(height + 3, width + 3)  # see `pixel_codes`
        codes = framed[1 : height + 1, 1 : width + 1]
        cap = self.settings.rivals.restarts
        rivals = [_PairRival(r, image_left_bgr, image_right_bgr, seed, cap) for r in self._rivals]
        context = RivalContext(self.model, result, camera, codes, self.settings.fitness, self.settings.rivals)
        return judge(context, rivals)

    def _recognize_alone(
        self,
        image_left_bgr: npt.NDArray[np.uint8],
        image_right_bgr: npt.NDArray[np.uint8],
        seed: int | None,
        report_peaks: bool,
        restarts: int | None = None,
    ) -> Recognition:
        """`recognize` without the rivals (`restarts`: cap on the GA's restarts, None: the settings')."""
        start = time.perf_counter()
        self._take(image_left_bgr, image_right_bgr)
        before = self.evaluator.evaluations
        rng = np.random.default_rng(seed) if seed is not None else self.proposer.rng
        proposal = self.proposer.propose(
            rng, peaks=report_peaks, restarts=restarts, look_alike=self._look_alike
        )
        chosen, measurement = self._depth_checked(
            self._texture_polished(
                self._turned_after_fold(self._most_confident(proposal.best, proposal.candidates, rng), rng)
            )
        )
        chosen = self._final_evidence(self._with_corner_hidden(chosen, rng), rng)
        kept = self.proposer.kept_poses
        if kept is not None and chosen.pose is not proposal.best.transform_model_to_camera:
            self.proposer.keep(chosen.pose, kept)  # tracking goes on from the verified pose (a half turn?)
        self._last_verification, self._frames_since_verified = chosen.verification, 0
        # the first peak is the best run's, which the recognition went on from
        poses = (
            [chosen.pose, *(p.transform_model_to_camera for p in proposal.peaks[1:])]
            if proposal.peaks
            else []
        )
        peaks = tuple(
            sorted((Peak(T, float(self.evaluator.evaluate(T)[0])) for T in poses), key=lambda p: -p.fitness)
        )
        return self._result(chosen, proposal.generations, before, start, peaks, measurement.offset)

    @_collector_paused
    def check(
        self,
        image_left_bgr: npt.NDArray[np.uint8],
        image_right_bgr: npt.NDArray[np.uint8],
        transform_model_to_camera: FloatArray,
        *,
        seed: int | None = None,
    ) -> Recognition:
        """Is the cloth still where it was? Recognition near a known pose, without the GA.

        The pose (e.g. from an earlier recognition, moved by the camera motion since) is
        polished by the refine stage inside the search bounds (a cloth pushed a few
        millimetres is followed), checked against the stereo pair's depth and decided like
        a one-shot recognition. Nothing is kept for tracking.

        Args:
            image_left_bgr, image_right_bgr: the stereo pair.
            transform_model_to_camera: (4, 4) ^CR T_M where the cloth is expected [m].
            seed: seed of the polish (default: the recognizer's own generator).

        Raises:
            InputError: images of the wrong type or size.
            ValueError: a pose that is not a finite 4x4 transform.
        """
        start = time.perf_counter()
        pose = np.array(transform_model_to_camera, dtype=float)
        if pose.shape != (4, 4) or not np.all(np.isfinite(pose)):
            raise ValueError(f"check needs a finite (4, 4) pose, got shape {pose.shape}")
        self._take(image_left_bgr, image_right_bgr)
        before = self.evaluator.evaluations
        rng = np.random.default_rng(seed) if seed is not None else self.proposer.rng
        fitness = self.proposer.fitness()
        if self.settings.refine.enabled:
            fine = self.proposer.fitness(subpixel=True)
            pose = self.refiner.polish(
                pose, fitness, fine, self.proposer.limits(), rng
            ).transform_model_to_camera
        chosen = self._verified(pose, float(fitness(pose)[0]), self.verifier.verify(pose)[0])
        chosen, measurement = self._depth_checked(chosen)
        return self._result(self._final_evidence(chosen, None), 0, before, start, (), measurement.offset)

    @_collector_paused
    def track(
        self,
        image_left_bgr: npt.NDArray[np.uint8],
        image_right_bgr: npt.NDArray[np.uint8],
        transform_motion: FloatArray | None = None,
        *,
        generations: int | None = None,
    ) -> Recognition:
        """Multi-step recognition: continues from the kept poses (a one-shot run if none).

        The kept poses move by the camera motion; a small GA evolves them inside a window
        around the best moved pose and the refine stage climbs the best briefly
        (`propose.Proposer.track`); the result is verified every
        `propose.tracking.verify_every`-th frame and decided.

        Args:
            image_left_bgr, image_right_bgr: the new stereo pair.
            transform_motion: (4, 4) ^CR_new T_CR_old, the previous right-camera frame in
                the new one; every kept pose moves by it. None: the camera did not move.
            generations: GA generations this frame (default: propose.tracking.ga.generations).

        Raises:
            InputError: images of the wrong type or size.
            ValueError: a motion that is not a finite 4x4 transform.
        """
        if self.proposer.kept_poses is None:
            return self.recognize(image_left_bgr, image_right_bgr)
        start = time.perf_counter()
        self._take(image_left_bgr, image_right_bgr, self.proposer.tracking_regions(transform_motion))
        before = self.evaluator.evaluations
        best, count = self.proposer.track(transform_motion, generations)
        pose = best.transform_model_to_camera
        self._frames_since_verified += 1
        every = self.settings.propose.tracking.verify_every
        if self._last_verification is None or self._frames_since_verified >= every:
            # not aligned (`_aligned`): a tracked pose drifting off the cloth must show it in
            # its evidence; aligning it hid a drift until the cloth had left the view
            # (bench_conveyor 25 mm/s episode 36: 3 of 4 runs not_present with, 0 of 3 without)
            self._last_verification = self.verifier.verify(pose)[0]
            self._frames_since_verified = 0
        chosen = _Verified(pose, best.search_fitness, self._last_verification, 0.0)
        return self._result(chosen, count, before, start, (), float("nan"))

    def _result(
        self,
        chosen: _Verified,
        generations: int,
        before: int,
        start: float,
        peaks: tuple[Peak, ...],
        depth_offset: float,
    ) -> Recognition:
        """The decided recognition at `chosen`."""
        v = chosen.verification
        evidence = self._evidence(chosen.search_fitness, v)
        decision = decide(self.settings.decide, evidence)
        return Recognition(
            found=decision.found,
            fitness=float(self.evaluator.evaluate(chosen.pose)[0]),
            transform_model_to_camera=chosen.pose,
            evaluations=self.evaluator.evaluations - before,
            generations=generations,
            time_s=time.perf_counter() - start,
            peaks=peaks,
            confidence=decision.confidence,
            visible_fraction=v.visible_fraction,
            appearance=v.appearance,
            search_fitness=chosen.search_fitness,
            depth_offset=depth_offset,
            interleaved=v.interleaved,
            agreeing=v.agreeing,
            outline=v.outline,
            occluded=v.occluded,
            textured_share=v.textured_share,
        )

    def _most_confident(
        self, best: Candidate, candidates: tuple[Candidate, ...], rng: np.random.Generator
    ) -> _Verified:
        """The most confident of `best`, its half and quarter turns and the other candidates
        whose search fitness is within `verify.ambiguity_margin` of the best (ties keep
        `best`); polished by the refine stage if it is not `best`.

        An alternative replaces `best` only if the texture agrees better there (a higher
        appearance): the hue fitness ranked `best` first, and only the texture, which the
        hue fitness does not see, may overrule it. The decision's other evidence, the
        visible fraction, changes with where a turned pose's footprint falls beside a
        cover: a covered striped print half-turned and shifted half a period agreed as
        well as at the truth (0.90 against 0.92) and, with more of its footprint beside
        the sheet (visible 0.62 against 0.60), looked more confident though its hue
        fitness was 0.05 lower. (A margin of 0.1 on the appearance was tried: one more
        folded corner came back half-turned on the bench.)"""
        s = self.settings
        T = best.transform_model_to_camera
        others = [c.transform_model_to_camera for c in candidates if c.transform_model_to_camera is not T]
        poses = np.array([T, T @ HALF_TURN, T @ _QUARTER_TURN, T @ _QUARTER_TURN.T, *others])
        fitness = self.proposer.fitness()
        scores = fitness(poses)
        scores[0] = best.search_fitness
        keep = np.flatnonzero(scores >= best.search_fitness - s.verify.ambiguity_margin)
        verified = [
            self._verified(poses[k], float(scores[k]), v)
            for k, v in zip(keep, self.verifier.verify(poses[keep]), strict=True)
        ]
        first = verified[0].verification.appearance
        better = [item for item in verified[1:] if item.verification.appearance > first]  # NaN: none
        chosen = max([verified[0], *better], key=lambda item: item.score)  # the first (best) on ties
        if chosen.pose is verified[0].pose or chosen.score <= verified[0].score:
            return verified[0]
        if s.refine.enabled:
            limits = self.proposer.limits()
            fine = self.proposer.fitness(subpixel=True)
            polished = self.refiner.polish(chosen.pose, fitness, fine, limits, rng).transform_model_to_camera
            return self._verified(polished, float(fitness(polished)[0]), self.verifier.verify(polished)[0])
        return chosen

    def _look_alike(self, pose: FloatArray) -> bool:
        """The model photo's texture disagrees at `pose` and at each of its quarter turns
        (`verify.look_alike_below`): an object of the model's hues, not the cloth."""
        level = self.settings.verify.look_alike_below
        turns = np.array([pose, pose @ HALF_TURN, pose @ _QUARTER_TURN, pose @ _QUARTER_TURN.T])
        return all(v.agreeing < level for v in self.verifier.verify(turns))  # NaN: not compared

    def _without_fold(self, chosen: _Verified, rng: np.random.Generator) -> _Verified:
        """`chosen` polished once more with a disagreeing corner taken as hidden (a folded-over
        corner: `refinement.disagreeing_corner`), if it has one and `refine.corner_disagreement`
        is set; else as it is."""
        s = self.settings.refine
        if not s.enabled or s.corner_disagreement is None:
            return chosen
        m = self.model
        pose, moved_at_all = chosen.pose, False
        for _ in range(CORNER_ROUNDS):
            agree, disagree = self.evaluator.point_agreement(pose)
            hidden = disagreeing_corner(m.points_in, m.points_out, agree, disagree, s.corner_disagreement)
            if hidden is None:
                break
            fitness = KernelFitness(self.evaluator, search=True, hidden=hidden)
            fine = KernelFitness(self.evaluator, search=True, subpixel=True, hidden=hidden)
            pose = self.refiner.polish(
                pose, fitness, fine, self.proposer.limits(), rng
            ).transform_model_to_camera
            moved_at_all = True
        if not moved_at_all:
            return chosen
        return self._verified(pose, float(self.proposer.fitness()(pose)[0]), self.verifier.verify(pose)[0])

    def _turned_after_fold(self, chosen: _Verified, rng: np.random.Generator) -> _Verified:
        """`_without_fold` of `chosen`, and if that moved it, the moved pose's half and quarter
        turns compared as the search's best is (`_most_confident`): the polish with a corner
        hidden can end on a turned peak of a periodic print, where the kept part of the
        interior matches as well as at the truth (full-run folded scene 97, violet_cells:
        the GA's best 34 mm off, its half turn kept, the fold's polish then half-turned on
        the truth's centre, 0.4 mm off; the texture ranks the truth far higher)."""
        unfolded = self._without_fold(chosen, rng)
        if unfolded is chosen:
            return chosen
        return self._most_confident(Candidate(unfolded.pose, unfolded.search_fitness), (), rng)

    def _texture_polished(self, chosen: _Verified) -> _Verified:
        """`chosen` moved in the cloth plane to where the texture agrees best
        (`texture_polish.texture_polish`) if the hue fitness barely holds its yaw
        (`texture_polish.yaw_weakly_held`) and the texture is compared mostly by correlation;
        kept if its search fitness stays within `refine.texture_fitness_margin` (one-shot only)."""
        s = self.settings.refine
        textured = chosen.verification.textured_share >= self.settings.verify.align_textured_from
        if not (s.enabled and s.texture_yaw_flat_below is not None and textured):
            return chosen
        fine = self.proposer.fitness(subpixel=True)
        turn = np.deg2rad(s.texture_probe_deg)
        if not yaw_weakly_held(chosen.pose, fine, turn, s.texture_probe_shift, s.texture_yaw_flat_below):
            return chosen

        def appearance(poses: FloatArray) -> FloatArray:
            return np.array([v.appearance for v in self.verifier.verify(poses, outline=False)])

        end = texture_polish(
            chosen.pose,
            appearance,
            s.texture_step_position,
            np.deg2rad(s.texture_step_deg),
            s.texture_min_step_position,
            s.texture_iterations,
        )
        fitness = float(self.proposer.fitness()(end.transform_model_to_camera)[0])
        if not fitness >= chosen.search_fitness - s.texture_fitness_margin:
            return chosen
        pose = end.transform_model_to_camera
        return self._verified(pose, fitness, self.verifier.verify(pose)[0])

    def _with_corner_hidden(self, chosen: _Verified, rng: np.random.Generator) -> _Verified:
        """`chosen` or, if its search fitness is below `refine.corner_hypotheses_below`, the best of
        it polished with each tried corner hidden (`refinement.corner_cuts`) and then without
        its disagreeing corner (`_without_fold`), if that scores `refine.corner_hypothesis_margin`
        more by `_explained`; its half and quarter turns are compared as in `_most_confident`. For a
        print compared mostly by correlation (`verify.align_textured_from`), its aligned texture
        must also agree at least as well as the pose's. An end is adopted only if a corner
        disagrees there (it is a fold: where the best end has none, the cloth is not taken as
        folded and the pose is kept; such an end is the pose polished again away from the
        depth check's: flat cloths 0.3 -> 1.0 mm, z up to 6 mm off on the bench; and passing it
        over for the next end took a 45 % covered plain square 65 mm off) and its kept part
        scores `refine.corner_hypothesis_explained` (as a flat cloth does: a look-alike fitted
        to part of another cloth with the rest hidden does not); corners are tried only from
        `refine.corner_hypotheses_floor()` up (below, none could reach that) and only where one
        of them, hidden at the pose itself, already scores the margin more (a fold's corner
        disagrees there: +0.05 to +0.22 on the bench's 30 folded scenes; a flat cloth's at
        most +0.004, so the polishes are not paid where nothing is folded)."""
        s = self.settings.refine
        if not (s.enabled and s.corner_hypotheses and s.corner_disagreement is not None):
            return chosen
        if not s.corner_hypotheses_floor() <= chosen.search_fitness < s.corner_hypotheses_below:
            return chosen
        m, e = self.model, self.evaluator
        masks = corner_cuts(m.points_in, m.points_out, s.corner_hypotheses, s.corner_hypothesis_share)
        fitnesses = [
            (KernelFitness(e, search=True, hidden=h), KernelFitness(e, search=True, subpixel=True, hidden=h))
            for h in masks
        ]
        here = max(float(fitness(chosen.pose)[0]) for fitness, _ in fitnesses)
        if not here >= float(self.proposer.fitness()(chosen.pose)[0]) + s.corner_hypothesis_margin:
            return chosen  # no tried corner is worth hiding at the pose: no fold to search for
        starts = self.refiner.polish_hidden(
            chosen.pose, fitnesses, self.proposer.limits(), rng, CORNER_HYPOTHESES_KEPT
        )
        ends = [self._without_fold(self._at_depth(T, 0.0), rng) for T in starts]
        folds = [self._corner_explained(end.pose) for end in ends]
        scores = [score for score, _ in folds]
        k = int(np.argmax(scores))
        if not (
            folds[k][1]  # the best explanation is a fold
            and scores[k] > self._explained(chosen.pose) + s.corner_hypothesis_margin
            and scores[k] >= s.corner_hypothesis_explained
        ):
            return chosen
        best = ends[k]
        T = best.pose
        turns = np.array([T, T @ HALF_TURN, T @ _QUARTER_TURN, T @ _QUARTER_TURN.T])
        explained = [scores[k], *(self._explained(turn) for turn in turns[1:])]
        fitness = self.proposer.fitness()(turns)
        verified = [
            best,
            *(
                self._verified(turn, float(f), v)
                for turn, f, v in zip(turns[1:], fitness[1:], self.verifier.verify(turns[1:]), strict=True)
            ),
        ]
        level = scores[k] - self.settings.verify.ambiguity_margin
        first = best.verification.appearance
        better = [
            item
            for item, x in zip(verified[1:], explained[1:], strict=True)
            if x >= level and item.verification.appearance > first  # NaN: none
        ]
        turned = max([best, *better], key=lambda item: item.score)  # the first (best) on ties
        end = best if turned is best else self._without_fold(turned, rng)
        if chosen.verification.textured_share >= self.settings.verify.align_textured_from:
            # a fine print: its texture says more than the hue; aligned, as the decision sees it,
            # it must agree at least as well (test seeds, covered violet_cells: 4 -> 18 mm off)
            before = self._aligned(chosen).verification.appearance
            if not self._aligned(end).verification.appearance >= before:  # NaN: kept
                return chosen
        return end

    def _explained(self, pose: FloatArray) -> float:
        """The search fitness at `pose` with its disagreeing corner hidden (`refinement.disagreeing_corner`
        at `refine.corner_disagreement`), or without one if none disagrees that much."""
        return self._corner_explained(pose)[0]

    def _corner_explained(self, pose: FloatArray) -> tuple[float, bool]:
        """`_explained` at `pose`, and whether a corner disagrees there (a fold)."""
        m = self.model
        agree, disagree = self.evaluator.point_agreement(pose)
        level = self.settings.refine.corner_disagreement
        hidden = (
            None if level is None else disagreeing_corner(m.points_in, m.points_out, agree, disagree, level)
        )
        if hidden is None:
            return float(self.proposer.fitness()(pose)[0]), False
        return float(KernelFitness(self.evaluator, search=True, hidden=hidden)(pose)[0]), True

    def _depth_checked(self, chosen: _Verified) -> tuple[_Verified, DepthMeasurement]:
        """`chosen` checked against the stereo pair (`stereo_depth.py`): moved to its stereo
        depth if the check trusts a small offset (`depth.adopt_within`); searched again on
        the stereo plane (`plane_search.py`) if its own plane is not the one the pair
        shows; else as it is. Also the measurement of the pose the search ended on."""
        s = self.settings.depth
        if not s.enabled:
            return chosen, DepthMeasurement(float("nan"), float("nan"), float("nan"), 0, False)
        measurement = self.depth.measure(chosen.pose)
        if measurement.trusted and abs(measurement.offset) <= s.adopt_within:
            return self._at_depth(chosen.pose, measurement.offset), measurement
        measured = measurement.samples >= s.min_samples
        off_plane = (
            abs(measurement.offset) > s.research_beyond or not measurement.correlation >= s.min_correlation
        )
        if not (s.research.enabled and measured and off_plane):
            return chosen, measurement
        plane = self.depth.fit_plane(chosen.pose)
        if plane is None or not plane.trusted or plane.correlation - plane.correlation_at_pose < s.min_gain:
            return chosen, measurement
        start = onto_plane(chosen.pose, plane.normal, plane.distance)
        poses = self._searched_in_plane(start, chosen.verification)
        found = [self._at_depth(pose, 0.0) for pose in poses]
        best = max(found, key=lambda item: item.score).pose  # the first (best by hue) on ties
        again = self.depth.measure(best)
        offset = again.offset if again.trusted and abs(again.offset) <= s.adopt_within else 0.0
        return self._at_depth(best, offset), measurement

    def _logits(self, poses: FloatArray) -> FloatArray:
        """(P,) the ranking of each of (P, 4, 4) poses (`decide.ranking`: the decision's log-odds
        without the outline's terms, so the outline is not measured)."""
        fitness = self.proposer.fitness()(poses)
        verified = self.verifier.verify(poses, outline=False)
        return np.array(
            [self._verified(T, float(f), v).score for T, f, v in zip(poses, fitness, verified, strict=True)]
        )

    def _at_depth(self, pose: FloatArray, offset: float) -> _Verified:
        """`pose` moved by `offset` along the ray through its origin, verified."""
        moved_pose = moved(pose, [0.0, 0.0, offset, 0.0, 0.0, 0.0]) if offset else np.array(pose, dtype=float)
        search_fitness = float(self.proposer.fitness()(moved_pose)[0])
        return self._verified(moved_pose, search_fitness, self.verifier.verify(moved_pose)[0])

    def _final_evidence(self, chosen: _Verified, rng: np.random.Generator | None) -> _Verified:
        """`chosen`'s final evidence (`_read_and_aligned`), with an image channel read at
        `verify.evidence_saturated` or more taken as clipped (`Verifier.clipped_from`): a bright
        cloth whose main channel the camera clipped then agrees with its photo (gain 2.0 in
        `scripts/bench_camera_axes.py`: flat found 40 % without). The pose was chosen without
        the bound, which moved a folded stripes print 9 mm when it ranked the poses
        (`verify.saturated`); only the re-search past a near-hue occluder ranks with it."""
        with self.verifier.clipped_from(self.settings.verify.evidence_saturated) as clipped:
            if clipped:
                verification = self.verifier.verify(chosen.pose)[0]
                chosen = self._verified(chosen.pose, chosen.search_fitness, verification)
            return self._read_and_aligned(chosen, rng)

    def _read_and_aligned(self, chosen: _Verified, rng: np.random.Generator | None) -> _Verified:
        """`chosen`'s final evidence: its plain occluders of a hue the model has read as hidden
        (`Verifier.read_occluders`, `verify.occluder_read`), the search fitness and the
        alignment (`_aligned`) with their pixels hidden too. With `rng` (one-shot), where the
        read hides more than `depth.research.occluder_min_share` of the texture, the pose is
        also searched again on its plane with those pixels hidden (`_searched_past_occluder`)
        and the better ranked kept. The read is a hypothesis (the plain region is a sheet over
        the cloth), the plain evidence the other (it is seen and disagrees): the final pose's
        evidence is the read's only where the decision's log-odds are higher with it. A sheet
        read as hidden lowers the visible fraction the decision weighs, and a right pose must
        not lose to its own cover (test seed 2, covered violet_cells 45 % under blue and 14 %
        out of the image: 0.76 without the read, 0.43 with it)."""
        pose = chosen.pose
        verification, masks = self.verifier.read_occluders(pose, chosen.verification)
        if masks is None:
            return self._aligned(chosen)
        with self.verifier.pixels_hidden(masks):
            read = self._verified(pose, float(self.proposer.fitness()(pose)[0]), verification)
        research = self.settings.depth.research
        share = research.occluder_min_share
        if rng is not None and share is not None and verification.occluded > share:
            again = self._searched_past_occluder(read, masks)
            if again is not None and again[0].score > read.score:
                read, masks = again
        occluded = read.verification.occluded
        with self.verifier.pixels_hidden(masks):
            aligned = self._aligned(read)
        aligned = replace(aligned, verification=replace(aligned.verification, occluded=occluded))
        plain = chosen if read.pose is pose else self._at_depth(read.pose, 0.0)
        plain = self._aligned(plain)
        settings = self.settings.decide
        if logit(settings, self._evidence(plain.search_fitness, plain.verification)) >= logit(
            settings, self._evidence(aligned.search_fitness, aligned.verification)
        ):
            return plain
        return aligned

    def _searched_in_plane(self, start: FloatArray, verification: Verification) -> FloatArray:
        """(N, 4, 4) the poses `plane_search.search_in_plane` finds from `start` on its plane
        (`depth.research`; turned too where the texture at the pose it comes from,
        `verification`, is compared mostly by correlation), ranked by the decision."""
        s, p = self.settings.depth.research, self.proposer
        textured = verification.textured_share >= self.settings.verify.align_textured_from
        return search_in_plane(
            start,
            p.fitness(s.stride),
            p.fitness(),
            p.fitness(subpixel=True),
            s,
            self._logits,
            turns=s.turns and textured,
        )

    def _searched_past_occluder(
        self, read: _Verified, masks: tuple[npt.NDArray[np.bool_], npt.NDArray[np.bool_]]
    ) -> tuple[_Verified, tuple[npt.NDArray[np.bool_], npt.NDArray[np.bool_]]] | None:
        """The pose searched again on its plane (the stereo plane if the depth check trusts one
        there, else its own; `plane_search.search_in_plane`, the shortlist ranked by the
        decision) with the occluder's pixels `masks` hidden, so that the occluder's hue does not
        pull it; its own occluders read at its end (None: that read finds none)."""
        s = self.settings.depth
        start = read.pose
        if s.enabled:
            plane = self.depth.fit_plane(read.pose)
            if plane is not None and plane.trusted:
                start = onto_plane(read.pose, plane.normal, plane.distance)
        with self.verifier.pixels_hidden(masks):
            poses = self._searched_in_plane(start, read.verification)
            best = max((self._at_depth(T, 0.0) for T in poses), key=lambda item: item.score).pose
        if s.enabled:
            again = self.depth.measure(best)
            if again.trusted and abs(again.offset) <= s.adopt_within:
                best = moved(best, [0.0, 0.0, again.offset, 0.0, 0.0, 0.0])
        verification, own = self.verifier.read_occluders(best)
        if own is None:
            return None
        with self.verifier.pixels_hidden(own):
            return self._verified(best, float(self.proposer.fitness()(best)[0]), verification), own

    def _aligned(self, chosen: _Verified) -> _Verified:
        """`chosen` with the evidence of the texture aligned near its pose (`Verifier.aligned`;
        the pose and its search fitness kept)."""
        pose, fitness = chosen.pose, chosen.search_fitness

        def score(verifications: list[Verification]) -> FloatArray:
            return np.array([self._verified(pose, fitness, v).score for v in verifications])

        verification = self.verifier.aligned(pose, chosen.verification, score)
        if verification is chosen.verification:
            return chosen
        return self._verified(pose, fitness, verification)

    def _verified(self, pose: FloatArray, search_fitness: float, verification: Verification) -> _Verified:
        score = ranking(self.settings.decide, self._evidence(search_fitness, verification))
        return _Verified(pose, search_fitness, verification, score)

    def _evidence(self, search_fitness: float, verification: Verification) -> Evidence:
        v = verification
        return Evidence(
            search_fitness,
            v.appearance,
            v.visible_fraction,
            v.interleaved,
            self.model.has_texture,
            v.agreeing,
            v.outline,
            v.textured_share,
        )


__all__ = ["RecognitionSettings", "Recognizer"]
