import math

import numpy as np
import pytest

from wavealt.camera import Camera
from wavealt.sim.light.optics import (
    Optics,
    fresnel_unpolarised,
    render_pair,
    shade,
    sun_vector,
)


def test_fresnel_limits_and_brewster():
    n = 1.34
    assert fresnel_unpolarised(1.0, n) == pytest.approx(((n - 1) / (n + 1)) ** 2)
    assert fresnel_unpolarised(0.0, n) == pytest.approx(1.0)
    th_b = math.atan(n)  # Brewster: p-polarised reflectance vanishes
    ci = math.cos(th_b)
    ct = math.sqrt(1 - (math.sin(th_b) / n) ** 2)
    rs2 = ((ci - n * ct) / (ci + n * ct)) ** 2
    assert fresnel_unpolarised(ci, n) == pytest.approx(rs2 / 2)
    c = np.linspace(0, 1, 200)
    assert np.all(np.diff(fresnel_unpolarised(c, n)) < 0)  # more grazing, more reflective


def test_lobe_peaks_where_normal_is_half_vector():
    cam = Camera.from_fov(33, 33, 40.0, 2.0)
    view = cam.view_vectors()
    sun = sun_vector(math.radians(20), math.radians(45))
    half = view[16, 16] + sun
    half /= np.linalg.norm(half)
    sx = np.full((1, 33, 33), -half[0] / half[2], dtype=np.float32)
    sy = np.full((1, 33, 33), -half[1] / half[2], dtype=np.float32)
    _, lobe = shade(sx, sy, view, sun, Optics())
    assert lobe[0, 16, 16] == pytest.approx(1.0, abs=1e-5)
    assert lobe[0].argmax() == 16 * 33 + 16


def _slopes(seed=0, t=3, h=40, w=40):
    rng = np.random.default_rng(seed)
    return (0.15 * rng.standard_normal((t, h, w))).astype(np.float32), \
           (0.15 * rng.standard_normal((t, h, w))).astype(np.float32)


def test_glinty_at_least_clean_and_equal_where_lobe_negligible():
    sx, sy = _slopes()
    cam = Camera.from_fov(40, 40, 60.0, 3.0)
    sun = sun_vector(math.radians(25), 0.3)
    clean, glinty = render_pair(sx, sy, cam.view_vectors(), sun, glint_severity=0.8, optics=Optics())
    assert clean.shape == glinty.shape == (3, 40, 40, 3)
    assert clean.dtype == glinty.dtype == np.float32
    assert np.all(glinty >= clean)
    _, lobe = shade(sx, sy, cam.view_vectors(), sun, Optics())
    faint = lobe * 0.8 < 1e-7
    assert faint.sum() > 100
    assert np.allclose(glinty[faint], clean[faint], rtol=0, atol=1e-6)
    assert 0.0 <= clean.min() and glinty.max() <= 1.0


def test_clean_independent_of_glint_severity_and_exposure_shared():
    sx, sy = _slopes(1)
    view = Camera.from_fov(40, 40, 60.0, 3.0).view_vectors()
    sun = sun_vector(0.3, 1.0)
    c1, g1 = render_pair(sx, sy, view, sun, glint_severity=0.2, optics=Optics())
    c2, g2 = render_pair(sx, sy, view, sun, glint_severity=1.0, optics=Optics())
    assert np.array_equal(c1, c2)
    assert np.all(g2 >= g1)
    # the sequence-wide exposure puts the clean mean at the display colour
    assert np.allclose(c1.reshape(-1, 3).mean(0), Optics().display_rgb, atol=0.01)


def test_render_rejects_negative_glint():
    sx, sy = _slopes()
    with pytest.raises(ValueError, match="glint_severity"):
        render_pair(sx, sy, Camera.from_fov(40, 40, 60, 3).view_vectors(), sun_vector(0.2, 0),
                    glint_severity=-1.0, optics=Optics())
