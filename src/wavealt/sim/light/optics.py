"""Optics of the sea surface: Fresnel reflectance, specular glint lobe, rendering.

Paper eq. (3):  ``I = I_water + F(N . c) I_sky + G_s(N, H) g``  with the unpolarised
Fresnel reflectance ``F`` of the air–water interface, the half vector
``H = (s + c) / |s + c|`` between the sun ``s`` and the camera ``c`` directions and a
specular lobe ``G_s = max(N . H, 0)^80``.

Exposure.  With a uniform sky the reflected-sky term varies by only a few per cent of the
mean radiance across realistic slopes, so a camera with a fixed gain would record an almost
flat frame.  Like a real camera locked for a clip, the renderer chooses one black level and
gain per *sequence* from the clean radiance (the paper's normalisation "avoids saturating
the images with too many white or too many black pixels"): the mean maps to the display
water colour and the standard deviation of the luminance to ``contrast`` of full scale.
The glint term is added after that mapping, so ``glint_severity`` is the peak glint as a
fraction of full scale, and clean and glinty frames share one exposure (glinty >= clean
everywhere, equal where the lobe is negligible).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from wavealt._checks import check_finite_number, check_rgb

WATER_REFRACTIVE_INDEX = 1.34


def fresnel_unpolarised(cos_i: np.ndarray, n: float = WATER_REFRACTIVE_INDEX) -> np.ndarray:
    """Unpolarised Fresnel reflectance of light from air onto water (Fresnel equations).

    ``cos_i`` is the cosine of the angle of incidence; values are clipped to ``[0, 1]``.
    ``R = (r_s^2 + r_p^2) / 2``; ``R(1) = ((n-1)/(n+1))^2`` and ``R(0) = 1``.
    """
    c = np.clip(np.asarray(cos_i), 0.0, 1.0)
    sin_t2 = (1.0 - c * c) / (n * n)
    cos_t = np.sqrt(1.0 - sin_t2)
    rs = (c - n * cos_t) / (c + n * cos_t)
    rp = (n * c - cos_t) / (n * c + cos_t)
    return 0.5 * (rs * rs + rp * rp)


def sun_vector(zenith_rad: float, azimuth_rad: float) -> np.ndarray:
    """Unit vector from the sea toward the sun; azimuth from image +x toward +y."""
    s = math.sin(zenith_rad)
    return np.array([s * math.cos(azimuth_rad), s * math.sin(azimuth_rad),
                     math.cos(zenith_rad)], dtype=np.float64)


def surface_normals(slope_x: np.ndarray, slope_y: np.ndarray) -> np.ndarray:
    """Unit normals ``(-sx, -sy, 1) / norm``, shape ``(..., 3)`` float32."""
    inv = 1.0 / np.sqrt(1.0 + slope_x * slope_x + slope_y * slope_y)
    return np.stack([-slope_x * inv, -slope_y * inv, inv], axis=-1).astype(np.float32)


@dataclass(frozen=True)
class Optics:
    """Optical constants of the renderer (paper eq. (3)).

    ``water_rgb`` and ``sky_rgb`` are radiances (arbitrary common unit); ``display_rgb`` is
    the colour the mean clean radiance is shown as, and ``contrast`` the standard deviation
    of the clean luminance, both in full-scale units.
    """

    water_rgb: tuple[float, float, float] = (0.004, 0.020, 0.030)
    sky_rgb: tuple[float, float, float] = (0.60, 0.75, 0.95)
    refractive_index: float = WATER_REFRACTIVE_INDEX
    lobe_exponent: float = 80.0
    display_rgb: tuple[float, float, float] = (0.10, 0.30, 0.40)
    contrast: float = 0.10

    def __post_init__(self) -> None:
        check_finite_number("refractive_index", self.refractive_index, low=1.0, low_open=True)
        check_finite_number("lobe_exponent", self.lobe_exponent, low=0.0, low_open=True)
        check_finite_number("contrast", self.contrast, low=0.0, low_open=True, high=1.0)
        for name in ("water_rgb", "sky_rgb", "display_rgb"):
            check_rgb(name, getattr(self, name))


def _power(x: np.ndarray, exponent: float) -> np.ndarray:
    """``x ** exponent`` by repeated squaring when the exponent is a small integer."""
    e = float(exponent)
    if e != int(e) or not 1 <= e <= 1024:
        return x ** np.float32(e)
    e = int(e)
    result = None
    base = x
    while e:
        if e & 1:
            result = base.copy() if result is None else result * base
        e >>= 1
        if e:
            base = base * base
    return result


def shade(slope_x: np.ndarray, slope_y: np.ndarray, view: np.ndarray, sun: np.ndarray,
          optics: Optics) -> tuple[np.ndarray, np.ndarray]:
    """Per-pixel Fresnel reflectance ``F(N . c)`` and specular lobe ``G_s(N, H)``.

    Parameters
    ----------
    slope_x, slope_y : (..., H, W) arrays
        Surface slopes.
    view : (H, W, 3) array
        Unit vectors from the sea toward the camera.
    sun : (3,) array
        Unit vector toward the sun.

    Returns
    -------
    fresnel, lobe : (..., H, W) float32 arrays
    """
    inv = 1.0 / np.sqrt(1.0 + slope_x * slope_x + slope_y * slope_y)
    # contiguous component planes: strided (H, W, 3) views make every product slower
    cx, cy, cz = (np.ascontiguousarray(view[..., i], dtype=np.float32) for i in range(3))
    n_dot_c = (cz - slope_x * cx - slope_y * cy) * inv
    fres = fresnel_unpolarised(n_dot_c, optics.refractive_index)
    half = view + sun.astype(np.float32)
    half /= np.linalg.norm(half, axis=-1, keepdims=True)
    hx, hy, hz = (np.ascontiguousarray(half[..., i], dtype=np.float32) for i in range(3))
    n_dot_h = (hz - slope_x * hx - slope_y * hy) * inv
    lobe = _power(np.maximum(n_dot_h, 0.0).astype(np.float32), optics.lobe_exponent)
    return fres.astype(np.float32, copy=False), lobe


def clean_radiance(fresnel: np.ndarray, optics: Optics) -> np.ndarray:
    """``I_water + F I_sky`` as ``(..., H, W, 3)`` float32 radiance."""
    water = np.asarray(optics.water_rgb, dtype=np.float32)
    sky = np.asarray(optics.sky_rgb, dtype=np.float32)
    return water + fresnel[..., np.newaxis] * sky


def exposure(fresnel: np.ndarray, optics: Optics) -> tuple[np.ndarray, float]:
    """Sequence-wide black level (per channel) and gain mapping radiance to display units.

    Computed from the Fresnel term of the whole clean sequence: with ``I = I_water + F I_sky``
    the mean radiance is ``I_water + mean(F) I_sky`` and the luminance (channel mean) has the
    standard deviation ``std(F) mean(I_sky)``.  Returns ``(offset_rgb, gain)`` with
    ``display = offset + gain * radiance``.
    """
    water = np.asarray(optics.water_rgb, dtype=np.float64)
    sky = np.asarray(optics.sky_rgb, dtype=np.float64)
    f_mean = float(fresnel.mean(dtype=np.float64))
    f_std = float(fresnel.std(dtype=np.float64))
    lum_std = f_std * float(sky.mean())
    gain = optics.contrast / lum_std if lum_std > 0 else 1.0
    offset = np.asarray(optics.display_rgb, dtype=np.float64) - gain * (water + f_mean * sky)
    return offset.astype(np.float32), float(gain)


def render_pair(slope_x: np.ndarray, slope_y: np.ndarray, view: np.ndarray, sun: np.ndarray,
                *, glint_severity: float, optics: Optics,
                clean_glint_severity: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Render a sequence twice from the same slopes: clean and glinty frames.

    Parameters
    ----------
    slope_x, slope_y : (T, H, W) arrays
        Surface slopes of each frame on the image grid.
    view : (H, W, 3) array
        Unit vectors toward the camera (``Camera.view_vectors``).
    sun : (3,) array
        Unit vector toward the sun.
    glint_severity : float
        Glint gain ``g`` of the glinty frames, in full-scale units (>= 0).
    clean_glint_severity : float
        ``g`` of the clean frames (0: no glint).

    Returns
    -------
    clean, glinty : (T, H, W, 3) float32 arrays in [0, 1]
    """
    g = check_finite_number("glint_severity", glint_severity, low=0.0)
    g0 = check_finite_number("clean_glint_severity", clean_glint_severity, low=0.0)
    fres, lobe = shade(slope_x, slope_y, view, sun, optics)
    offset, gain = exposure(fres, optics)
    # display = offset + gain (I_water + F I_sky) = a + b F, per channel
    a = (offset + gain * np.asarray(optics.water_rgb, dtype=np.float32)).astype(np.float32)
    b = (gain * np.asarray(optics.sky_rgb, dtype=np.float32)).astype(np.float32)
    base = fres[..., np.newaxis] * b
    base += a
    lobe3 = lobe[..., np.newaxis]
    glinty = base + np.float32(g) * lobe3
    np.clip(glinty, 0.0, 1.0, out=glinty)
    if g0:
        base += np.float32(g0) * lobe3
    np.clip(base, 0.0, 1.0, out=base)
    return base, glinty
