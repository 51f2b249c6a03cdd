"""Camera model: noise statistics, sRGB, compression, vignetting, attitude."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wavealt.camera import Camera
from wavealt.sim.sensor import (
    SensorModel,
    attitude_view_vectors,
    capture_pair,
    encode,
    expose_and_read,
    srgb_decode,
    srgb_encode,
    vignetting_map,
)


@pytest.mark.parametrize(("level", "full_well", "read"), [(0.05, 5000.0, 10.0), (0.4, 20000.0, 3.0)])
def test_noise_statistics_shot_plus_read(level, full_well, read):
    sensor = SensorModel(full_well_e=full_well, read_noise_e=read, srgb=False)
    rng = np.random.default_rng(0)
    sig = np.full((4, 64, 64, 3), level, dtype=np.float32)
    out = expose_and_read(sig, rng.standard_normal(sig.shape, dtype=np.float32), sensor)
    e = level * full_well
    assert out.mean() == pytest.approx(level, rel=2e-3)
    assert out.var() == pytest.approx((e + read**2) / full_well**2, rel=0.05)


def test_noise_variance_grows_with_signal_like_shot_noise():
    sensor = SensorModel(full_well_e=10000.0, read_noise_e=0.0, srgb=False)
    z = np.random.default_rng(1).standard_normal((2, 32, 32, 3), dtype=np.float32)
    v1 = expose_and_read(np.full(z.shape, 0.1, np.float32), z, sensor).var()
    v4 = expose_and_read(np.full(z.shape, 0.4, np.float32), z, sensor).var()
    assert v4 / v1 == pytest.approx(4.0, rel=0.02)


def test_capture_pair_shares_exposure_and_noise():
    rng = np.random.default_rng(2)
    clean = rng.uniform(0.002, 0.004, (3, 16, 16, 3)).astype(np.float32)
    glinty = clean.copy()
    glinty[:, 4:6, 4:6] += 0.5
    sensor = SensorModel(srgb=False)
    c, g = capture_pair(clean, glinty, sensor=sensor, rng=7, exposure_ev=0.0)
    assert c.dtype == np.float32 and c.shape == clean.shape
    mask = np.ones(clean.shape[:3], bool)
    mask[:, 4:6, 4:6] = False
    np.testing.assert_array_equal(c[mask], g[mask])  # identical where the glint adds nothing
    assert np.all(g[~mask] >= c[~mask])
    assert c.mean() == pytest.approx(sensor.target_grey, rel=0.02)
    c1, _ = capture_pair(clean, glinty, sensor=sensor, rng=7, exposure_ev=1.0)
    assert c1.mean() == pytest.approx(2 * sensor.target_grey, rel=0.02)
    c_again, _ = capture_pair(clean, glinty, sensor=sensor, rng=7, exposure_ev=0.0)
    np.testing.assert_array_equal(c, c_again)


def test_srgb_round_trip_and_known_points():
    x = np.linspace(0, 1, 1001, dtype=np.float32)
    np.testing.assert_allclose(srgb_decode(srgb_encode(x)), x, atol=2e-6)
    assert float(srgb_encode(np.float32(0.18))) == pytest.approx(0.4614, abs=1e-3)
    assert float(srgb_encode(np.float32(1.0))) == pytest.approx(1.0, abs=1e-6)


@pytest.mark.parametrize("compression", ["jpeg", "h264"])
def test_compression_round_trip_is_close_and_in_range(compression):
    rng = np.random.default_rng(3)
    base = np.linspace(0.1, 0.6, 64, dtype=np.float32)[None, None, :, None]
    lin = np.broadcast_to(base, (4, 64, 64, 3)) + rng.normal(0, 0.005, (4, 64, 64, 3)).astype(np.float32)
    lin = np.clip(lin, 0, 1).astype(np.float32)
    ref = encode(lin, SensorModel(compression="none"))
    out = encode(lin, SensorModel(compression=compression, jpeg_quality=90, h264_crf=18))
    assert out.shape == lin.shape and out.dtype == np.float32
    assert 0.0 <= out.min() and out.max() <= 1.0
    assert np.abs(out - ref).mean() < 0.02
    assert not np.array_equal(out, np.rint(ref * 255) / 255)  # it is lossy


def test_the_h264_preset_reaches_the_encoder():
    """libx264's presets code the same frames differently (``medium`` adds B-frames and
    quarter-pixel motion), each a close, lossy round trip."""
    rng = np.random.default_rng(5)
    x = np.arange(64, dtype=np.float32)
    t = np.arange(8, dtype=np.float32)[:, None, None]
    # a texture moving 0.6 px a frame, under noise
    wave = 0.3 + 0.1 * np.sin(0.4 * (x[None, None, :] - 0.6 * t) + 0.3 * x[None, :, None])
    lin = np.clip(wave[..., None] + rng.normal(0, 0.01, (8, 64, 64, 3)), 0, 1).astype(np.float32)
    ref = encode(lin, SensorModel(compression="none"))
    outs = {p: encode(lin, SensorModel(compression="h264", h264_crf=23, h264_preset=p))
            for p in ("ultrafast", "medium")}
    for out in outs.values():
        assert np.abs(out - ref).mean() < 0.02
    assert not np.array_equal(outs["ultrafast"], outs["medium"])


def test_vignetting_cos4():
    v = vignetting_map(65, 65, 50.0, strength=1.0)
    assert v[32, 32] == pytest.approx(1.0, abs=1e-3)
    r = math.hypot(32.0, 32.0)
    assert v[0, 0] == pytest.approx(math.cos(math.atan(r / 50.0)) ** 4, rel=1e-3)
    np.testing.assert_array_equal(vignetting_map(8, 8, 50.0, strength=0.0), 1.0)


def test_attitude_zero_is_the_nadir_camera_and_tilt_shifts_the_footprint():
    cam = Camera(48, 40, 60.0, 5.0)
    view, shift = attitude_view_vectors(40, 48, 60.0)
    np.testing.assert_allclose(view, cam.view_vectors(), atol=1e-6)
    assert shift == (0, 0)
    view_p, shift_p = attitude_view_vectors(40, 48, 60.0, pitch_rad=math.radians(5))
    assert shift_p[0] == 0 and abs(shift_p[1]) == round(60.0 * math.tan(math.radians(5)))
    # the optical axis meets the sea at the shifted footprint centre: the view vector there
    # points from that ground point back to the camera
    centre = view_p[19:21, 23:25].mean(axis=(0, 1))
    expect = np.array([-shift_p[1] / 60.0, -shift_p[0] / 60.0, 1.0])
    np.testing.assert_allclose(centre / np.linalg.norm(centre), expect / np.linalg.norm(expect),
                               atol=0.01)
    np.testing.assert_allclose(np.linalg.norm(view_p, axis=-1), 1.0, atol=1e-6)
    _, shift_r = attitude_view_vectors(40, 48, 60.0, roll_rad=math.radians(5))
    assert shift_r[1] == 0 and abs(shift_r[0]) == round(60.0 * math.tan(math.radians(5)))


def test_sensor_bad_input():
    with pytest.raises(ValueError, match="compression must be one of"):
        SensorModel(compression="gif")
    with pytest.raises(ValueError, match="jpeg_quality must be an integer"):
        SensorModel(jpeg_quality=0)
    with pytest.raises(ValueError, match="h264_preset must be one of ultrafast, "):
        SensorModel(h264_preset="turbo")
    with pytest.raises(ValueError, match="full_well_e must be > 0"):
        SensorModel(full_well_e=0)
    with pytest.raises(ValueError, match="read_noise_e must be >= 0"):
        SensorModel(read_noise_e=-1)
    with pytest.raises(ValueError, match="pitch_rad"):
        attitude_view_vectors(8, 8, 10.0, pitch_rad=1.2)
    with pytest.raises(ValueError, match="h264 needs even frame sizes"):
        encode(np.zeros((2, 7, 8, 3), np.float32), SensorModel(compression="h264"))
