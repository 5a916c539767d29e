"""Episode recordings in Rerun (`--record F.rrd`): what the robot saw and did, on one timeline.

A recording holds, on the `cell_time` timeline [s] (and the `vision_cycle` sequence
for what each vision cycle saw):

- `cell/table`, `cell/sheet`, `cell/box`: the fixed cell in Σ_W (static);
- `cell/robot/<link>`: each rigid body's pose (named after its first link), its URDF
  primitives below it (scene samples);
- `cell/tcp`, `cell/tcp_path`: the TCP now, and its path so far (at each phase end);
- `cell/cloths/<No.n>`: every cloth's soft-body mesh with its print (scene samples);
- `cameras/left`, `cameras/right`: the camera's pose and pinhole (its frustum in 3D),
  with `cameras/<side>/image` (JPEG) and `cameras/<side>/outline/recognised` and
  `.../true`: S_in's outline under the recognised and the true pose (vision cycles);
- `cloth/recognised`, `cloth/filtered`, `cloth/true`: Σ_M's pose, its axes and S_in's
  outline below; `cloth/grasp_point`: where the loop means to grasp (vision cycles);
- `signals/recognition/*` (fitness, confidence, visible fraction), `signals/filter/*`
  (NIS, residual), `signals/error/*` (against the truth) (vision cycles);
- `signals/joints/<kind>`, one series per joint: `position` [rad], `velocity` [rad/s],
  `position_of_range` and `velocity_of_limit` (-1 and 1 are the limits; drawn as
  `signals/joints/limit_low|high`) (control steps);
- `log/phases`, `log/recognitions`, `log/outcome`: text entries.

rerun-sdk is an optional extra (`robot_app[viewer]`) imported only when a recording is
made; `require_rerun` turns its absence into a one-line input error. Every temporal row
is buffered (`TimedColumns`) and sent in columns when many are pending and at `close`,
so recording costs little per control step and per vision cycle. The caller gives the
file name (an `atomic_path` temporary); `close` finalises the file. Nothing here is
specific to one episode of one cloth: a longer job (several cloths, a conveyor) logs
its cycles, phases and outcomes into the same recorder.
"""

from __future__ import annotations

import math
import uuid
from pathlib import Path
from types import ModuleType, TracebackType
from typing import Any

import cv2
import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray
from robot_app.control.episode import PhaseRecord, VisionCycle
from robot_app.errors import InputError
from robot_app.experiments.recording_columns import Kind, TimedColumns
from robot_app.experiments.recording_layout import CellLayout, SceneSample, Shape
from robot_app.geometry import quaternion_xyzw_from_matrix
from robot_app.vision import ProjectedOutline

RERUN_RANGE = ">=0.41,<0.42"  # the tested range (pyproject.toml, extra `viewer`)
INSTALL_HINT = "pip install 'robot_app[viewer]'"
RECOGNISED_RGB, TRUE_RGB, FILTERED_RGB = (255, 215, 0), (255, 0, 255), (0, 200, 255)
GRASP_RGB, TCP_RGB = (255, 60, 60), (240, 240, 240)
PLURAL = {"box": "boxes", "cylinder": "cylinders", "sphere": "spheres"}
FLUSH_ROWS = 20_000  # buffered rows (and joint samples) that trigger a send before `close`
JOINT_SERIES = ("position", "velocity", "position_of_range", "velocity_of_limit")


def require_rerun(key: str = "--record") -> ModuleType:
    """The `rerun` module, or an InputError (exit 2) saying how to install it.

    Raises:
        InputError: rerun-sdk is not installed (or cannot be imported); `key` names the option.
    """
    try:
        import rerun
    except ImportError as err:
        raise InputError(
            f"{key} needs the optional viewer extra (rerun-sdk {RERUN_RANGE}): {INSTALL_HINT}",
            key=key,
            expected=INSTALL_HINT,
        ) from err
    return rerun


class EpisodeRecorder:
    """One Rerun recording written to `path` (give an `atomic_path` temporary).

    Args:
        path: the .rrd file to write.
        name: the recording's name in the viewer.
        jpeg_quality: camera images are stored as JPEG of this quality (1-100).

    Raises:
        InputError: rerun-sdk is not installed.
    """

    def __init__(self, path: str | Path, *, name: str = "pick-place episode", jpeg_quality: int = 90) -> None:
        if not 1 <= jpeg_quality <= 100:
            raise ValueError(f"jpeg_quality must be within 1-100, got {jpeg_quality}")
        self.rr = rr = require_rerun()
        from robot_app.experiments.recording_blueprint import default_blueprint

        self.path = Path(path)
        self.jpeg_quality = jpeg_quality
        self.cycles = 0
        self._rec = rr.RecordingStream("robot_app", recording_id=str(uuid.uuid4()))
        self._rec.set_log_tick_enabled(False)
        self._rec.set_log_time_enabled(False)  # the timelines are cell_time and vision_cycle only
        self._rec.save(str(self.path), default_blueprint=default_blueprint(rr))
        self._rec.send_recording_name(name)
        self._rec.log("/", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        self._layout: CellLayout | None = None
        self._columns = TimedColumns(rr, self._rec)
        self._joint_times: list[float] = []
        self._q: list[FloatArray] = []
        self._dq: list[FloatArray] = []
        self._tcp_path: list[FloatArray] = []
        self._last_time = 0.0
        self._closed = False

    # ------------------------------------------------------------------ static
    def log_layout(self, layout: CellLayout) -> None:
        """Logs the fixed cell, the link primitives, the cloths' prints and the cameras (static)."""
        rr, rec = self.rr, self._rec
        self._layout = layout
        for name, shapes in layout.fixed.items():
            self._log_shapes(f"cell/{name}", shapes)
        for link, shapes in layout.links.items():
            self._log_shapes(f"cell/robot/{link}", shapes)
        for cloth in layout.cloths:
            texture = cv2.cvtColor(cloth.texture_bgr, cv2.COLOR_BGR2RGB)
            rec.log(
                f"cell/cloths/{cloth.label}",
                rr.Mesh3D.from_fields(
                    triangle_indices=np.asarray(cloth.triangles, dtype=np.uint32),
                    vertex_texcoords=np.asarray(cloth.uvs, dtype=np.float32),
                    albedo_texture_buffer=texture.tobytes(),
                    albedo_texture_format=rr.components.ImageFormat(
                        width=texture.shape[1],
                        height=texture.shape[0],
                        color_model="RGB",
                        channel_datatype="U8",
                    ),
                ),
                static=True,
            )
        for side, camera in zip(("left", "right"), layout.cameras, strict=True):
            rec.log(
                f"cameras/{side}",
                rr.Pinhole(
                    image_from_camera=camera.camera_matrix,
                    resolution=camera.image_size,
                    image_plane_distance=0.08,
                ),
                static=True,
            )
        rec.log("cell/tcp", rr.Points3D.from_fields(colors=[TCP_RGB], radii=[0.008]), static=True)
        rec.log("cell/tcp_path", rr.LineStrips3D.from_fields(colors=[TCP_RGB], radii=[0.002]), static=True)
        lower, upper = layout.joint_lower, layout.joint_upper
        if not (len(layout.joint_names) == len(lower) == len(upper) == len(layout.joint_velocity)):
            raise ValueError("a layout needs one position and velocity limit per joint name")
        for kind in JOINT_SERIES:
            self._rec.log(
                f"signals/joints/{kind}", rr.SeriesLines(names=list(layout.joint_names)), static=True
            )
        self._series("signals/joints/limit_high", "limit", (255, 80, 80))
        self._series("signals/joints/limit_low", "limit", (255, 80, 80))

    def log_target(self, outline_model: tuple[FloatArray, ...], grasp_radius: float = 0.006) -> None:
        """Logs the target model's S_in outline in Σ_M under each `cloth/*` pose (static)."""
        rr, rec = self.rr, self._rec
        strips = [np.vstack([p, p[:1]]) for p in outline_model]
        for name, rgb in (("recognised", RECOGNISED_RGB), ("filtered", FILTERED_RGB), ("true", TRUE_RGB)):
            rec.log(f"cloth/{name}", rr.TransformAxes3D(0.05), static=True)
            rec.log(
                f"cloth/{name}/outline", rr.LineStrips3D(strips, colors=[rgb], radii=[0.0015]), static=True
            )
        rec.log(
            "cloth/grasp_point",
            rr.Points3D.from_fields(colors=[GRASP_RGB], radii=[grasp_radius]),
            static=True,
        )
        for side in ("left", "right"):
            for name, rgb in (("recognised", RECOGNISED_RGB), ("true", TRUE_RGB)):
                rec.log(
                    f"cameras/{side}/outline/{name}",
                    rr.LineStrips2D.from_fields(colors=[rgb], radii=[1.0]),
                    static=True,
                )
        self._series("signals/recognition/fitness", "fitness", RECOGNISED_RGB)
        self._series("signals/recognition/confidence", "confidence", (120, 220, 120))
        self._series("signals/recognition/visible_fraction", "visible fraction", (150, 150, 255))
        for axis, rgb in (("x_mm", (255, 90, 90)), ("y_mm", (90, 255, 90)), ("z_mm", (90, 140, 255))):
            self._series(f"signals/error/{axis}", axis, rgb)
        self._series("signals/error_yaw_deg", "yaw error [deg]", (255, 200, 0))

    # ------------------------------------------------------------------ temporal
    def log_joints(self, time: float, q: npt.ArrayLike, dq: npt.ArrayLike) -> None:
        """Buffers one joint sample: positions [rad] and velocities [rad/s] at cell time [s]."""
        self._joint_times.append(float(time))
        self._q.append(np.asarray(q, dtype=float))
        self._dq.append(np.asarray(dq, dtype=float))

    def log_scene(self, sample: SceneSample) -> None:
        """Buffers the link poses, the TCP and the cloths' nodes of one scene sample."""
        columns, time = self._columns, sample.time
        for link, pose in sample.link_poses.items():
            columns.add(f"cell/robot/{link}", "pose", time, pose)
        columns.add("cell/tcp", "point", time, sample.tcp)
        self._tcp_path.append(np.asarray(sample.tcp, dtype=float))
        for label, nodes in sample.cloth_nodes.items():
            columns.add(f"cell/cloths/{label}", "mesh", time, np.asarray(nodes, dtype=np.float32))
        self._last_time = max(self._last_time, time)
        self._flush_if_full()

    def log_phase(self, record: PhaseRecord) -> None:
        """A finished phase as a text entry at its end."""
        note = f": {record.note}" if record.note else ""
        text = f"{record.phase} {record.start_time:.2f}-{record.end_time:.2f} s{note}"
        self._columns.add("log/phases", "text", record.end_time, (text, "INFO"))
        if self._tcp_path:  # the path so far, growing phase by phase
            self._columns.add("cell/tcp_path", "path", record.end_time, np.asarray(self._tcp_path))
        self._last_time = max(self._last_time, record.end_time)
        self._flush_if_full()

    def log_vision_cycle(
        self,
        cycle: VisionCycle,
        transform_left_camera_to_world: FloatArray,
        recognised: ProjectedOutline,
        true: ProjectedOutline | None = None,
        transform_true_to_world: FloatArray | None = None,
    ) -> None:
        """One vision cycle on both timelines: images, outlines, poses, signals, a text entry.

        Args:
            cycle: what the loop saw and concluded.
            transform_left_camera_to_world: (4, 4) ^W T_CL at capture [m].
            recognised: S_in's outline in both images under the recognised pose [px].
            true: the same under the true pose (simulation), or None.
            transform_true_to_world: (4, 4) true ^W T_M at capture (simulation), or None.
        """
        capture, record, recognition = cycle.capture, cycle.record, cycle.recognition
        t, n = capture.time, self.cycles

        def add(entity: str, kind: Kind, value: object) -> None:
            self._columns.add(entity, kind, t, value, cycle=n)

        true_left, true_right = (true.left, true.right) if true is not None else (None, None)
        cameras = (
            ("left", capture.left_bgr, transform_left_camera_to_world, recognised.left, true_left),
            (
                "right",
                capture.right_bgr,
                capture.transform_right_camera_to_world,
                recognised.right,
                true_right,
            ),
        )
        for side, image, pose, outline, truth in cameras:
            ok, jpeg = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, self.jpeg_quality])
            if not ok:
                raise RuntimeError("OpenCV could not encode a camera image as JPEG")
            add(f"cameras/{side}", "pose", pose)
            add(f"cameras/{side}/image", "image", jpeg.tobytes())
            add(f"cameras/{side}/outline/recognised", "strips", _closed(outline))
            if truth is not None:
                add(f"cameras/{side}/outline/true", "strips", _closed(truth))
        add("cloth/recognised", "pose", cycle.transform_model_to_world)
        if transform_true_to_world is not None:
            add("cloth/true", "pose", transform_true_to_world)
        grasp_frame = cycle.transform_model_to_world
        if cycle.filtered is not None:
            grasp_frame = cycle.filtered.as_transform()
            add("cloth/filtered", "pose", grasp_frame)
            residual = np.linalg.norm(cycle.transform_model_to_world[:3, 3] - cycle.filtered.position)
            add("signals/filter/residual_mm", "scalar", 1e3 * residual)
        add("cloth/grasp_point", "point", grasp_frame[:3, :3] @ cycle.grasp_point_model + grasp_frame[:3, 3])
        if math.isfinite(cycle.nis):
            add("signals/filter/nis", "scalar", cycle.nis)
        add("signals/recognition/fitness", "scalar", recognition.fitness)
        add("signals/recognition/confidence", "scalar", recognition.confidence)
        add("signals/recognition/visible_fraction", "scalar", recognition.visible_fraction)
        for axis in ("x_mm", "y_mm", "z_mm", "yaw_deg"):
            value = getattr(record, f"error_{axis}")
            if value is not None:
                add(
                    f"signals/error/{axis}" if axis != "yaw_deg" else "signals/error_yaw_deg", "scalar", value
                )
        verdict = "accepted" if record.accepted else "rejected"
        text = (
            f"#{n} {record.mode}: fitness {recognition.fitness:.3f}, "
            f"confidence {recognition.confidence:.2f}, {'found' if record.found else 'not found'}, "
            f"{verdict} ({record.reason})"
        )
        add("log/recognitions", "text", (text, "INFO" if record.accepted else "WARN"))
        self.cycles += 1
        self._last_time = max(self._last_time, t)
        self._flush_if_full()

    def log_outcome(self, time: float, text: str, success: bool) -> None:
        """The episode's (or a task's) outcome as a text entry at cell time [s]."""
        self._columns.add("log/outcome", "text", time, (text, "INFO" if success else "ERROR"))
        self._last_time = max(self._last_time, time)

    # ------------------------------------------------------------------ buffers
    def flush(self) -> None:
        """Sends everything buffered: joint samples, scene samples, vision cycles, text."""
        if self._joint_times and self._layout is not None:
            self._send_joints(self._layout)
        self._columns.flush()

    def close(self) -> None:
        """Sends what is buffered and finalises the file (idempotent)."""
        if self._closed:
            return
        try:
            self.flush()
        finally:
            self._closed = True
            self._rec.flush()
            self._rec.disconnect()

    def __enter__(self) -> EpisodeRecorder:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()

    # ------------------------------------------------------------------ helpers
    def _flush_if_full(self) -> None:
        if self._columns.pending + len(self._joint_times) > FLUSH_ROWS:
            self.flush()

    def _send_joints(self, layout: CellLayout) -> None:
        times = np.asarray(self._joint_times)
        q, dq = np.asarray(self._q), np.asarray(self._dq)
        mid = (layout.joint_upper + layout.joint_lower) / 2
        half = (layout.joint_upper - layout.joint_lower) / 2
        series = {
            "position": q,
            "velocity": dq,
            "position_of_range": (q - mid) / half,  # -1 and 1 are the limits
            "velocity_of_limit": dq / layout.joint_velocity,
        }
        for kind in JOINT_SERIES:  # one entity per kind, one plot line per joint
            self._columns.send_series(f"signals/joints/{kind}", times, series[kind])
        for name, value in (("limit_high", 1.0), ("limit_low", -1.0)):
            self._columns.send_series(f"signals/joints/{name}", times[[0, -1]], [value, value])
        self._joint_times.clear()
        self._q.clear()
        self._dq.clear()

    def _log_shapes(self, entity: str, shapes: tuple[Shape, ...]) -> None:
        rr, rec = self.rr, self._rec
        for kind in ("box", "cylinder", "sphere"):
            group = [s for s in shapes if s.kind == kind]
            if not group:
                continue
            centres = [s.pose[:3, 3] for s in group]
            quaternions = [rr.Quaternion(xyzw=quaternion_xyzw_from_matrix(s.pose[:3, :3])) for s in group]
            colours = [s.rgba for s in group]
            solid = rr.components.FillMode.Solid
            archetype: Any
            if kind == "box":
                archetype = rr.Boxes3D(
                    sizes=[s.size for s in group],
                    centers=centres,
                    quaternions=quaternions,
                    colors=colours,
                    fill_mode=solid,
                )
            elif kind == "cylinder":
                archetype = rr.Cylinders3D(
                    lengths=[s.size[2] for s in group],
                    radii=[s.size[0] for s in group],
                    centers=centres,
                    quaternions=quaternions,
                    colors=colours,
                    fill_mode=solid,
                )
            else:
                archetype = rr.Ellipsoids3D(
                    half_sizes=[[s.size[0]] * 3 for s in group],
                    centers=centres,
                    colors=colours,
                    fill_mode=solid,
                )
            rec.log(f"{entity}/{PLURAL[kind]}", archetype, static=True)

    def _series(self, entity: str, name: str, rgb: tuple[int, int, int]) -> None:
        self._rec.log(entity, self.rr.SeriesLines(names=name, colors=[rgb]), static=True)


def _closed(polygons: tuple[FloatArray, ...]) -> list[FloatArray]:
    return [np.vstack([p, p[:1]]) for p in polygons if len(p)]


__all__ = ["INSTALL_HINT", "RERUN_RANGE", "EpisodeRecorder", "require_rerun"]
