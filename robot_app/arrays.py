"""Array type aliases shared by every package (numpy.typing at the module boundaries)."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
"""A float64 array; its shape is given where it is used, e.g. "(N, 3) points [m]"."""

ImageBGR = npt.NDArray[np.uint8]
"""An (H, W, 3) uint8 colour image in OpenCV's BGR channel order."""

__all__ = ["FloatArray", "ImageBGR"]
