import math

import numpy as np
import pytest

from wavealt.camera import Camera, focal_px_from_fov


def test_focal_and_gsd():
    f = focal_px_from_fov(224, 90.0)
    assert f == pytest.approx(112.0)
    cam = Camera(224, 224, f, 5.0)
    assert cam.gsd_m == pytest.approx(5.0 / 112.0)
    assert cam.footprint_m[0] == pytest.approx(2 * 5.0 * math.tan(math.radians(45)))
    assert cam.fov_x_deg == pytest.approx(90.0)


def test_view_vectors_unit_and_nadir_at_centre():
    cam = Camera.from_fov(64, 48, 60.0, 3.0)
    v = cam.view_vectors()
    assert v.shape == (48, 64, 3) and v.dtype == np.float32
    assert np.allclose(np.linalg.norm(v, axis=-1), 1.0, atol=1e-6)
    # symmetric about the optical axis; the edge column sees 30 deg off nadir
    assert np.allclose(v[..., 0], -v[:, ::-1, 0], atol=1e-6)
    edge = math.degrees(math.acos(v[24, 0, 2]))
    assert edge == pytest.approx(30.0, abs=0.5)


@pytest.mark.parametrize("kw, match", [
    (dict(altitude_m=0.0), "altitude_m"), (dict(altitude_m=15.5), "altitude_m"),
    (dict(focal_px=-1.0), "focal_px"), (dict(width_px=0), "width_px"),
])
def test_bad_camera(kw, match):
    base = dict(width_px=32, height_px=32, focal_px=30.0, altitude_m=2.0)
    base.update(kw)
    with pytest.raises(ValueError, match=match):
        Camera(**base)


@pytest.mark.parametrize("fov", [0.0, 180.0, 200.0, float("nan")])
def test_bad_fov(fov):
    with pytest.raises(ValueError, match="fov_deg"):
        focal_px_from_fov(64, fov)


def test_unturn_yaw_puts_every_frame_where_the_middle_one_sees_the_sea() -> None:
    """A point on the sea, placed in each frame where a yawing camera sees it (through the
    link's own NED-to-image axes, :func:`ned_to_image`), lands where the middle frame shows
    it; the other sign of the rate sends it away."""
    from wavealt.camera import unturn_yaw
    from wavealt.live.mavlink import ned_to_image

    size, fps, rate = 81, 10.0, 40.0  # 4 degrees a frame, nose turning right
    c = (size - 1) / 2
    yy, xx = np.mgrid[0:size, 0:size].astype(float)
    point_ned = (-12.0, 25.0, 0.0)  # behind and right of the camera, px on the sea
    frames = []
    for t in range(5):
        yaw = math.radians(rate * (t - 2) / fps)
        x, y = ned_to_image(point_ned, yaw)
        frames.append(np.exp(-((xx - c - x) ** 2 + (yy - c - y) ** 2) / 6.0))
    frames = np.stack(frames).astype(np.float32)
    middle = np.unravel_index(np.argmax(frames[2]), frames[2].shape)
    assert max(np.hypot(*np.subtract(np.unravel_index(np.argmax(f), f.shape), middle))
               for f in frames) > 3.0  # the point moves in the frames as taken
    for f in unturn_yaw(frames, rate, fps):
        assert np.unravel_index(np.argmax(f), f.shape) == middle
    wrong = unturn_yaw(frames, -rate, fps)
    assert np.unravel_index(np.argmax(wrong[0]), wrong[0].shape) != middle
    gray_u8 = (255 * frames).astype(np.uint8)
    assert unturn_yaw(gray_u8, 0.0, fps).tobytes() == gray_u8.tobytes()


def test_unturn_headings_takes_any_heading_log() -> None:
    """A heading per frame: a steady turn's headings are the steady turn's frames; an
    unsteady turn (the heading back and forth) puts a point seen through the link's axes
    where the reference heading shows it; a log of the wrong length is refused."""
    from wavealt.camera import unturn_headings, unturn_yaw
    from wavealt.live.mavlink import ned_to_image

    size = 81
    c = (size - 1) / 2
    yy, xx = np.mgrid[0:size, 0:size].astype(float)
    rng = np.random.default_rng(0)
    frames = rng.random((5, size, size)).astype(np.float32)
    steady = [40.0 * (t - 2) / 10.0 for t in range(5)]
    assert np.array_equal(unturn_headings(frames, steady), unturn_yaw(frames, 40.0, 10.0))
    heads = [0.0, 6.0, -3.0, 9.0, -7.0]
    point_ned = (-12.0, 25.0, 0.0)
    seen = []
    for d in heads:
        x, y = ned_to_image(point_ned, math.radians(d))
        seen.append(np.exp(-((xx - c - x) ** 2 + (yy - c - y) ** 2) / 6.0))
    back = unturn_headings(np.stack(seen).astype(np.float32), heads)
    where = {np.unravel_index(np.argmax(f), f.shape) for f in back}
    assert len(where) == 1  # every frame where heading 0 sees the point
    with pytest.raises(ValueError, match="4 headings for 5 frames"):
        unturn_headings(frames, heads[:4])


@pytest.mark.parametrize(("rate", "fps", "match"), [
    (200.0, 30.0, "yaw_rate_dps"), (float("nan"), 30.0, "yaw_rate_dps"), (10.0, 0.0, "fps")])
def test_unturn_yaw_refuses_bad_rates(rate, fps, match) -> None:
    from wavealt.camera import unturn_yaw

    with pytest.raises(ValueError, match=match):
        unturn_yaw(np.zeros((3, 16, 16), np.float32), rate, fps)
