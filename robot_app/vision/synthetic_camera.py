"""Camera realism for the synthetic renderer: exposure, white balance, shading, noise, blur, JPEG.

A real hand camera does not give the renderer's exact colours: its gain and the light level
change the exposure, its white balance tints every channel, the light falls off smoothly
across the view, and the picture is noisy, a little out of focus and JPEG-compressed. The
ranges of `CameraRealism.draw` are those of the simulated cell's camera model (issue 14):
gain 0.65-1.35, white balance 0.88-1.12 per channel, smooth shading, noise sigma up to 7
grey levels, blur sigma up to 1.2 px, JPEG quality 70-92.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray

Image = npt.NDArray[np.uint8]


@dataclass(frozen=True)
class CameraRealism:
    """One camera's imaging, drawn once per scene (both cameras share gain, white balance
    and shading; noise and JPEG are drawn per image).

    Attributes:
        gain: overall exposure factor.
        white_balance: (3,) factors of the b, g, r channels.
        shading: peak-to-peak amplitude of the smooth brightness variation across the view
            (0.2: the corners up to 20 % darker than the brightest part).
        noise_sigma: pixel noise [grey levels].
        blur_sigma: Gaussian blur [px] (0: none).
        jpeg_quality: JPEG quality 1-100, or None for no compression.
    """

    gain: float = 1.0
    white_balance: tuple[float, float, float] = (1.0, 1.0, 1.0)
    shading: float = 0.0
    noise_sigma: float = 2.0
    blur_sigma: float = 0.0
    jpeg_quality: int | None = None

    @classmethod
    def draw(cls, rng: np.random.Generator) -> CameraRealism:
        """A camera drawn uniformly from the realistic ranges (see the module docstring)."""
        return cls(
            gain=float(rng.uniform(0.65, 1.35)),
            white_balance=tuple(float(v) for v in rng.uniform(0.88, 1.12, 3)),  # type: ignore[arg-type]
            shading=float(rng.uniform(0.0, 0.3)),
            noise_sigma=float(rng.uniform(0.0, 7.0)),
            blur_sigma=float(rng.uniform(0.0, 1.2)),
            jpeg_quality=int(rng.integers(70, 93)),
        )

    def image(
        self, radiance_bgr: npt.NDArray[np.float32], rng: np.random.Generator, shade: FloatArray
    ) -> Image:
        """The camera's picture of a float BGR image (0-255 at gain 1), `shade` (H, W) the
        smooth brightness field of this scene."""
        image = radiance_bgr * (self.gain * np.asarray(self.white_balance, np.float32))[None, None, :]
        image = image * shade[..., None].astype(np.float32)
        if self.blur_sigma > 0:
            image = np.asarray(cv2.GaussianBlur(image, (0, 0), self.blur_sigma), dtype=np.float32)
        if self.noise_sigma > 0:
            image = image + rng.normal(0.0, self.noise_sigma, image.shape).astype(np.float32)
        out = np.clip(np.rint(image), 0, 255).astype(np.uint8)
        if self.jpeg_quality is not None:
            ok, data = cv2.imencode(".jpg", out, [cv2.IMWRITE_JPEG_QUALITY, int(self.jpeg_quality)])
            if not ok:
                raise RuntimeError("JPEG encoding failed")
            out = np.asarray(cv2.imdecode(data, cv2.IMREAD_COLOR), dtype=np.uint8)
        return out

    def shade_field(self, image_size: tuple[int, int], rng: np.random.Generator) -> FloatArray:
        """(H, W) smooth brightness factors in [1 - shading, 1] (a low-order random surface)."""
        width, height = image_size
        if self.shading <= 0:
            return np.ones((height, width))
        coarse = rng.uniform(0.0, 1.0, (3, 4)).astype(np.float32)
        field = cv2.resize(coarse, (width, height), interpolation=cv2.INTER_CUBIC).astype(float)
        span = max(float(np.ptp(field)), 1e-6)
        return np.asarray(1.0 - self.shading * (field.max() - field) / span)


__all__ = ["CameraRealism"]
