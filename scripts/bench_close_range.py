"""How close can the hand cameras recognise a cloth? Tracking error per camera-to-cloth distance.

    python scripts/bench_close_range.py [--cloths 1,3,5,7,9,13,16,19] [--seeds 3]
        [--distances 0.26,0.24,...,0.08] [--realism realistic] [--out results/bench_close_range]
        [--set key=value ...]

The geometry of the servo's DESCEND on a still cloth: the realistic cell at the main
job's 320 x 240 hand-camera images (configs/pick_place.yaml; cameras with
their noise, white balance, shading, JPEG; the lamp's shadows; the fingers in view), a
cloth of the catalogue laid by the scene seed, the arm at the controller's observation
pose. One one-shot recognition there starts the tracker (a miss: the episode is
skipped, counted); then the hand goes down over the cloth's grasp point, TCP pointing
down as in DESCEND, the right camera from the first to the last `--distances` above the
cloth's surface, one stereo capture at each (the arm set there at rest: no motion blur),
each tracked by the multi-step GA from the previous frame's kept poses moved by the
camera's motion (the loop's `VisionPipeline` does the same). Near the cloth only part
of it is in view (at 0.10 m the view is about 90 x 67 mm).

Printed per distance, over every (cloth, seed): the tracked pose's in-plane position
error against the truth (`geometry.pose_error`, median / p95 / max [mm]), the yaw error
(p95 [deg]), the depth error (median |z| [mm]), the share of frames the decision calls
found, the median fitness and visible fraction. A second table does the same with
the tracker restarted at each distance from the true pose moved 5 mm and 3 deg (a
prediction's typical error): whether a view at that distance pulls a prediction back, not
only whether tracking survives the way down. Rows go to <out>/rows.csv.

`loop.min_working_distance` comes from this table: the nearest distance at which, and at
every distance above which, the p95 in-plane error of both tables stays within the pose
filter's own noise model for a recognition (`filter.measurement_std_xy` 3.5 mm per axis,
whose radial p95 is 3.5 * sqrt(-2 ln 0.05) = 8.6 mm). With 24 frames a distance the p95 is
about the second largest error: a coarse figure, read it with the max beside it.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from robot_app.arrays import FloatArray
from robot_app.config import load_config
from robot_app.control import JointLimits, Kinematics, observation_posture
from robot_app.control.anchored_recognizer import AnchoredRecognizer
from robot_app.experiments.pick_place_episode import PickPlaceConfig
from robot_app.geometry import invert_transform, make_transform, pose_error, rotation_about_z
from robot_app.outputs import atomic_write_csv, output_folder
from robot_app.sim import (
    ClothBody,
    ModelStation,
    SimCell,
    World,
    cloth_spec,
    make_scene,
    observation_camera_pose,
)
from robot_app.vision import RecognitionSettings, Recognizer, make_model

CAMERA_FRAME = "camera_right_optical"
DISTANCES = tuple(round(0.26 - 0.01 * i, 3) for i in range(19))  # 0.26 ... 0.08 [m]
PERTURBATION = (0.005, np.deg2rad(3.0))  # [m], [rad] of the restarted tracker's start


def recognition_settings(config: PickPlaceConfig, min_view_fraction: float | None) -> RecognitionSettings:
    """The episode's recogniser settings (the table's depth window, as `run_episode` sets it),
    with `fitness.min_view_fraction` if given (a `--set` of one fitness key does not validate:
    the search's pixel-code keys must equal the fitness's)."""
    data = config.recognition.model_dump()
    if min_view_fraction is not None:
        data["fitness"]["min_view_fraction"] = min_view_fraction
    window = config.table_depth_window
    if window is None:
        return RecognitionSettings.model_validate(data)
    data["propose"]["bounds"].update(
        z=(config.world.observation.height - window, config.world.observation.height + window),
        max_tilt_deg=config.table_tilt_deg,
    )
    data["propose"]["tracking"]["depth_window"] = window
    return RecognitionSettings.model_validate(data)


def run_cloth(
    cloth: int,
    seeds: list[int],
    distances: list[float],
    extra: list[str],
    min_view_fraction: float | None,
    anchor_window: float | None,
) -> list[dict[str, object]]:
    """Every seed's descents over cloth No.`cloth`; one row per (seed, mode, distance)."""
    base = load_config(PickPlaceConfig, None, [*extra, f"scene.target={cloth}", "scene.conveyor_speed=0"])
    with ModelStation.for_world(base.world) as station:
        photo = station.photograph(cloth_spec(cloth))
    model = make_model(
        photo.photo_bgr, photo.model_camera, photo.background_bgr, base.model, name=f"No.{cloth}"
    )
    w = base.world
    kinematics = Kinematics.from_urdf(w.robot.urdf, "base_link", "tcp")
    limits = JointLimits.from_urdf(w.robot.urdf, base.trajectory)
    observation = observation_posture(
        kinematics, limits, observation_camera_pose(w), w.robot.home_joints, base.loop.ik_tolerance
    )
    rows: list[dict[str, object]] = []
    for seed in seeds:
        overrides = [*extra, f"scene.target={cloth}", "scene.conveyor_speed=0", f"seed={seed}"]
        config = load_config(PickPlaceConfig, None, overrides)
        with World(config.world) as world:
            world.robot.reset_joints(observation)
            scene = make_scene(world, config.scene, seed=config.seed)
            cell = SimCell(world)
            recognizer = Recognizer(model, world.stereo.rig, recognition_settings(config, min_view_fraction))
            if anchor_window is not None:  # tracked depth held near the one-shot recognition's
                recognizer = AnchoredRecognizer(recognizer, config.world.observation.height, anchor_window)
            capture = cell.capture()
            first = recognizer.recognize(capture.left_bgr, capture.right_bgr, seed=seed)
            pose = capture.transform_right_camera_to_world @ first.transform_model_to_camera
            error = pose_error(pose, scene.target.pose(), tuple(model.symmetry_angles))
            row = {"cloth": cloth, "seed": seed}
            if not first.found or math.hypot(error.x_mm, error.y_mm) > 10.0:
                rows.append(row | {"mode": "start", "found": False})
                continue
            descent = _Descent(world, cell, scene.target, recognizer, kinematics, limits, observation)
            rng = np.random.default_rng([seed, cloth])
            for mode in ("descent", "restart"):
                descent.start(capture.transform_right_camera_to_world)
                for distance in distances:
                    measured = descent.track_at(distance, rng if mode == "restart" else None)
                    rows.append(row | {"mode": mode, "distance": distance, **measured})
    return rows


class _Descent:
    """The hand going down over the cloth's grasp point, tracking at each distance."""

    def __init__(
        self,
        world: World,
        cell: SimCell,
        cloth: ClothBody,
        recognizer: Recognizer,
        kinematics: Kinematics,
        limits: JointLimits,
        observation: FloatArray,
    ) -> None:
        self.world, self.cell, self.cloth, self.recognizer = world, cell, cloth, recognizer
        self.kinematics, self.limits, self.observation = kinematics, limits, observation
        self.tcp_rotation = kinematics.frame_pose(observation, "tcp")[:3, :3]
        self.camera_above_tcp = float(
            kinematics.frame_pose(observation, CAMERA_FRAME)[2, 3]
            - kinematics.frame_pose(observation, "tcp")[2, 3]
        )
        truth = cloth.pose()
        self.grasp_model = np.append(recognizer.model.grasp_point, 1.0)
        self.grasp = (truth @ self.grasp_model)[:3]
        self.surface = float(truth[2, 3])
        self.symmetry = tuple(recognizer.model.symmetry_angles)
        self.q = np.array(observation, dtype=float)
        self.previous = np.eye(4)

    def start(self, camera: FloatArray) -> None:
        """From the observation pose, whose frame the one-shot recognition saw."""
        self.q = np.array(self.observation, dtype=float)
        self.previous = camera

    def track_at(self, distance: float, restart: np.random.Generator | None) -> dict[str, object]:
        """The right camera `distance` [m] above the cloth over the grasp point: one tracked frame.

        With `restart`, the tracker starts from the true pose moved by `PERTURBATION`
        (random direction and sign) instead of from the previous frame's poses."""
        height = self.surface + distance - self.camera_above_tcp
        target = make_transform(self.tcp_rotation, [self.grasp[0], self.grasp[1], height])
        result = self.kinematics.solve_ik(
            target, self.q, frame="tcp", time_budget=0.2, preferred_posture=self.observation
        )
        if not (result.success and self.limits.contains(result.q)):
            return {"ik_failed": True}
        self.q = np.array(result.q)
        self.world.robot.reset_joints(self.q)
        self.world.step()
        capture = self.cell.capture()
        camera = capture.transform_right_camera_to_world
        truth = self.cloth.pose()
        motion = invert_transform(camera) @ self.previous
        kept = self.recognizer.population
        if restart is not None and kept is not None:  # the best kept pose onto a prediction-sized error
            angle = restart.uniform(0.0, 2.0 * np.pi)
            offset = make_transform(
                np.eye(3), PERTURBATION[0] * np.array([np.cos(angle), np.sin(angle), 0.0])
            )
            turn = make_transform(
                rotation_about_z(restart.choice([-1.0, 1.0]) * PERTURBATION[1]), np.zeros(3)
            )
            motion = invert_transform(camera) @ offset @ truth @ turn @ invert_transform(kept[0])
        self.previous = camera
        wall = time.perf_counter()
        recognition = self.recognizer.track(capture.left_bgr, capture.right_bgr, motion)
        wall = time.perf_counter() - wall
        pose = camera @ recognition.transform_model_to_camera
        error = pose_error(pose, truth, self.symmetry)
        grasp_error = (pose @ self.grasp_model)[:2] - (truth @ self.grasp_model)[:2]
        return {
            "camera_height": float(camera[2, 3] - self.surface),
            "found": bool(recognition.found),
            "confidence": float(recognition.confidence),
            "fitness": float(recognition.fitness),
            "visible_fraction": float(recognition.visible_fraction),
            "error_xy_mm": math.hypot(error.x_mm, error.y_mm),
            "grasp_xy_mm": float(np.linalg.norm(grasp_error) * 1e3),
            "error_z_mm": abs(error.z_mm),
            "error_yaw_deg": abs(error.yaw_deg),
            "track_s": wall,
        }


def percentiles(rows: list[dict[str, object]], key: str) -> FloatArray:
    return np.array([float(r[key]) for r in rows])  # type: ignore[arg-type]


def table(rows: list[dict[str, object]], mode: str, distances: list[float]) -> list[str]:
    """One line per distance of `mode`'s rows (markdown)."""
    lines = [
        f"## {mode}",
        "| camera-cloth [m] | frames | Σ_M xy error med / p95 / max [mm] | grasp point xy med / p95 [mm] "
        "| yaw p95 [deg] | depth med [mm] | found | fitness med | visible med |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for d in distances:
        sel = [r for r in rows if r["mode"] == mode and r.get("distance") == d and "fitness" in r]
        if not sel:
            continue
        xy, grasp = percentiles(sel, "error_xy_mm"), percentiles(sel, "grasp_xy_mm")
        yaw, z = percentiles(sel, "error_yaw_deg"), percentiles(sel, "error_z_mm")
        found = np.mean([bool(r["found"]) for r in sel])
        fitness, visible = percentiles(sel, "fitness"), percentiles(sel, "visible_fraction")
        lines.append(
            f"| {d:.2f} | {len(sel)} | {np.median(xy):.1f} / {np.percentile(xy, 95):.1f} / {xy.max():.1f} "
            f"| {np.median(grasp):.1f} / {np.percentile(grasp, 95):.1f} | {np.percentile(yaw, 95):.1f} "
            f"| {np.median(z):.1f} | {found:.0%} | {np.median(fitness):.2f} | {np.median(visible):.2f} |"
        )
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cloths", default="1,3,5,7,9,13,16,19", help="catalogue numbers")
    parser.add_argument("--seeds", type=int, default=3, help="scene seeds per cloth")
    parser.add_argument("--base-seed", type=int, default=7000)
    parser.add_argument("--distances", default=",".join(f"{d:.2f}" for d in DISTANCES), help="[m], far first")
    parser.add_argument("--realism", default="realistic")
    parser.add_argument("--out", default="results/bench_close_range")
    parser.add_argument(
        "--min-view-fraction", type=float, default=None, help="recognition.fitness.min_view_fraction"
    )
    parser.add_argument(
        "--anchor-window", type=float, default=None, help="[m] hold the tracked depth (AnchoredRecognizer)"
    )
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    args = parser.parse_args()
    cloths = [int(c) for c in args.cloths.split(",")]
    distances = [float(d) for d in args.distances.split(",")]
    extra = [f"world.realism={args.realism}", "world.cameras.image_size=[320,240]", *args.set]
    with output_folder(args.out) as out:
        rows: list[dict[str, object]] = []
        for cloth in cloths:
            seeds = [args.base_seed + 100 * cloth + i for i in range(args.seeds)]
            rows.extend(run_cloth(cloth, seeds, distances, extra, args.min_view_fraction, args.anchor_window))
            print(
                f"No.{cloth}: {sum(r['mode'] == 'descent' for r in rows)} descent frames so far", flush=True
            )
        skipped = sum(r["mode"] == "start" for r in rows)
        ik_failed = sum(bool(r.get("ik_failed")) for r in rows)
        print(f"\n{len(cloths) * args.seeds} descents; {skipped} skipped (no trusted one-shot recognition "
              f"at the observation pose); {ik_failed} frames without an IK solution")  # fmt: skip
        for mode in ("descent", "restart"):
            print("\n".join(["", *table(rows, mode, distances)]))
        keys = ["cloth", "seed", "mode", "distance", "camera_height", "found", "confidence", "fitness",
                "visible_fraction", "error_xy_mm", "grasp_xy_mm", "error_z_mm", "error_yaw_deg", "track_s",
                "ik_failed"]  # fmt: skip
        atomic_write_csv(out / "rows.csv", [{k: r.get(k, "") for k in keys} for r in rows])


if __name__ == "__main__":
    main()
