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
