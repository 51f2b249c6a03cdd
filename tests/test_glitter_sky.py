"""Cox–Munk glint and glitter against the independent ``coxmunk`` package; sky; whitecaps.

``coxmunk`` (T. Harmel, PyPI, MIT) computes the polarised sunglint of Cox & Munk (1954)
slope statistics.  Its package ``__init__`` pulls plotting and data-frame dependencies
(cmocean, docopt, xarray, pandas, netCDF4) that wavealt does not need, so the test loads its
computational module ``coxmunk/coxmunk.py`` (NumPy and SciPy only) by file path.
"""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest

from wavealt.sim.light.glitter import (
    advected_crops,
    cox_munk_glint,
    glint_reflectance,
    whitecap_field,
    whitecap_fraction,
)
from wavealt.sim.light.optics import sun_vector
from wavealt.sim.light.sky import SkyModel, reflect
from wavealt.sim.sea.realistic import RealisticSea, SeaSpectrum

N_WATER = 1.34


def _coxmunk_module():
    spec = importlib.util.find_spec("coxmunk")
    if spec is None or not spec.submodule_search_locations:
        pytest.skip("the coxmunk package is not installed (pip install --no-deps coxmunk)")
    path = Path(list(spec.submodule_search_locations)[0]) / "coxmunk.py"
    mspec = importlib.util.spec_from_file_location("_coxmunk_core", path)
    mod = importlib.util.module_from_spec(mspec)
    mspec.loader.exec_module(mod)
    return mod


def coxmunk_iso(sza: float, vza: float, azi: float, wind: float) -> float:
    cm = _coxmunk_module()
    return float(cm.sunglint(sza, vza, azi, m=N_WATER).sunglint(wind, 0.0, stats="cm_iso",
                                                                shadow=False)[0])


GEOMETRIES = [  # sun zenith, view zenith, relative azimuth (180: looking at the specular point)
    (10.0, 0.0, 0.0), (30.0, 0.0, 0.0), (50.0, 0.0, 0.0), (30.0, 30.0, 180.0),
    (40.0, 15.0, 180.0), (60.0, 20.0, 120.0), (20.0, 25.0, 90.0),
]


@pytest.mark.parametrize("wind", [2.0, 6.0, 12.0])
@pytest.mark.parametrize("geometry", GEOMETRIES)
def test_flat_mean_glint_equals_coxmunk_cm_iso(geometry, wind):
    """Equation (CM) with all slopes unresolved: the coxmunk value to 1e-4 (same physics,
    independent code, Fresnel of n = 1.34 both sides, no shadowing)."""
    ref = coxmunk_iso(*geometry, wind)
    assert cox_munk_glint(*geometry, wind, refractive_index=N_WATER) == pytest.approx(ref, rel=1e-4)


@pytest.mark.parametrize("altitude_m", [2.0, 12.0])
@pytest.mark.parametrize(("wind", "sun_zeniths"), [(3.0, (10.0, 20.0)), (7.0, (10.0, 25.0)),
                                                   (12.0, (15.0, 35.0))])
def test_synthesised_sea_mean_glint_matches_coxmunk(altitude_m, wind, sun_zeniths):
    """Resolved facets from the synthesised sea plus sub-pixel glitter, averaged over many
    seas, give the Cox–Munk mean glint at any altitude: tolerance 6 % (sampling error of the
    Gaussian tail over 60 seas x 3 frames is about 2 %).

    The sea is isotropic (s = 0; cm_iso is isotropic) and has no long-wave modes: a dozen
    random long waves tilt a whole small frame at once, which makes the mean converge far
    more slowly without changing it (checked by hand: 0.93 +- 0.045 with them over 400
    seas at the hardest case)."""
    sp = SeaSpectrum(wind_speed_mps=wind, spreading_s=0.0)
    seas = [RealisticSea(sp, n=48, dx_m=altitude_m / 221.7, rng=seed, long_bands=0)
            for seed in range(60)]
    fields = [(f, s) for s in seas for f in s.iter_fields([0.0, 2.3, 4.9])]
    view = np.zeros((48, 48, 3), dtype=np.float32)
    view[..., 2] = 1.0
    for z in sun_zeniths:
        sun = sun_vector(math.radians(z), 0.0)
        mean = np.mean([glint_reflectance(f["slope_x"], f["slope_y"], view, sun,
                                          subpixel_slope_variance=s.subpixel_slope_variance).mean()
                        for f, s in fields])
        assert mean == pytest.approx(coxmunk_iso(z, 0.0, 0.0, wind), rel=0.04)


def test_glitter_grain_depends_on_the_pixel_footprint():
    """Same mean, but a larger sub-pixel variance spreads the glint over more pixels."""
    rng = np.random.default_rng(0)
    sx, sy = (rng.normal(0, 0.12, (64, 64)).astype(np.float32) for _ in range(2))
    view = np.zeros((64, 64, 3), dtype=np.float32)
    view[..., 2] = 1
    sun = sun_vector(math.radians(15), 0.0)
    fine = glint_reflectance(sx, sy, view, sun, subpixel_slope_variance=0.001)
    coarse = glint_reflectance(sx, sy, view, sun, subpixel_slope_variance=0.02)
    assert fine.max() > 5 * coarse.max()
    assert (fine / fine.mean()).std() > (coarse / coarse.mean()).std()


def test_glint_bad_input():
    view = np.zeros((4, 4, 3), dtype=np.float32)
    view[..., 2] = 1
    with pytest.raises(ValueError, match="sun must be above the horizon"):
        glint_reflectance(np.zeros((4, 4)), np.zeros((4, 4)), view, np.array([1.0, 0, -0.1]),
                          subpixel_slope_variance=0.01)
    with pytest.raises(ValueError, match="subpixel_slope_variance must be >= 0"):
        glint_reflectance(np.zeros((4, 4)), np.zeros((4, 4)), view, np.array([0, 0, 1.0]),
                          subpixel_slope_variance=-1)
    with pytest.raises(ValueError, match="sun_zenith_deg must be < 90"):
        cox_munk_glint(95.0, 0.0, 0.0, 5.0)


# -- sky -------------------------------------------------------------------------------------
def test_sky_varies_with_direction_and_brightens_toward_sun_and_horizon():
    sun = sun_vector(math.radians(40), 0.0)
    sky = SkyModel(sun)
    zen = sky.radiance(np.array([0.0, 0.0, 1.0]))
    near_sun = sky.radiance(sun * 0.999 + np.array([0, 0.0447, 0]))
    away = np.array([-math.sin(math.radians(40)), 0.0, math.cos(math.radians(40))])
    horizon = sky.radiance(np.array([-0.999, 0.0, 0.0447]))
    assert near_sun.sum() > 3 * zen.sum()
    assert horizon.sum() > sky.radiance(away).sum()
    assert zen[2] > zen[0]  # blue overhead


def test_sky_level_matches_its_diffuse_irradiance():
    sun = sun_vector(math.radians(30), 1.0)
    sky = SkyModel(sun, diffuse_ratio=0.2)
    mu = np.linspace(0.0005, 0.9995, 400)
    az = np.linspace(0, 2 * math.pi, 240, endpoint=False)
    m, a = np.meshgrid(mu, az, indexing="ij")
    s = np.sqrt(1 - m**2)
    d = np.stack([s * np.cos(a), s * np.sin(a), m], -1)
    irr = np.mean(sky.relative_luminance(d) * m) * 2 * math.pi * sky.zenith_radiance
    assert irr == pytest.approx(0.2 * sun[2], rel=0.01)


def test_reflected_sky_depends_on_slope():
    view = np.zeros((1, 1, 3), dtype=np.float32)
    view[..., 2] = 1
    flat, ndc = reflect(view, np.zeros((1, 1)), np.zeros((1, 1)))
    np.testing.assert_allclose(flat[0, 0], [0, 0, 1], atol=1e-6)
    np.testing.assert_allclose(ndc, 1.0, atol=1e-6)
    tilted, _ = reflect(view, np.full((1, 1), 0.2), np.zeros((1, 1)))
    # a facet tilted by atan(0.2) mirrors the zenith ray by twice that angle
    assert math.degrees(math.acos(tilted[0, 0, 2])) == pytest.approx(2 * math.degrees(math.atan(0.2)), abs=1e-3)
    sky = SkyModel(sun_vector(math.radians(30), 0.0))
    assert not np.allclose(sky.radiance(flat), sky.radiance(tilted), rtol=0.02)


def test_sky_bad_input():
    with pytest.raises(ValueError, match="above the horizon"):
        SkyModel(np.array([1.0, 0.0, -0.2]))
    with pytest.raises(ValueError, match="diffuse_ratio must be > 0"):
        SkyModel(np.array([0.0, 0.0, 1.0]), diffuse_ratio=0.0)


# -- whitecaps -------------------------------------------------------------------------------
def test_whitecap_fraction_monahan():
    assert whitecap_fraction(0.0) == 0.0
    assert whitecap_fraction(10.0) == pytest.approx(3.84e-6 * 10**3.41)
    assert whitecap_fraction(5.0) < whitecap_fraction(10.0) < whitecap_fraction(15.0)


def test_whitecap_field_covers_the_fraction_at_a_physical_scale():
    cover = whitecap_field((256, 256), dx_m=0.01, fraction=0.05, rng=1)
    assert cover.dtype == np.float32 and cover.min() >= 0 and cover.max() <= 1
    assert cover.mean() == pytest.approx(0.05, abs=0.02)
    # patch size is physical: a 4x finer grid makes 4x larger patches in pixels
    coarse = whitecap_field((512, 512), dx_m=0.01, fraction=0.2, rng=1, patch_m=0.08)
    fine = whitecap_field((512, 512), dx_m=0.0025, fraction=0.2, rng=2, patch_m=0.08)
    corr = [np.corrcoef(c[:, :-s].ravel(), c[:, s:].ravel())[0, 1] for c, s in ((coarse, 3), (fine, 12))]
    assert corr[0] == pytest.approx(corr[1], abs=0.1)
    assert whitecap_field((8, 8), dx_m=0.01, fraction=0.0, rng=1).max() == 0


def test_non_contiguous_input_gives_the_same_result():
    rng = np.random.default_rng(4)
    sx = rng.normal(0, 0.1, (2, 24, 20)).astype(np.float32)
    sy = rng.normal(0, 0.1, (2, 24, 20)).astype(np.float32)
    view = np.zeros((20, 24, 3), dtype=np.float32)
    view[..., 2] = 1.0
    sun = sun_vector(0.3, 1.0)
    a = glint_reflectance(sx.transpose(0, 2, 1), sy.transpose(0, 2, 1), view, sun,
                          subpixel_slope_variance=0.01)
    b = glint_reflectance(np.ascontiguousarray(sx.transpose(0, 2, 1)),
                          np.ascontiguousarray(sy.transpose(0, 2, 1)), view, sun,
                          subpixel_slope_variance=0.01)
    np.testing.assert_array_equal(a, b)
    d1, n1 = reflect(view, sx.transpose(0, 2, 1), sy.transpose(0, 2, 1))
    d2, n2 = reflect(view, np.ascontiguousarray(sx.transpose(0, 2, 1)),
                     np.ascontiguousarray(sy.transpose(0, 2, 1)))
    np.testing.assert_array_equal(d1, d2)
    np.testing.assert_array_equal(n1, n2)


def test_foam_carried_by_the_water_moves_smoothly_not_in_whole_pixel_jumps():
    """The foam map rides with the water: whole-pixel shifts are exact rolls, and a shift of
    a fraction of a pixel moves every wavenumber's phase by ``k . shift`` (a staircase of
    rounded shifts would leave the first frames identical)."""
    field = whitecap_field((64, 64), dx_m=0.02, fraction=0.1, rng=3)
    shifts = np.array([[0.0, 0.0], [0.0, 0.3], [2.0, -3.0], [0.5, 0.25]])
    crops = advected_crops(field, shifts, (48, 40), offset=(5, 7))
    assert crops.shape == (4, 48, 40) and crops.dtype == np.float32
    np.testing.assert_allclose(crops[0], field[5:53, 7:47], atol=1e-5)
    np.testing.assert_allclose(crops[2], np.roll(field, (-2, 3), axis=(0, 1))[5:53, 7:47],
                               atol=1e-5)
    assert np.abs(crops[1] - crops[0]).max() > 0.05  # a third of a pixel already shows
    # the sub-pixel shift as a phase ramp: the uncropped map's spectrum, before clipping
    full = advected_crops(np.clip(field, 0.0, 1.0), shifts[3:], (64, 64))[0]
    f0, f1 = np.fft.fft2(field), np.fft.fft2(full)
    ky, kx = 2 * np.pi * np.fft.fftfreq(64)[:, None], 2 * np.pi * np.fft.fftfreq(64)[None, :]
    low = (np.hypot(kx, ky) < 0.4) & (np.abs(f0) > 0.05 * np.abs(f0).max())
    phase = np.angle(f1[low] / f0[low])
    np.testing.assert_allclose(phase, (ky * 0.5 + kx * 0.25)[low], atol=0.05)
