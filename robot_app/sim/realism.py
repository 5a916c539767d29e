"""How real the simulated cell looks: light, cameras, cloth appearance, and three presets.

`world.realism` names a preset (`clean`, `realistic`, `harsh`) that only supplies the
defaults of the `world.lighting.*`, `world.imaging.*` and `world.appearance.*` keys
(and, through `scene_defaults`, of the scene's wrinkle and fold keys left null). A key
set in a YAML file or with `--set` wins over the preset. `clean` is the cell as it was
before these settings existed: straight-down light without shadows, ideal cameras,
flat cartoon cloths; its images are bit for bit the old ones.

Where the `realistic` and `harsh` numbers come from (typical values, not one product):
- read noise 1-2.5 DN and a full well of 6000-10000 e- at 8 bits: small-pixel CMOS
  machine-vision sensors (datasheets of 2-3 µm global-shutter sensors list 2-7 e- read
  noise and 6-11 ke- full well; 1 DN = full_well / 255 e- at unit gain);
- vignetting 25-45 % at the corners: the cos^4 fall-off of a 48° lens plus mechanical
  vignetting at wide apertures (0.4-0.9 EV);
- exposure 8-20 ms indoors under a lamp, latency 50-120 ms from exposure to the image in
  memory (USB3 / GigE cameras with driver buffering), a few % lost frames on a busy bus;
- JPEG quality 90 (a camera's or webcam's MJPEG "high") and 70 (a bandwidth-limited
  stream); white-balance errors of 3-8 % per channel after a grey-card or auto balance;
- a key light 30-50° off vertical with 25-35 % ambient fill, a warm LED or halogen colour.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, Field, field_validator

from robot_app.config import StrictModel

Realism = Literal["clean", "realistic", "harsh"]
REALISM_NAMES: tuple[str, ...] = ("clean", "realistic", "harsh")
DEFAULT_REALISM: Realism = "realistic"
CONFIGS = Path(__file__).resolve().parents[2] / "configs"
DEFAULT_IMAGE_SIZE = (640, 480)  # CameraSettings.image_size's default

Vec3 = tuple[float, float, float]
AngleRange = tuple[float, float]


def _ordered(value: AngleRange, low: float, high: float) -> AngleRange:
    if not low <= value[0] <= value[1] <= high:
        raise ValueError(f"must be [low, high] with {low} <= low <= high <= {high}")
    return value


class StationLightingSettings(StrictModel):
    """The model station's own lamp (paper Fig. 7), fixed: a photo studio, not the cell."""

    ambient: float = Field(0.6, ge=0.0, le=1.0, description="light from everywhere (share of full)")
    key: float = Field(0.4, ge=0.0, le=1.5, description="directional lamp, on a surface facing it")
    zenith_deg: float = Field(0.0, ge=0.0, le=80.0, description="lamp angle off vertical [deg]")
    azimuth_deg: float = Field(0.0, ge=-180.0, le=180.0, description="lamp direction about world z [deg]")
    key_rgb: Vec3 = Field((1.0, 1.0, 1.0), description="lamp colour, linear RGB gains 0-1")

    @field_validator("key_rgb")
    @classmethod
    def _colour(cls, value: Vec3) -> Vec3:
        if not all(0.0 <= c <= 1.0 for c in value):
            raise ValueError("key_rgb needs three gains in [0, 1]")
        return value


class LightingSettings(StrictModel):
    """Light of the cell: ambient fill plus one key lamp whose direction is drawn per scene.

    The renderer (pybullet's TinyRenderer) shades every surface with
    ambient + key · max(0, n·l) + specular; shadows of everything between a surface and
    the key lamp (arm, hand, gripper, cameras, box) take the key's share away.
    """

    ambient: float = Field(0.6, ge=0.0, le=1.0)
    key: float = Field(0.4, ge=0.0, le=1.5)
    key_zenith_deg: AngleRange = Field((0.0, 0.0), description="range of the key's angle off vertical [deg]")
    key_azimuth_deg: AngleRange = Field((0.0, 0.0), description="range of its direction about z [deg]")
    key_rgb: Vec3 = Field((1.0, 1.0, 1.0), description="key colour, linear RGB gains 0-1")
    specular: float = Field(0.0, ge=0.0, le=0.5, description="renderer's specular coefficient")
    shadows: bool = False
    two_sided: bool = Field(
        True,
        description="draw a cloth lying face down lit, as its face up (a second render per image; "
        "off: TinyRenderer lights it by ambient only, `lighting.render_two_sided`)",
    )
    shadow_map_size: int = Field(128, ge=32, le=2048, description="shadow map side [px]")
    penumbra: float = Field(0.006, ge=0.0, le=0.05, description="width of soft shadow edges [m]")
    station: StationLightingSettings = StationLightingSettings()

    @field_validator("key_zenith_deg")
    @classmethod
    def _zenith(cls, value: AngleRange) -> AngleRange:
        return _ordered(value, 0.0, 80.0)

    @field_validator("key_azimuth_deg")
    @classmethod
    def _azimuth(cls, value: AngleRange) -> AngleRange:
        return _ordered(value, -180.0, 180.0)

    @field_validator("key_rgb")
    @classmethod
    def _colour(cls, value: Vec3) -> Vec3:
        if not all(0.0 <= c <= 1.0 for c in value):
            raise ValueError("key_rgb needs three gains in [0, 1]")
        return value


class StationImagingSettings(StrictModel):
    """The station camera: manual exposure and white balance, set once on the empty sheet."""

    white_balance_error: float = Field(0.0, ge=0.0, le=0.5, description="log sigma per channel")
    vignetting: float = Field(0.0, ge=0.0, le=0.9, description="brightness lost in the corners")
    full_well: float | None = Field(None, gt=100.0, le=1e6, description="[e-]; null: no photon noise")
    noise_sigma: float = Field(0.0, ge=0.0, le=50.0, description="read noise [DN] at unit gain")
    jpeg_quality: int | None = Field(None, ge=10, le=100, description="null: lossless")


class ImagingSettings(StrictModel):
    """The hand cameras between the renderer and `capture()`, applied per image.

    Order, as in a camera: vignetting, motion blur over the exposure, exposure gain (fixed
    or auto-exposure that follows the scene with a time constant), photon and read noise,
    white balance per channel, 8-bit quantisation, JPEG. Every capture carries its
    exposure time and the time it becomes available (latency); a dropped frame makes the
    capture wait one more frame period.
    """

    exposure: Literal["fixed", "auto"] = "fixed"
    gain: float = Field(1.0, gt=0.0, le=16.0, description="fixed gain, or auto-exposure's start")
    target_level: float = Field(0.42, gt=0.05, lt=0.95, description="auto-exposure mean level (0-1)")
    ae_time_constant: float = Field(0.3, ge=0.0, le=10.0, description="auto-exposure lag [s]")
    ae_initial_error: float = Field(0.0, ge=0.0, le=1.0, description="log sigma of the first exposure")
    flicker: float = Field(0.0, ge=0.0, le=0.5, description="relative brightness jitter per frame")
    white_balance_error: float = Field(0.0, ge=0.0, le=0.5, description="log sigma per channel")
    vignetting: float = Field(0.0, ge=0.0, le=0.9, description="brightness lost in the corners")
    full_well: float | None = Field(None, gt=100.0, le=1e6, description="[e-]; null: no photon noise")
    noise_sigma: float = Field(0.0, ge=0.0, le=50.0, description="read noise [DN] at unit gain")
    exposure_time: float = Field(0.0, ge=0.0, le=0.2, description="[s]; motion blur over it")
    jpeg_quality: int | None = Field(None, ge=10, le=100, description="null: lossless")
    frame_rate: float = Field(30.0, gt=0.0, le=1000.0, description="[Hz]")
    latency: float = Field(0.0, ge=0.0, le=2.0, description="mean exposure-to-memory delay [s]")
    latency_jitter: float = Field(0.0, ge=0.0, le=1.0, description="its standard deviation [s]")
    drop_probability: float = Field(0.0, ge=0.0, le=0.5, description="share of lost frames")
    station: StationImagingSettings = StationImagingSettings()


class AppearanceSettings(StrictModel):
    """How cloths look: flat cartoon colours (the old catalogue) or fabric.

    `fabric` gives each cloth a woven, knitted or pile micro-texture, colour variation and
    prints, a darker and duller back side, and a render mesh `visual_spacing` fine that
    shows wrinkles and folds (the physics mesh stays as it is).
    """

    fabric: bool = False
    visual_spacing: float = Field(0.009, ge=0.004, le=0.05, description="render mesh spacing [m]")


PRESETS: dict[str, dict[str, dict[str, Any]]] = {
    "clean": {
        "lighting": {},
        "imaging": {},
        "appearance": {},
        "scene": {"wrinkle_amplitude": 0.0, "fold_probability": 0.0},
    },
    "realistic": {
        "lighting": {
            "ambient": 0.32,
            "key": 0.72,
            "key_zenith_deg": (30.0, 50.0),
            "key_azimuth_deg": (-180.0, 180.0),
            "key_rgb": (1.0, 0.96, 0.9),
            "specular": 0.05,
            "shadows": True,
            "station": {"ambient": 0.45, "key": 0.55, "zenith_deg": 15.0, "azimuth_deg": 60.0},
        },
        "imaging": {
            "exposure": "auto",
            "ae_time_constant": 0.3,
            "ae_initial_error": 0.1,
            "flicker": 0.02,
            "white_balance_error": 0.03,
            "vignetting": 0.25,
            "full_well": 10000.0,
            "noise_sigma": 1.0,
            "exposure_time": 0.008,
            "jpeg_quality": 90,
            "latency": 0.05,
            "latency_jitter": 0.01,
            "station": {
                "white_balance_error": 0.02,
                "vignetting": 0.15,
                "full_well": 10000.0,
                "noise_sigma": 1.0,
                "jpeg_quality": 95,
            },
        },
        "appearance": {"fabric": True},
        "scene": {"wrinkle_amplitude": 0.008, "fold_probability": 0.0},
    },
    "harsh": {
        "lighting": {
            "ambient": 0.25,
            "key": 0.85,
            "key_zenith_deg": (35.0, 50.0),
            "key_azimuth_deg": (-180.0, 180.0),
            "key_rgb": (1.0, 0.88, 0.74),
            "specular": 0.1,
            "shadows": True,
            "station": {
                "ambient": 0.4,
                "key": 0.6,
                "zenith_deg": 25.0,
                "azimuth_deg": 60.0,
                "key_rgb": (1.0, 0.94, 0.86),
            },
        },
        "imaging": {
            "exposure": "auto",
            "ae_time_constant": 0.6,
            "ae_initial_error": 0.3,
            "flicker": 0.06,
            "white_balance_error": 0.08,
            "vignetting": 0.45,
            "full_well": 6000.0,
            "noise_sigma": 2.5,
            "exposure_time": 0.02,
            "jpeg_quality": 70,
            "latency": 0.12,
            "latency_jitter": 0.04,
            "drop_probability": 0.05,
            "station": {
                "white_balance_error": 0.04,
                "vignetting": 0.25,
                "full_well": 6000.0,
                "noise_sigma": 2.0,
                "jpeg_quality": 85,
            },
        },
        "appearance": {"fabric": True},
        "scene": {"wrinkle_amplitude": 0.012, "fold_probability": 0.35},
    },
}
"""Each preset's values of the keys it sets; keys it leaves out keep the settings' defaults
(which are the `clean` values)."""

PRESET_SECTIONS = ("lighting", "imaging", "appearance")


CALIBRATED_RIG_PRESETS = ("realistic", "harsh")
"""Presets whose recogniser and loop get the rig a simulated calibration measured (through
the preset's camera model: `robot-app sim calibration-views` then `robot-app calibrate`),
not the URDF truth; `clean` keeps the truth."""


def calibrated_rig_file(image_size: Any) -> Path | None:
    """`configs/rig_calibrated_<w>x<h>.yaml` for cameras of that size, if it was made."""
    try:
        width, height = (int(v) for v in image_size)
    except (TypeError, ValueError):
        return None
    path = CONFIGS / f"rig_calibrated_{width}x{height}.yaml"
    return path if path.is_file() else None


def fill_preset_defaults(data: Any) -> Any:
    """Returns the raw `world` mapping with the preset's values under the keys it leaves unset.

    Besides the `lighting`, `imaging` and `appearance` keys, the realistic and harsh
    presets set `cameras.rig_file` (when it is not given, even as null) to the calibrated
    rig of the cameras' size; a size that was never calibrated keeps the URDF truth (the
    stereo camera warns when a cell is built). Unknown presets and non-mappings are
    returned unchanged, for validation.
    """
    if not isinstance(data, dict):
        return data
    name = data.get("realism", DEFAULT_REALISM)
    if not isinstance(name, str) or name not in PRESETS:
        return data
    filled = dict(data)
    for section in PRESET_SECTIONS:
        given = data.get(section)
        if isinstance(given, BaseModel):  # a settings object given whole is taken as it is
            continue
        if given is not None and not isinstance(given, dict):
            continue
        filled[section] = _merge(PRESETS[name][section], given or {})
    cameras = data.get("cameras")
    if name in CALIBRATED_RIG_PRESETS and (cameras is None or isinstance(cameras, dict)):
        cameras = dict(cameras or {})
        if "rig_file" not in cameras:
            size = cameras.get("image_size", DEFAULT_IMAGE_SIZE)
            rig_file = calibrated_rig_file(size)
            if rig_file is not None:  # else the truth (the cell warns when it is built)
                cameras["rig_file"] = rig_file
                filled["cameras"] = cameras
    return filled


def scene_defaults(realism: str) -> dict[str, float]:
    """The preset's wrinkle amplitude [m] and fold probability, for scene keys left null."""
    return dict(PRESETS[realism]["scene"])


def _merge(defaults: dict[str, Any], given: dict[str, Any]) -> dict[str, Any]:
    """`given` over `defaults`, recursively for nested mappings."""
    merged = dict(defaults)
    for key, value in given.items():
        if isinstance(value, dict) and isinstance(merged.get(key), dict):
            merged[key] = _merge(merged[key], value)
        else:
            merged[key] = value
    return merged


__all__ = [
    "CALIBRATED_RIG_PRESETS",
    "DEFAULT_REALISM",
    "PRESETS",
    "REALISM_NAMES",
    "AppearanceSettings",
    "ImagingSettings",
    "LightingSettings",
    "Realism",
    "StationImagingSettings",
    "StationLightingSettings",
    "calibrated_rig_file",
    "fill_preset_defaults",
    "scene_defaults",
]
