"""Stereo depth check: how far is the cloth's plane, by the stereo pair alone?

The hue fitness knows the cloth's size only through the model: a model seen smaller and
farther away fills nearly the same pixels of one image, and in the other it is off by
the disparity error only (about 0.17 px per mm at 580 mm). When part of the cloth's
outline is missing (a corner folded under, showing its back side), the search can trade
that small disparity error for a better fit of a shrunk model onto the rest of the
cloth: on the synthetic bench such results were 20-80 mm too far.

The plane sweep here does not use the model's size at all. It takes the right-image
pixels around the pose's footprint that have a horizontal grey gradient (edges and
texture: the pixels whose left-image counterpart moves visibly with depth), moves them
onto the left image through the pose's plane at a range of depths along the rays of the
right camera, and scores each depth by the zero-mean normalised cross-correlation of
the grey values (invariant to gain and offset between the cameras). Everything lying on
the table shares the plane, so the sheet's own edges and other cloths near the footprint
help rather than hurt. The depth with the highest correlation (coarse steps over the
whole range, then fine steps around the best, a parabola through the best three) is the
stereo depth of the pose's origin.

`StereoDepth.measure` returns that depth offset with how sure it is: enough edge pixels,
a correlation peak high enough and clearly above the correlation at the pose's own
depth. `StereoDepth.fit_plane` also sweeps the plane's tilt about the camera's x and y
axes (from the pose's plane and from one facing the camera): the plane the pair shows,
whatever the pose's own depth and tilt. The recogniser (`Recognizer`) takes a sure small
offset as the depth; when the offset is large or the pose's plane explains the pair
poorly, it fits the stereo plane and searches the pose again on it
(`plane_search.py`), where a model of the wrong size cannot fit.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt
from pydantic import Field

from robot_app.arrays import FloatArray
from robot_app.config import StrictModel
from robot_app.vision.camera import StereoRig
from robot_app.vision.cloth_model import ClothModel
from robot_app.vision.plane_search import PlaneSearchSettings
from robot_app.vision.stereo_depth_kernels import edge_samples, reached_box, sweep


class DepthCheckSettings(StrictModel):
    """The stereo depth check.

    Attributes:
        enabled: measure the depth of the final pose by the plane sweep.
        fine_range: the first sweep covers the pose's depth and this on either side [m].
        fine_step: its step [m]; a parabola through the best three gives the offset.
        search_range: when the first sweep peaks at its end, a coarse sweep covers this
            on either side of the pose's depth [m], and a fine one its best.
        coarse_step: the coarse sweep's step [m].
        smoothing: side of the box filter both images are smoothed with [px] (camera
            noise of sigma 7 would otherwise pass the gradient test all over the sheet);
            1: none.
        pixel_step: right-image pixels looked at every this many in each direction [px].
        margin: pixels around the model's footprint looked at too [px].
        min_gradient: a pixel counts if its horizontal grey gradient (central difference)
            is at least this [grey levels].
        max_samples: at most this many pixels are swept (evenly thinned) [-].
        min_samples: fewer edge pixels: the depth is not measured.
        min_correlation: the best correlation must reach this to be trusted.
        min_gain: ... and exceed the correlation at the pose's own depth by this, unless
            the offset is within `adopt_within`.
        adopt_within: a trusted offset up to this is taken as the depth (the pose moves
            along the ray through its origin) [m].
        research_beyond: an offset beyond this, or a correlation below `min_correlation`,
            means the pose's plane is not the one the pair shows: the recogniser fits the
            stereo plane (`fit_plane`) and, if that explains the pair clearly better
            (`min_gain`), searches the pose again on it (`research`) [m].
        research: the search on the stereo plane (`plane_search.py`); `enabled: false`
            for none.
        plane_tilt_range: `fit_plane` sweeps the tilt this far about each camera axis [deg].
        plane_tilt_step: ... in these steps, then a third of them around the best [deg].
        plane_rounds: rounds of depth and tilt sweeps.
    """

    enabled: bool = True
    fine_range: float = Field(default=0.004, gt=0.0, le=0.05)
    fine_step: float = Field(default=0.0005, gt=0.0)
    search_range: float = Field(default=0.06, gt=0.0, le=0.2)
    coarse_step: float = Field(default=0.004, gt=0.0)
    smoothing: int = Field(default=3, ge=1, le=9)
    pixel_step: int = Field(default=3, ge=1, le=16)
    margin: int = Field(default=12, ge=0, le=100)
    min_gradient: float = Field(default=8.0, ge=0.0)
    max_samples: int = Field(default=600, ge=16)
    min_samples: int = Field(default=100, ge=16)
    min_correlation: float = Field(default=0.8, ge=-1.0, le=1.0)
    min_gain: float = Field(default=0.05, ge=0.0, le=2.0)
    adopt_within: float = Field(default=0.008, ge=0.0)
    research_beyond: float = Field(default=0.012, ge=0.0)
    research: PlaneSearchSettings = PlaneSearchSettings()
    plane_tilt_range: float = Field(default=15.0, gt=0.0, le=45.0)
    plane_tilt_step: float = Field(default=1.5, gt=0.0, le=10.0)
    plane_rounds: int = Field(default=3, ge=1, le=10)


@dataclass(frozen=True)
class DepthMeasurement:
    """The stereo depth of a pose's plane.

    Attributes:
        offset: stereo depth minus the pose's depth, at the model origin [m] (NaN: not measured).
        correlation: the correlation at the stereo depth (-1 to 1; NaN: not measured).
        correlation_at_pose: the correlation at the pose's own depth.
        samples: edge pixels swept.
        trusted: the measurement passes `min_samples`, `min_correlation` and `min_gain`.
    """

    offset: float
    correlation: float
    correlation_at_pose: float
    samples: int
    trusted: bool


@dataclass(frozen=True)
class StereoPlane:
    """The plane the stereo pair shows around a pose: n·X = distance in Σ_CR.

    Attributes:
        normal: (3,) unit normal, pointing away from the camera like the model's z axis.
        distance: [m].
        correlation: the correlation through this plane.
        correlation_at_pose: the correlation through the pose's own plane.
        trusted: `correlation` reaches `min_correlation` with enough edge pixels.
    """

    normal: FloatArray
    distance: float
    correlation: float
    correlation_at_pose: float
    trusted: bool


class _Sweep:
    """Edge pixels of the right image around one pose and the left crop they can reach."""

    def __init__(self, pixels: FloatArray, values: FloatArray, left: npt.NDArray[np.uint8],
                 left_origin: npt.NDArray[np.int64], depth: StereoDepth) -> None:  # fmt: skip
        self.pixels, self.values, self.left, self.left_origin = pixels, values, left, left_origin
        self.depth = depth

    def scores(self, planes: FloatArray) -> FloatArray:
        rig = self.depth.rig
        arguments = (self.depth.left_from_right, self.pixels, self.values, self.left, self.left_origin)
        return np.asarray(sweep(np.ascontiguousarray(planes), rig.left.camera_matrix,
                                rig.right.camera_matrix, *arguments))  # fmt: skip


class StereoDepth:
    """The plane sweep of one model on one rig; `update` takes a pair.

    Args:
        model: the cloth model (its points give the footprint).
        rig: the stereo rig (the images are undistorted as the fitness's are).
        settings: the sweep.
    """

    def __init__(self, model: ClothModel, rig: StereoRig, settings: DepthCheckSettings) -> None:
        self.rig = rig
        self.settings = settings
        points = np.vstack([model.points_in, model.points_out])[:, :2].astype(np.float32)
        hull = cv2.convexHull(points).reshape(-1, 2).astype(float)
        self._outline = np.column_stack([hull, np.zeros(len(hull))])  # the model's convex outline in Σ_M
        self._images: tuple[npt.NDArray[np.uint8], npt.NDArray[np.uint8]] | None = None
        self.left_from_right = np.ascontiguousarray(rig.transform_right_to_left)

    def update(self, image_left_bgr: npt.NDArray[np.uint8], image_right_bgr: npt.NDArray[np.uint8]) -> None:
        """Takes the pair (BGR, the rig's size), undistorted if the rig says so."""
        images = []
        for image, camera in ((image_left_bgr, self.rig.left), (image_right_bgr, self.rig.right)):
            array = np.ascontiguousarray(image)
            if camera.has_distortion:
                K = camera.camera_matrix
                array = np.asarray(cv2.undistort(array, K, camera.dist_coeffs, None, K), dtype=np.uint8)
            images.append(array)
        self._images = (images[0], images[1])

    def measure(self, transform_model_to_camera: FloatArray) -> DepthMeasurement:
        """The stereo depth of the plane of a pose ^CR T_M (see the module docstring): a fine
        sweep around the pose's depth, and the coarse sweep over the whole range only when
        the fine one peaks at its end.

        Raises:
            RuntimeError: no pair yet (call `update`).
        """
        pose = np.ascontiguousarray(transform_model_to_camera, dtype=float)
        prepared = self._prepare(pose)
        if isinstance(prepared, int):
            return DepthMeasurement(float("nan"), float("nan"), float("nan"), prepared, False)
        normal = pose[:3, 2]
        offset, best, at_pose = self._depth(prepared, normal, pose[:3, 3])
        s = self.settings
        near = abs(offset) <= s.adopt_within
        trusted = best >= s.min_correlation and (near or best - at_pose >= s.min_gain)
        return DepthMeasurement(offset, best, at_pose, len(prepared.values), bool(trusted))

    def fit_plane(self, transform_model_to_camera: FloatArray) -> StereoPlane | None:
        """The plane around a pose's footprint that best explains the pair, whatever the
        pose's own depth and tilt: its depth (along the ray through the pose's origin) and
        its tilt about the camera's x and y axes, each swept in turn, `plane_rounds` times,
        each round finer (`plane_tilt_range`, `plane_tilt_step`), from the pose's plane and
        from one facing the camera; the better. None: too few edge pixels.

        Raises:
            RuntimeError: no pair yet (call `update`).
        """
        pose = np.ascontiguousarray(transform_model_to_camera, dtype=float)
        prepared = self._prepare(pose)
        if isinstance(prepared, int):
            return None
        s = self.settings
        at_pose = float(prepared.scores(np.append(pose[:3, 2], pose[:3, 2] @ pose[:3, 3])[None])[0])
        fits = [self._ascend(prepared, start, pose[:3, 3].copy()) for start in (pose[:3, 2], _FACING)]
        normal, origin, best = max(fits, key=lambda fit: fit[2])
        trusted = best >= s.min_correlation
        return StereoPlane(normal, float(normal @ origin), best, at_pose, bool(trusted))

    def sweep_mask(
        self,
        mask: npt.NDArray[np.bool_],
        planes: FloatArray,
        pixel_step: int = 1,
        min_gradient: float | None = None,
    ) -> tuple[FloatArray, int]:
        """Correlations through each of `planes` ((D, 4): unit normal n, distance d, n·X = d
        in Σ_CR) of the right-image pixels in `mask` ((H, W) bool) that have a horizontal
        grey gradient of at least `min_gradient` (None: the settings'), every `pixel_step`
        pixels; and how many such pixels there are. A local surface (the top cloth of a
        pile around a grasp point) rather than the model's footprint; the pose plays no
        part. (D,) -2 where fewer than 16 pixels were found or land in the left image.

        Raises:
            RuntimeError: no pair yet (call `update`).
        """
        if self._images is None:
            raise RuntimeError("no stereo pair to measure on: call update(left, right) first")
        planes = np.ascontiguousarray(planes, dtype=float).reshape(-1, 4)
        v, u = np.nonzero(mask)
        if not len(u):
            return np.full(len(planes), -2.0), 0
        s = self.settings
        gradient = s.min_gradient if min_gradient is None else float(min_gradient)
        box = np.array([u.min(), v.min(), u.max(), v.max()], dtype=np.int64)
        right, right_origin = _smoothed_crop(self._images[1], box, s.smoothing)
        pixels, values = edge_samples(right, box - np.tile(right_origin, 2), pixel_step, gradient)
        pixels += right_origin
        inside = mask[pixels[:, 1].astype(np.int64), pixels[:, 0].astype(np.int64)]
        pixels, values = np.ascontiguousarray(pixels[inside]), np.ascontiguousarray(values[inside])
        if len(values) < 16:
            return np.full(len(planes), -2.0), len(values)
        height, width = self._images[0].shape[:2]
        left, left_origin = _smoothed_crop(
            self._images[0], np.array([0, 0, width - 1, height - 1]), s.smoothing
        )
        prepared = _Sweep(pixels, values, left, left_origin, self)
        return prepared.scores(planes), len(values)

    def _ascend(
        self, prepared: _Sweep, normal: FloatArray, origin: FloatArray
    ) -> tuple[FloatArray, FloatArray, float]:
        """Depth, then tilt about camera x, then about y, `plane_rounds` times, each round's
        tilt steps a third of the last's: the (normal, point, correlation) reached."""
        s = self.settings
        normal = np.asarray(normal, dtype=float).copy()
        best = -2.0
        tilt_range, tilt_step = np.deg2rad(s.plane_tilt_range), np.deg2rad(s.plane_tilt_step)
        for _ in range(s.plane_rounds):
            offset, best, _ = self._depth(prepared, normal, origin)
            origin = origin * (origin[2] + offset) / origin[2]
            for axis in (0, 1):
                angles = np.arange(-tilt_range, tilt_range + 1e-12, tilt_step)
                turned = np.array([_rotation(axis, a) @ normal for a in angles])
                scores = prepared.scores(np.column_stack([turned, turned @ origin]))
                j = int(np.argmax(scores))
                if scores[j] > best:
                    normal, best = turned[j], float(scores[j])
            tilt_range, tilt_step = 2.0 * tilt_step, tilt_step / 3.0
        offset, best, _ = self._depth(prepared, normal, origin)
        return normal, origin * (origin[2] + offset) / origin[2], best

    def _prepare(self, pose: FloatArray) -> _Sweep | int:
        """The sweep's samples around `pose`, or their number when too few."""
        if self._images is None:
            raise RuntimeError("no stereo pair to measure on: call update(left, right) first")
        s = self.settings
        box = self._footprint(pose)
        if box[2] - box[0] < 4 or box[3] - box[1] < 4:
            return 0
        right, right_origin = _smoothed_crop(self._images[1], box, s.smoothing)
        local = box - np.tile(right_origin, 2)
        pixels, values = edge_samples(right, local, s.pixel_step, s.min_gradient)
        pixels += right_origin
        if len(values) > s.max_samples:
            keep = np.linspace(0, len(values) - 1, s.max_samples).round().astype(np.int64)
            pixels, values = np.ascontiguousarray(pixels[keep]), np.ascontiguousarray(values[keep])
        if len(values) < s.min_samples:
            return len(values)
        z = float(pose[2, 3])
        low = max(-s.search_range, 0.05 - z)  # stay in front of the camera
        width, height = self.rig.image_size
        K_left, K_right = self.rig.left.camera_matrix, self.rig.right.camera_matrix
        scales = ((z + low) / z, (z + s.search_range) / z)
        reached = reached_box(pose, box, K_left, K_right, self.left_from_right, *scales, width, height)
        left, left_origin = _smoothed_crop(self._images[0], reached, s.smoothing)
        return _Sweep(pixels, values, left, left_origin, self)

    def _depth(self, prepared: _Sweep, normal: FloatArray, origin: FloatArray) -> tuple[float, float, float]:
        """(offset [m], its correlation, the correlation at offset 0) of the plane through
        `origin` with `normal` moved along the ray through `origin`."""
        s = self.settings
        z = float(origin[2])
        distance = float(normal @ origin)

        def scores_at(offsets: FloatArray) -> FloatArray:
            scales = (z + offsets) / z
            return prepared.scores(np.column_stack([np.tile(normal, (len(offsets), 1)), distance * scales]))

        half = round(s.fine_range / s.fine_step)
        fine = np.arange(-half, half + 1, dtype=float) * s.fine_step
        scores = scores_at(fine)
        at_pose = float(scores[half])
        j = int(np.argmax(scores))
        if j in (0, len(fine) - 1):  # the peak is farther: the whole range, then fine around its best
            low = max(-s.search_range, 0.05 - z)
            coarse = np.arange(low, s.search_range + 1e-12, s.coarse_step, dtype=float)
            centre = float(coarse[int(np.argmax(scores_at(coarse)))])
            fine = centre + np.arange(-half, half + 1, dtype=float) * s.fine_step
            scores = scores_at(fine)
            j = int(np.argmax(scores))
        offset = float(fine[j]) + peak_shift(scores, j, s.fine_step)
        return offset, float(scores[j]), at_pose

    def _footprint(self, pose: FloatArray) -> npt.NDArray[np.int64]:
        """(u0, v0, u1, v1) box of the model's points in the right image, with the margin."""
        X = self._outline @ pose[:3, :3].T + pose[:3, 3]
        X = X[X[:, 2] > 1e-6]
        width, height = self.rig.image_size
        if not len(X):
            return np.array([0, 0, -1, -1], dtype=np.int64)
        uv = (
            X[:, :2] / X[:, 2:] @ self.rig.right.camera_matrix[:2, :2].T + self.rig.right.camera_matrix[:2, 2]
        )
        m = self.settings.margin
        box = np.array([uv[:, 0].min() - m, uv[:, 1].min() - m, uv[:, 0].max() + m, uv[:, 1].max() + m])
        box = np.clip(np.floor(box), [0, 0, 0, 0], [width - 1, height - 1, width - 1, height - 1])
        return box.astype(np.int64)


_FACING = np.array([0.0, 0.0, 1.0])  # a plane facing the camera


def peak_shift(scores: npt.ArrayLike, j: int, step: float) -> float:
    """Where the parabola through `scores[j - 1 : j + 2]` peaks, relative to sample `j` [same
    unit as `step`, the samples' spacing]; 0 at either end or where the three do not bend down."""
    values = np.asarray(scores, dtype=float)
    if not 0 < j < len(values) - 1:
        return 0.0
    a, b, c = values[j - 1], values[j], values[j + 1]
    curvature = a - 2.0 * b + c
    return 0.5 * float(a - c) / float(curvature) * step if curvature < 0 else 0.0


def _rotation(axis: int, angle: float) -> FloatArray:
    """(3, 3) rotation by `angle` [rad] about camera axis x (0) or y (1)."""
    c, s = np.cos(angle), np.sin(angle)
    if axis == 0:
        return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _smoothed_crop(
    image_bgr: npt.NDArray[np.uint8], box: npt.NDArray[np.int64], smoothing: int
) -> tuple[npt.NDArray[np.uint8], npt.NDArray[np.int64]]:
    """The part of `image_bgr` inside `box` (u0, v0, u1, v1, inclusive) with a border for
    the filter, box-filtered over `smoothing` pixels, and the full-image (u, v) of its
    pixel (0, 0)."""
    border = smoothing // 2 + 1
    height, width = image_bgr.shape[:2]
    u0, v0 = max(int(box[0]) - border, 0), max(int(box[1]) - border, 0)
    u1, v1 = min(int(box[2]) + border, width - 1), min(int(box[3]) + border, height - 1)
    crop = np.ascontiguousarray(image_bgr[v0 : v1 + 1, u0 : u1 + 1])
    if smoothing > 1:
        crop = np.asarray(cv2.blur(crop, (smoothing, smoothing)), dtype=np.uint8)
    return crop, np.array([u0, v0], dtype=np.int64)


__all__ = ["DepthCheckSettings", "DepthMeasurement", "StereoDepth", "StereoPlane", "peak_shift"]
