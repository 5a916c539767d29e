"""A camera between the renderer and the image: exposure, colour, noise, blur, JPEG, timing.

The renderer's image is taken as the light reaching the sensor at unit gain (0-1). A
camera then applies, in the order a real one does: vignetting; motion blur along the
image motion during the exposure; the exposure gain (fixed, or auto-exposure that
meters each frame and follows with a time constant, so it lags the scene) and lamp
flicker; photon noise (variance = signal in electrons) and read noise; white balance
gains per channel; 8-bit quantisation; JPEG. Everything random comes from the camera's
own seeded generator: the same seed and the same captures give the same images.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

from robot_app.sim.realism import ImagingSettings, StationImagingSettings

Image = npt.NDArray[np.uint8]
GAIN_LIMITS = (1.0 / 16.0, 16.0)
LUMA_BGR = np.array([0.114, 0.587, 0.299], dtype=np.float32)


@dataclass(frozen=True)
class Exposure:
    """What a camera did to one frame.

    Attributes:
        gain: exposure gain applied (1 = the renderer's brightness).
        blur_px: length of the motion blur [px].
    """

    gain: float
    blur_px: float


class CameraModel:
    """One physical camera's imaging, with its state (auto-exposure gain, generator).

    Args:
        settings: the camera's imaging settings.
        seed: seed of its noise, white balance and exposure errors.
        white_point_rgb: colour of the lamp the white balance was set for (linear RGB);
            gains make it grey, before the camera's own errors.
    """

    def __init__(
        self,
        settings: ImagingSettings | StationImagingSettings,
        seed: int | tuple[int, ...] = 0,
        white_point_rgb: tuple[float, float, float] = (1.0, 1.0, 1.0),
    ) -> None:
        self.settings = settings
        self._white_point = np.asarray(white_point_rgb, dtype=float)
        self._vignette: dict[tuple[int, int], npt.NDArray[np.float32]] = {}
        self.reset(seed)

    def reset(self, seed: int | tuple[int, ...]) -> None:
        """Restarts the camera: new generator, new white-balance error, exposure unknown."""
        self._rng = np.random.default_rng(seed)
        error = self._rng.normal(0.0, self.settings.white_balance_error, size=3)
        balance_rgb = self._white_point[1] / np.maximum(self._white_point, 1e-3) * np.exp(error)
        self.white_balance_bgr = balance_rgb[::-1].astype(np.float32)
        self.gain: float | None = None
        self._last_time: float | None = None

    @property
    def is_identity(self) -> bool:
        """True if the camera leaves the rendered image untouched (the clean preset)."""
        s = self.settings
        exposure = isinstance(s, StationImagingSettings) or (
            s.exposure == "fixed" and s.gain == 1.0 and s.flicker == 0.0 and s.exposure_time == 0.0
        )
        return (
            exposure
            and s.white_balance_error == 0.0
            and np.allclose(self.white_balance_bgr, 1.0)
            and s.vignetting == 0.0
            and s.full_well is None
            and s.noise_sigma == 0.0
            and s.jpeg_quality is None
        )

    def expose(
        self, rendered_bgr: Image, time: float = 0.0, blur_px: tuple[float, float] = (0.0, 0.0)
    ) -> tuple[Image, Exposure]:
        """The image this camera delivers for a rendered one.

        Args:
            rendered_bgr: (H, W, 3) uint8 image from the renderer.
            time: exposure time stamp [s] (auto-exposure follows the scene over time).
            blur_px: image motion during the exposure (du, dv) [px].
        """
        if self.is_identity:
            return rendered_bgr, Exposure(1.0, 0.0)
        s = self.settings
        counts = rendered_bgr.astype(np.float32)  # [DN] at unit gain
        if s.vignetting > 0:
            counts *= self._vignetting(counts.shape[1], counts.shape[0])[..., None]
        length = float(np.hypot(*blur_px))
        if length > 0.3:
            counts = motion_blur(counts, blur_px)
        gain = self._gain(counts, time)
        if isinstance(s, ImagingSettings) and s.flicker > 0:
            gain *= float(np.exp(self._rng.normal(0.0, s.flicker)))
        counts *= np.float32(gain)
        read_variance = np.float32((s.noise_sigma * gain) ** 2)
        if s.full_well is not None:  # photon noise: variance = signal [e-], in DN at this gain
            sigma = np.maximum(counts, 0.0) * np.float32(gain * 255.0 / s.full_well)
            sigma += read_variance
            np.sqrt(sigma, out=sigma)
            noise = self._rng.standard_normal(counts.shape, dtype=np.float32)
            noise *= sigma
            counts += noise
        elif read_variance > 0:
            counts += np.sqrt(read_variance) * self._rng.standard_normal(counts.shape, dtype=np.float32)
        counts *= self.white_balance_bgr
        np.rint(counts, out=counts)
        np.clip(counts, 0, 255, out=counts)
        image = counts.astype(np.uint8)
        if s.jpeg_quality is not None:
            image = jpeg_round_trip(image, s.jpeg_quality)
        return image, Exposure(gain, length)

    def _gain(self, signal: npt.NDArray[np.float32], time: float) -> float:  # signal [DN]
        """This frame's gain. Auto-exposure meters the frame and sets the gain of the next one:
        the log gain moves towards the wanted one by 1 - exp(-dt / time constant)."""
        s = self.settings
        if not isinstance(s, ImagingSettings) or s.exposure == "fixed":
            return float(s.gain) if isinstance(s, ImagingSettings) else 1.0
        metered = float(signal.reshape(-1, 3).mean(axis=0) @ LUMA_BGR) / 255.0
        wanted = s.target_level / max(metered, 1e-3)
        if self.gain is None or self._last_time is None:  # first frame: settled, with an error
            error = float(np.exp(self._rng.normal(0.0, s.ae_initial_error)))
            self.gain = float(np.clip(wanted * error, *GAIN_LIMITS))
            self._last_time = time
            return self.gain
        used = self.gain
        dt = max(0.0, time - self._last_time)
        rate = 1.0 if s.ae_time_constant == 0 else 1.0 - float(np.exp(-dt / s.ae_time_constant))
        self.gain = float(np.clip(used * (wanted / used) ** rate, *GAIN_LIMITS))
        self._last_time = time
        return used

    def _vignetting(self, width: int, height: int) -> npt.NDArray[np.float32]:
        """(H, W) relative illumination: 1 in the middle, 1 - vignetting in the corners."""
        key = (width, height)
        if key not in self._vignette:
            u = (np.arange(width) - (width - 1) / 2) / ((width - 1) / 2)
            v = (np.arange(height) - (height - 1) / 2) / ((height - 1) / 2)
            r2 = (u[None, :] ** 2 * width**2 + v[:, None] ** 2 * height**2) / (width**2 + height**2)
            self._vignette[key] = (1.0 - self.settings.vignetting * r2).astype(np.float32)
        return self._vignette[key]


@dataclass(frozen=True)
class FrameTiming:
    """When a frame arrives: its exposure, the time it is in memory, whether one was lost."""

    time: float
    available_time: float
    dropped: bool


class FrameClock:
    """Latency and lost frames of a (stereo) camera, from its own seeded generator."""

    def __init__(self, settings: ImagingSettings, seed: int | tuple[int, ...] = 0) -> None:
        self.settings = settings
        self.reset(seed)

    def reset(self, seed: int | tuple[int, ...]) -> None:
        self._rng = np.random.default_rng(seed)

    def timing(self, time: float) -> FrameTiming:
        """Timing of a frame exposed at `time` [s]."""
        s = self.settings
        latency = s.latency
        if s.latency_jitter > 0:
            latency = max(0.0, latency + s.latency_jitter * float(self._rng.standard_normal()))
        dropped = s.drop_probability > 0 and float(self._rng.random()) < s.drop_probability
        if dropped:  # the frame triggered now is lost: the next one comes a period later
            latency += 1.0 / s.frame_rate
        return FrameTiming(time, time + latency, bool(dropped))


def motion_blur(signal: npt.NDArray[np.float32], blur_px: tuple[float, float]) -> npt.NDArray[np.float32]:
    """The image averaged along a straight motion of (du, dv) pixels (a box over the exposure)."""
    du, dv = blur_px
    length = float(np.hypot(du, dv))
    size = int(np.ceil(length)) | 1
    kernel = np.zeros((size, size), np.float32)
    centre = (size - 1) / 2
    samples = max(2, int(np.ceil(length * 4)))
    for t in np.linspace(-0.5, 0.5, samples):
        x, y = centre + t * du, centre + t * dv
        x0, y0 = int(np.floor(x)), int(np.floor(y))
        fx, fy = x - x0, y - y0
        for xi, yi, w in ((x0, y0, (1 - fx) * (1 - fy)), (x0 + 1, y0, fx * (1 - fy)),
                          (x0, y0 + 1, (1 - fx) * fy), (x0 + 1, y0 + 1, fx * fy)):  # fmt: skip
            if 0 <= xi < size and 0 <= yi < size:
                kernel[yi, xi] += w
    kernel /= kernel.sum()
    return np.asarray(cv2.filter2D(signal, -1, kernel, borderType=cv2.BORDER_REFLECT), dtype=np.float32)


def jpeg_round_trip(image: Image, quality: int) -> Image:
    """The image after JPEG compression at `quality` (10-100) and decompression."""
    ok, encoded = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
    if not ok:
        raise RuntimeError("OpenCV could not JPEG-encode an image")
    return np.asarray(cv2.imdecode(encoded, cv2.IMREAD_COLOR), dtype=np.uint8)


def image_motion(
    velocity_camera: npt.ArrayLike, angular_velocity_camera: npt.ArrayLike, depth: float, focal_px: float
) -> tuple[float, float]:
    """Image velocity [px/s] at the image centre of a camera moving over a scene `depth` [m] away.

    Args:
        velocity_camera: (3,) the camera's velocity in its own (OpenCV) frame [m/s].
        angular_velocity_camera: (3,) its angular velocity in its frame [rad/s].
        depth: distance to the scene along the optical axis [m].
        focal_px: focal length [px].
    """
    v = np.asarray(velocity_camera, dtype=float)
    w = np.asarray(angular_velocity_camera, dtype=float)
    z = max(depth, 1e-3)
    return (
        float(focal_px * (-v[0] / z - w[1])),
        float(focal_px * (-v[1] / z + w[0])),
    )


__all__ = [
    "CameraModel",
    "Exposure",
    "FrameClock",
    "FrameTiming",
    "image_motion",
    "jpeg_round_trip",
    "motion_blur",
]
