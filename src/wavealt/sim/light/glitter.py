"""Sun glint from resolved and unresolved facets (Cox & Munk 1954), and whitecaps.

A pixel sees a patch of sea whose *resolved* mean slope ``z_res`` comes from the synthesised
field, while the facets finer than the pixel have slopes spread around it with the variance
of the unresolved part of the spectrum, ``sigma_sub^2`` (``RealisticSea.subpixel_slope_variance``;
the larger the pixel footprint, the larger it is).  Modelling those facets as isotropic
Gaussian, the glint reflectance of the pixel is the Cox–Munk expression

    rho = pi F(omega) P(z_req - z_res) / (4 mu_s mu_v cos^4 theta_n),                  (CM)
    P(dz) = exp(-|dz|^2 / sigma_sub^2) / (pi sigma_sub^2)

(Cox & Munk 1954, eq. 5; the ``cm_iso`` statistics of the ``coxmunk`` package), where
``z_req`` is the facet slope that reflects the sun into the camera (its normal is the half
vector ``h`` of sun and view directions), ``theta_n`` that facet's tilt, ``omega`` the angle
of incidence on it, ``mu_s`` and ``mu_v`` the cosines of the sun and view zenith angles and
``F`` the Fresnel reflectance.  ``rho`` is a reflectance: the glint radiance is
``E_sun mu_s rho / pi`` for a sun of normal irradiance ``E_sun``.

Averaged over a sea whose resolved slopes are Gaussian with variance ``sigma_res^2``, the
Gaussian ``P`` convolves into one of variance ``sigma_res^2 + sigma_sub^2`` (Cox–Munk's total):
the mean glint is independent of the altitude, only its graininess changes with it.
"""

from __future__ import annotations

import math

import numpy as np

from wavealt._checks import as_rng, check_finite_number
from wavealt.sim.light.optics import WATER_REFRACTIVE_INDEX, fresnel_unpolarised
from wavealt.sim.sea.spectrum import cox_munk_slope_variance

#: Angular radius of the sun, rad; its disc sets a floor on the slope spread a pixel sees.
SUN_RADIUS_RAD = 0.00465
#: Slope-variance floor: the sun disc seen through a mirror facet spans half its angle in
#: facet tilt, ``(r_sun / 2)^2`` per axis.
MIN_SLOPE_VARIANCE = 2.0 * (SUN_RADIUS_RAD / 2.0) ** 2


def cox_munk_iso_pdf(zx: np.ndarray, zy: np.ndarray, slope_variance: float) -> np.ndarray:
    """Isotropic Gaussian slope density ``exp(-(zx^2+zy^2)/s2) / (pi s2)`` (Cox & Munk 1954).

    ``slope_variance`` ``s2`` is the total mean-square slope (both axes).
    """
    s2 = max(float(slope_variance), MIN_SLOPE_VARIANCE)
    return np.exp(-(zx * zx + zy * zy) / s2) / (math.pi * s2)


def glint_reflectance(slope_x: np.ndarray, slope_y: np.ndarray, view: np.ndarray,
                      sun: np.ndarray, *, subpixel_slope_variance: float,
                      refractive_index: float = WATER_REFRACTIVE_INDEX) -> np.ndarray:
    """Per-pixel Cox–Munk glint reflectance, equation (CM) of the module docstring.

    Parameters
    ----------
    slope_x, slope_y : (..., H, W) arrays
        Resolved surface slopes ``dh/dx``, ``dh/dy``.
    view : (H, W, 3) array
        Unit vectors from the sea toward the camera.
    sun : (3,) array
        Unit vector toward the sun (``sun[2] > 0``).
    subpixel_slope_variance : float
        Mean-square slope of the unresolved facets (both axes), >= 0.
    refractive_index : float
        Of water.

    Returns
    -------
    rho : (..., H, W) float32 array
        Glint reflectance (dimensionless; ``pi L / (E_sun mu_s)``).
    """
    check_finite_number("subpixel_slope_variance", subpixel_slope_variance, low=0.0)
    sun = np.asarray(sun, dtype=np.float64)
    if not sun[2] > 0:
        msg = f"sun must be above the horizon (sun[2] > 0); got {sun.tolist()!r}"
        raise ValueError(msg)
    view = np.asarray(view, dtype=np.float32)
    half = view + sun.astype(np.float32)
    half /= np.linalg.norm(half, axis=-1, keepdims=True)
    hz = half[..., 2]
    zx_req = -half[..., 0] / hz  # facet normal (-zx, -zy, 1) parallel to h
    zy_req = -half[..., 1] / hz
    cos_inc = half @ sun.astype(np.float32)
    fres = fresnel_unpolarised(cos_inc, refractive_index).astype(np.float32)
    geom = (math.pi * fres / (4.0 * float(sun[2]) * view[..., 2] * hz**4)).astype(np.float32)
    pdf = cox_munk_iso_pdf(zx_req - slope_x, zy_req - slope_y, subpixel_slope_variance)
    return (geom * pdf).astype(np.float32)


def cox_munk_glint(sun_zenith_deg: float, view_zenith_deg: float, relative_azimuth_deg: float,
                   wind_speed_mps: float, *,
                   refractive_index: float = WATER_REFRACTIVE_INDEX) -> float:
    """Cox–Munk isotropic glint reflectance of a flat-on-average sea (no resolved slope).

    ``relative_azimuth_deg`` is 180 when the camera looks toward the specular point (sun and
    camera on opposite sides), as in the ``coxmunk`` package.
    """
    check_finite_number("sun_zenith_deg", sun_zenith_deg, low=0.0, high=90.0, high_open=True)
    check_finite_number("view_zenith_deg", view_zenith_deg, low=0.0, high=90.0, high_open=True)
    ts, tv, phi = (math.radians(sun_zenith_deg), math.radians(view_zenith_deg),
                   math.radians(relative_azimuth_deg))
    sun = np.array([math.sin(ts), 0.0, math.cos(ts)])
    # coxmunk's convention: sun at azimuth 0, the sensor (seen from the sea) at azimuth phi
    view = np.array([[[math.sin(tv) * math.cos(phi), math.sin(tv) * math.sin(phi),
                       math.cos(tv)]]])
    rho = glint_reflectance(np.zeros((1, 1)), np.zeros((1, 1)), view, sun,
                            subpixel_slope_variance=float(cox_munk_slope_variance(wind_speed_mps)),
                            refractive_index=refractive_index)
    return float(rho[0, 0])


def whitecap_fraction(wind_speed_mps: float) -> float:
    """Whitecap coverage ``W = 3.84e-6 U10^3.41`` (Monahan & O'Muircheartaigh 1980), in [0, 1]."""
    u = check_finite_number("wind_speed_mps", wind_speed_mps, low=0.0)
    return float(min(3.84e-6 * u**3.41, 1.0))


def whitecap_field(shape: tuple[int, int], *, dx_m: float, fraction: float, rng,
                   patch_m: float = 1.5, wind_dir_rad: float = 0.0) -> np.ndarray:
    """A periodic foam-cover map in [0, 1] whose mean is ``fraction``, ``shape`` float32.

    A Gaussian random field with a power-law (fractal) spectrum between the physical outer
    scale ``patch_m`` and an inner scale of 1 cm, stretched 2:1 along the wind, is thresholded
    with a soft, ragged fringe (foam thins out at its edges).  All scales are in metres, so
    the patches shrink in pixels as the camera climbs, like the waves.
    """
    check_finite_number("fraction", fraction, low=0.0, high=1.0)
    check_finite_number("dx_m", dx_m, low=0.0, low_open=True)
    check_finite_number("patch_m", patch_m, low=0.0, low_open=True)
    rng = as_rng(rng)
    h, w = shape
    if fraction <= 0:
        return np.zeros(shape, dtype=np.float32)
    noise = rng.standard_normal(shape)
    ky = 2 * math.pi * np.fft.fftfreq(h, d=dx_m)[:, np.newaxis]
    kx = 2 * math.pi * np.fft.rfftfreq(w, d=dx_m)[np.newaxis, :]
    c, s = math.cos(wind_dir_rad), math.sin(wind_dir_rad)
    k_along, k_across = kx * c + ky * s, -kx * s + ky * c
    k2 = (2.0 * k_along) ** 2 + k_across**2  # patches twice as long along the wind
    k0 = 2 * math.pi / patch_m
    filt = (k2 + k0**2) ** -1.4 * np.exp(-k2 * 0.01**2)
    field = np.fft.irfft2(np.fft.rfft2(noise) * filt, s=shape)
    field /= max(float(field.std()), 1e-12)
    edge = 0.6  # fringe width in standard deviations of the field

    def cover(thr: float, f: np.ndarray) -> np.ndarray:
        return np.clip((f - thr) / edge, 0.0, 1.0) ** 0.7

    sample = field[::2, ::2]
    lo, hi = -6.0, 6.0
    for _ in range(40):  # bisection on the threshold: mean cover = fraction
        mid = 0.5 * (lo + hi)
        if cover(mid, sample).mean() > fraction:
            lo = mid
        else:
            hi = mid
    return cover(0.5 * (lo + hi), field).astype(np.float32)


def advected_crops(field: np.ndarray, shifts_px: np.ndarray, crop: tuple[int, int],
                   offset: tuple[int, int] = (0, 0)) -> np.ndarray:
    """Crops of the periodic map ``field`` ``(n, m)`` carried by the water: frame ``i`` shows
    ``field`` moved by ``-shifts_px[i] = -(rows, cols)`` pixels, to a fraction of a pixel
    (a phase ramp on its spectrum), cropped to ``crop`` from ``offset``, clipped to
    ``[0, 1]`` (the ringing of the map's sharp edges); ``(len(shifts_px), *crop)`` float32.

    Rounded to whole pixels, a slowly drifting patch would stand still and then jump: a
    staircase motion whose spectrum spreads over harmonics of the jump rate, which no
    surface on the sea has.
    """
    n, m = field.shape
    spec = np.fft.rfft2(field)
    fy = np.fft.fftfreq(n)[:, None]
    fx = np.fft.rfftfreq(m)[None, :]
    rows = (np.arange(crop[0]) + offset[0]) % n
    cols = (np.arange(crop[1]) + offset[1]) % m
    out = np.empty((len(shifts_px), *crop), dtype=np.float32)
    for i, (dr, dc) in enumerate(np.asarray(shifts_px, dtype=np.float64)):
        moved = np.fft.irfft2(spec * np.exp(2j * np.pi * (fy * dr + fx * dc)), s=(n, m))
        out[i] = np.clip(moved[np.ix_(rows, cols)], 0.0, 1.0)
    return out


__all__ = [
    "MIN_SLOPE_VARIANCE", "SUN_RADIUS_RAD", "advected_crops", "cox_munk_glint",
    "cox_munk_iso_pdf", "glint_reflectance", "whitecap_field", "whitecap_fraction",
]
