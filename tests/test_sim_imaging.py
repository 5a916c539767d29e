"""The camera model between the renderer and `capture()`: each effect is there, and measured.

Pure numpy: no pybullet. A flat grey image stands for a rendered uniform surface.
"""

from __future__ import annotations

import numpy as np
import pytest

from robot_app.sim.cameras import StereoFrame
from robot_app.sim.imaging import CameraModel, FrameClock, image_motion, jpeg_round_trip, motion_blur
from robot_app.sim.realism import PRESETS, ImagingSettings, StationImagingSettings

REALISTIC = ImagingSettings.model_validate(PRESETS["realistic"]["imaging"])
HARSH = ImagingSettings.model_validate(PRESETS["harsh"]["imaging"])


def _flat(level: int, size: tuple[int, int] = (120, 160)) -> np.ndarray:
    return np.full((*size, 3), level, np.uint8)


def _settings(**values: object) -> ImagingSettings:
    return ImagingSettings.model_validate(values)


def test_clean_camera_returns_the_rendered_image_itself() -> None:
    image = np.random.default_rng(0).integers(0, 256, size=(48, 64, 3), dtype=np.uint8)
    camera = CameraModel(ImagingSettings(), seed=3)
    assert camera.is_identity
    out, exposure = camera.expose(image, 0.0, (0.0, 0.0))
    assert out is image and exposure.gain == 1.0
    assert CameraModel(StationImagingSettings(), seed=3).is_identity
    assert not CameraModel(REALISTIC, seed=3).is_identity


def test_noise_in_a_flat_region_follows_photon_and_read_noise() -> None:
    settings = _settings(full_well=10000.0, noise_sigma=1.0)
    out, _ = CameraModel(settings, seed=1).expose(_flat(128))
    measured = out.astype(float).std(axis=(0, 1))
    expected = np.sqrt(128 * 255 / 10000 + 1.0)  # [DN]: photon variance K·signal plus read noise²
    np.testing.assert_allclose(measured, expected, rtol=0.12)
    darker, _ = CameraModel(settings, seed=1).expose(_flat(32))
    assert darker.astype(float).std() < measured.mean()  # photon noise grows with the signal
    assert abs(out.astype(float).mean() - 128) < 0.5


def test_gain_amplifies_noise() -> None:
    low, _ = CameraModel(_settings(noise_sigma=1.0, gain=1.0), seed=2).expose(_flat(40))
    high, _ = CameraModel(_settings(noise_sigma=1.0, gain=4.0), seed=2).expose(_flat(10))
    assert abs(high.mean() - 40) < 1.0
    assert high.astype(float).std() == pytest.approx(4 * low.astype(float).std(), rel=0.15)


def test_same_seed_same_images_other_seed_other_noise() -> None:
    image = np.random.default_rng(5).integers(20, 230, size=(60, 80, 3), dtype=np.uint8)
    runs = []
    for seed in (7, 7, 8):
        camera = CameraModel(HARSH, seed=seed)
        runs.append([camera.expose(image, t, (1.5, -0.5))[0] for t in (0.0, 0.07, 0.13)])
    for a, b in zip(runs[0], runs[1], strict=True):
        np.testing.assert_array_equal(a, b)
    assert not np.array_equal(runs[0][0], runs[2][0])
    assert not np.array_equal(runs[0][0], runs[0][1])  # each frame draws fresh noise


def test_vignetting_darkens_the_corners_by_the_configured_share() -> None:
    out, _ = CameraModel(_settings(vignetting=0.3), seed=0).expose(_flat(200, (121, 161)))
    centre, corner = float(out[60, 80, 1]), float(out[0, 0, 1])
    assert centre == pytest.approx(200, abs=1)
    assert corner / centre == pytest.approx(0.7, abs=0.01)


def test_white_balance_error_tints_each_channel_differently() -> None:
    out, _ = CameraModel(_settings(white_balance_error=0.08), seed=4).expose(_flat(120))
    means = out.reshape(-1, 3).mean(axis=0)
    assert np.ptp(means) > 2.0
    # set for a warm lamp, the balance boosts blue and cuts red (BGR order)
    warm, _ = CameraModel(
        _settings(white_balance_error=0.01), seed=4, white_point_rgb=(1.0, 0.9, 0.7)
    ).expose(_flat(100))
    b, g, r = warm.reshape(-1, 3).mean(axis=0)
    assert b > g > r


def test_auto_exposure_follows_a_brightness_step_with_its_time_constant() -> None:
    settings = _settings(exposure="auto", target_level=0.4, ae_time_constant=0.5)
    camera = CameraModel(settings, seed=0)
    _, first = camera.expose(_flat(102))  # 0.4 of full scale: gain 1
    assert first.gain == pytest.approx(1.0, rel=0.02)
    gains = []
    for k in range(1, 91):  # the scene gets twice as bright at t = 0; frames every 1/30 s
        out, exposure = camera.expose(_flat(204), k / 30)
        gains.append(exposure.gain)
    # the gain used at frame k was metered on frames up to k-1: it lags, then settles at 0.5
    assert gains[0] == pytest.approx(1.0, rel=0.02)
    after_tau = gains[15]  # 0.5 s later: 1 - 1/e of the way in log gain
    assert np.log(after_tau) == pytest.approx((1 - np.exp(-(15 / 30) / 0.5)) * np.log(0.5), abs=0.06)
    assert gains[-1] == pytest.approx(0.5, rel=0.08)
    assert abs(out.mean() - 102) < 10


def test_first_auto_exposure_has_the_configured_error_spread() -> None:
    settings = _settings(exposure="auto", ae_initial_error=0.2)
    gains = [CameraModel(settings, seed=s).expose(_flat(102))[1].gain for s in range(200)]
    assert np.std(np.log(gains)) == pytest.approx(0.2, rel=0.2)


def test_motion_blur_spreads_an_edge_over_the_motion() -> None:
    image = np.zeros((40, 80), np.float32)
    image[:, 40:] = 1.0
    blurred = motion_blur(image, (8.0, 0.0))
    row = blurred[20]
    ramp = np.flatnonzero((row > 0.02) & (row < 0.98))
    assert 6 <= len(ramp) <= 9  # the edge is smeared over the 8 px the image moved
    np.testing.assert_allclose(motion_blur(image, (0.0, 8.0))[:, 38:43].std(axis=0), 0.0, atol=1e-6)


def test_image_motion_of_a_camera_moving_sideways_and_turning() -> None:
    # moving +x at 0.2 m/s over a scene 0.5 m away: the image moves -x at f·v/z
    du, dv = image_motion([0.2, 0.0, 0.0], [0.0, 0.0, 0.0], 0.5, 400.0)
    assert du == pytest.approx(-160.0) and dv == pytest.approx(0.0)
    du, dv = image_motion([0.0, 0.0, 0.0], [0.1, 0.0, 0.0], 0.5, 400.0)  # tilting about x
    assert dv == pytest.approx(40.0) and du == pytest.approx(0.0)


def test_jpeg_loses_detail_by_its_quality() -> None:
    image = np.random.default_rng(0).integers(0, 256, size=(64, 64, 3), dtype=np.uint8)
    error = {q: np.abs(jpeg_round_trip(image, q).astype(int) - image).mean() for q in (95, 70)}
    assert 0 < error[95] < error[70]


def test_latency_jitter_and_dropped_frames() -> None:
    clock = FrameClock(HARSH, seed=3)
    timings = [clock.timing(k * 0.1) for k in range(2000)]
    delay = np.array([t.available_time - t.time for t in timings])
    dropped = np.array([t.dropped for t in timings])
    assert dropped.mean() == pytest.approx(HARSH.drop_probability, abs=0.015)
    kept = delay[~dropped]
    assert kept.mean() == pytest.approx(HARSH.latency, abs=0.005)
    assert kept.std() == pytest.approx(HARSH.latency_jitter, rel=0.15)
    assert np.all(delay >= 0)
    # a lost frame: the next one comes a frame period later
    assert delay[dropped].mean() == pytest.approx(HARSH.latency + 1 / HARSH.frame_rate, abs=0.01)
    realistic = [FrameClock(REALISTIC, seed=3).timing(1.0) for _ in range(1)]
    assert not realistic[0].dropped and realistic[0].available_time > 1.0


def test_stereo_frame_defaults_and_checks_its_times() -> None:
    image = np.zeros((2, 2, 3), np.uint8)
    frame = StereoFrame(image, image, 1.5, np.eye(4))
    assert frame.available_time == 1.5 and not frame.dropped
    with pytest.raises(ValueError, match="precedes"):
        StereoFrame(image, image, 1.5, np.eye(4), available_time=1.0)
