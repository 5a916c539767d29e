"""Measured checks of the simulator: lift a cloth with the gripper, and recognise a cloth
from its station photo in the hand stereo pair against ground truth.

Used by the slow tests and by `scripts/bench_sim.py`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from robot_app.geometry import make_transform, pose_error
from robot_app.sim.cloth_body import ClothBody
from robot_app.sim.cloth_visual import ClothLook
from robot_app.sim.cloths import ClothSpec
from robot_app.sim.config import WorldConfig
from robot_app.sim.realism import scene_defaults
from robot_app.sim.station import ModelStation
from robot_app.sim.world import World

TOOL_DOWN = np.diag([1.0, -1.0, -1.0])  # tcp z (tool axis) pointing down
FINGERTIP_CLEARANCE = 0.012  # tcp height above the cloth so the fingertips clear the table [m]


@dataclass(frozen=True)
class LiftResult:
    """Outcome of lifting a cloth by one gripped point.

    Attributes:
        anchored: number of nodes anchored to the gripper.
        max_stretch: largest edge length / rest length seen during the lift.
        lifted: height of the highest node above the table at the end [m].
        finite: no node position became NaN/inf.
    """

    anchored: int
    max_stretch: float
    lifted: float
    finite: bool


def lift_check(world: World, cloth: ClothBody, height: float = 0.3, duration: float = 1.0) -> LiftResult:
    """Grips the cloth at its node of largest world x and lifts it by `height` [m] in `duration` [s].

    The arm starts from the observation joints; it holds the top for 0.5 s before the end.
    """
    nodes = cloth.nodes()
    grip = nodes[np.argmax(nodes[:, 0])] + np.array([-0.01, 0.0, FINGERTIP_CLEARANCE])
    robot = world.robot
    q_grip = robot.solve_frame_ik("tcp", make_transform(TOOL_DOWN, grip), world.observation_joints)
    top = grip + np.array([0.0, 0.0, height])
    q_top = robot.solve_frame_ik("tcp", make_transform(TOOL_DOWN, top), q_grip)
    robot.reset_joints(q_grip)
    robot.set_gripper(0.0)
    anchored = cloth.grasp(robot, radius=0.025)
    ramp = max(1, round(duration / world.dt))
    stretch = 0.0
    for k in range(1, ramp + round(0.5 / world.dt) + 1):
        robot.command_joints(q_grip + (q_top - q_grip) * min(1.0, k / ramp))
        world.step()
        if k % 6 == 0:
            stretch = max(stretch, cloth.max_edge_stretch())
    final = cloth.nodes()
    return LiftResult(
        anchored,
        stretch,
        float(final[:, 2].max() - world.config.table.top_z),
        bool(np.all(np.isfinite(final))),
    )


@dataclass(frozen=True)
class RecognitionCheck:
    """Recognition of one cloth at the observation pose, against ground truth.

    The cloth lies as the world's realism preset lays it (flat in `clean`, wrinkled in
    `realistic`, maybe with a folded corner in `harsh`).

    Errors are in the right-camera frame; yaw errors are taken modulo the model's
    symmetry angles (a plain rectangle looks the same turned by 180°).
    """

    number: int
    found: bool
    fitness: float
    error_x_mm: float
    error_y_mm: float
    error_z_mm: float
    error_yaw_deg: float
    error_tilt_deg: float
    time_s: float


def recognition_check(
    spec: ClothSpec, config: WorldConfig, seed: int = 0, station: ModelStation | None = None
) -> RecognitionCheck:
    """Makes the cloth's model from the station photo, lays the cloth at a seeded random pose
    in the range (wrinkled and folded as the realism preset says), captures the stereo
    pair at the observation pose and recognises it."""
    from robot_app.vision.photo_model import make_model  # vision is optional for the sim
    from robot_app.vision.recognizer import Recognizer

    own_station = station is None
    station = station or ModelStation.for_world(config)
    try:
        photo = station.photograph(spec)
    finally:
        if own_station:
            station.close()
    model = make_model(photo.photo_bgr, photo.model_camera, photo.background_bgr, name=spec.name)
    rng = np.random.default_rng(seed)
    defaults = scene_defaults(config.realism)
    look_rng = np.random.default_rng((seed, 11))
    look = ClothLook.draw(look_rng, spec.size, defaults["wrinkle_amplitude"], defaults["fold_probability"])
    with World(config) as world:
        world.reseed(seed)
        # within 50 mm of the range centre, so that the cloth is whole in both cameras
        # (the left camera's view is shifted by the 0.1 m baseline)
        x, y = np.asarray(config.range.centre_xy) + rng.uniform(-0.05, 0.05, size=2)
        cloth = world.add_cloth(spec, float(x), float(y), float(rng.uniform(-np.pi, np.pi)), look=look)
        frame = world.stereo.render()
        truth = world.transform_model_to_camera(cloth)
        recognizer = Recognizer(model, world.stereo.rig)
        start = time.perf_counter()
        result = recognizer.recognize(frame.left_bgr, frame.right_bgr, seed=seed)
        elapsed = time.perf_counter() - start
    error = pose_error(result.transform_model_to_camera, truth, tuple(model.symmetry_angles))
    return RecognitionCheck(
        spec.number,
        bool(result.found),
        float(result.fitness),
        error.x_mm,
        error.y_mm,
        error.z_mm,
        error.yaw_deg,
        error.tilt_deg,
        elapsed,
    )


__all__ = ["LiftResult", "RecognitionCheck", "lift_check", "recognition_check"]
