"""Camera model of the ``realistic`` preset: attitude, vignetting, exposure, noise, encoding.

Radiance (linear, any unit) becomes the frames a real camera would store:

1. attitude: a small roll/pitch rotates the view rays (:func:`attitude_view_vectors`);
2. vignetting: natural ``cos^4`` fall-off of irradiance off the optical axis, scaled by a
   strength in [0, 1] (0: none, 1: the full ``cos^4`` law of a simple lens);
3. exposure: one gain per sequence (a camera locked for a clip) that puts the mean clean
   luminance at ``target_grey * 2^exposure_ev`` of full scale; glint then saturates as it
   does in real footage;
4. noise: photo-electrons ``e = signal * full_well_e`` with shot noise (Poisson, drawn as its
   Gaussian limit ``N(e, e)``, exact to well under a grey level above ~20 e-) and read
   noise ``N(0, read_noise_e^2)``; clipped to the full well;
5. encoding: the sRGB transfer function (IEC 61966-2-1), 8-bit quantisation, and optionally
   JPEG (Pillow) or H.264 (PyAV/libx264) compression of the sequence.

Clean and glinty frames of a pair share the exposure and the same standard-normal draws, so
they are identical wherever the glint adds nothing.
"""

from __future__ import annotations

import io
import math
from typing import Any

import numpy as np
from PIL import Image

from wavealt._checks import as_rng, check_finite_number
from wavealt.sim.config import COMPRESSIONS, SensorModel


def srgb_encode(linear: np.ndarray) -> np.ndarray:
    """sRGB transfer function (IEC 61966-2-1) of linear values in [0, 1], float32."""
    x = np.clip(np.asarray(linear, dtype=np.float32), 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x,
                    1.055 * np.power(x, 1.0 / 2.4, dtype=np.float32) - 0.055).astype(np.float32)


def srgb_decode(encoded: np.ndarray) -> np.ndarray:
    """Inverse of :func:`srgb_encode`, float32."""
    y = np.clip(np.asarray(encoded, dtype=np.float32), 0.0, 1.0)
    return np.where(y <= 0.04045, y / 12.92,
                    np.power((y + 0.055) / 1.055, 2.4, dtype=np.float32)).astype(np.float32)


def attitude_matrix(roll_rad: float, pitch_rad: float) -> np.ndarray:
    """Rotation ``R = R_y(pitch) R_x(roll)`` from camera to world axes, ``(3, 3)``.

    Roll turns about the image x axis, pitch about the image y axis; zero is nadir.
    """
    cr, sr = math.cos(roll_rad), math.sin(roll_rad)
    cp, sp = math.cos(pitch_rad), math.sin(pitch_rad)
    rx = np.array([[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]])
    ry = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
    return ry @ rx


def attitude_view_vectors(height_px: int, width_px: int, focal_px: float, *, roll_rad: float = 0.0,
                          pitch_rad: float = 0.0) -> tuple[np.ndarray, tuple[int, int]]:
    """View vectors of a tilted camera and the shift of its footprint centre in pixels.

    Pixel ``(v, u)`` looks along ``R ((u-cx)/f, (v-cy)/f, -1)``; the vector from the sea toward
    the camera is its opposite (``Camera.view_vectors`` when ``R = I``).  The footprint centre
    moves by ``f tan`` of the tilt, returned as ``(rows, cols)`` rounded to whole pixels (in
    pixels it does not depend on the altitude).  The keystone stretch across the frame (under
    ``tan(fov/2) tan(tilt)``, 3 % at 60 deg and 3 deg) is neglected: the sea is sampled on
    the nadir grid, so no interpolation enters the surface.

    Returns
    -------
    view : (H, W, 3) float32
    shift_px : (int, int)
    """
    check_finite_number("roll_rad", roll_rad, low=-math.pi / 4, high=math.pi / 4)
    check_finite_number("pitch_rad", pitch_rad, low=-math.pi / 4, high=math.pi / 4)
    rot = attitude_matrix(roll_rad, pitch_rad)
    u = (np.arange(width_px, dtype=np.float64) + 0.5 - width_px / 2.0) / focal_px
    v = (np.arange(height_px, dtype=np.float64) + 0.5 - height_px / 2.0) / focal_px
    uu, vv = np.meshgrid(u, v)
    rays = np.stack([uu, vv, -np.ones_like(uu)], axis=-1) @ rot.T
    view = -rays / np.linalg.norm(rays, axis=-1, keepdims=True)
    axis = rot @ np.array([0.0, 0.0, -1.0])
    shift = (int(round(focal_px * axis[1] / -axis[2])), int(round(focal_px * axis[0] / -axis[2])))
    return view.astype(np.float32), shift


def vignetting_map(height_px: int, width_px: int, focal_px: float, *, strength: float) -> np.ndarray:
    """Relative illumination ``1 - strength (1 - cos^4 theta)``, ``(H, W)`` float32."""
    check_finite_number("strength", strength, low=0.0, high=1.0)
    u = (np.arange(width_px) + 0.5 - width_px / 2.0) / focal_px
    v = (np.arange(height_px) + 0.5 - height_px / 2.0) / focal_px
    cos2 = 1.0 / (1.0 + u[np.newaxis, :] ** 2 + v[:, np.newaxis] ** 2)
    return (1.0 - strength * (1.0 - cos2 * cos2)).astype(np.float32)


def expose_and_read(signal: np.ndarray, normals: np.ndarray, sensor: SensorModel) -> np.ndarray:
    """Full-scale signal ``(..., 3)`` -> noisy linear frames in [0, 1], float32.

    ``normals`` are standard-normal draws shaped like ``signal`` (shared between the clean
    and glinty frames of a pair).  Shot noise variance ``e``, read noise variance ``r^2``.
    """
    fw = np.float32(sensor.full_well_e)
    e = np.clip(signal, 0.0, 1.0).astype(np.float32) * fw
    sigma = np.sqrt(e + np.float32(sensor.read_noise_e) ** 2)
    return np.clip((e + sigma * normals) / fw, 0.0, 1.0).astype(np.float32)


def _jpeg(frames8: np.ndarray, quality: int) -> np.ndarray:
    out = np.empty_like(frames8)
    for i, f in enumerate(frames8):
        buf = io.BytesIO()
        Image.fromarray(f).save(buf, format="JPEG", quality=int(quality))
        buf.seek(0)
        out[i] = np.asarray(Image.open(buf).convert("RGB"))
    return out


def _h264(frames8: np.ndarray, crf: int, fps: float, preset: str = "ultrafast") -> np.ndarray:
    import av  # deferred: 0.4 s, only for H.264 encoding

    t, h, w, _ = frames8.shape
    if h % 2 or w % 2:
        msg = f"h264 needs even frame sizes; got {h}x{w}"
        raise ValueError(msg)
    buf = io.BytesIO()
    with av.open(buf, mode="w", format="mp4") as box:
        stream = box.add_stream("libx264", rate=max(int(round(fps)), 1))
        stream.width, stream.height, stream.pix_fmt = w, h, "yuv420p"
        stream.options = {"crf": str(int(crf)), "preset": preset, "threads": "1"}
        for f in frames8:
            for pkt in stream.encode(av.VideoFrame.from_ndarray(f, format="rgb24")):
                box.mux(pkt)
        for pkt in stream.encode():
            box.mux(pkt)
    buf.seek(0)
    with av.open(buf, mode="r") as box:
        dec = [fr.to_ndarray(format="rgb24") for fr in box.decode(video=0)]
    if len(dec) != t:
        msg = f"h264 round trip returned {len(dec)} frames for {t}"
        raise ValueError(msg)
    return np.stack(dec)


#: Bits of the analogue-to-digital converter; the sRGB curve is applied to its codes by table.
ADC_BITS = 12
_ADC_MAX = 2**ADC_BITS - 1
_SRGB_LUT = srgb_encode(np.arange(_ADC_MAX + 1, dtype=np.float32) / np.float32(_ADC_MAX))


def encode(linear: np.ndarray, sensor: SensorModel, *, fps: float = 30.0) -> np.ndarray:
    """Linear frames ``(T, H, W, 3)`` -> stored frames, float32 in [0, 1].

    A 12-bit ADC code, then (if ``sensor.srgb``) the sRGB curve by look-up table, then
    optionally 8-bit compression.
    """
    lin = np.clip(linear, 0.0, 1.0)
    if sensor.srgb:
        y = _SRGB_LUT[np.rint(lin * np.float32(_ADC_MAX)).astype(np.int16)]
    else:
        y = lin.astype(np.float32)
    if sensor.compression == "none":
        return y
    q = np.rint(y * 255.0).astype(np.uint8)
    if sensor.compression == "jpeg":
        q = _jpeg(q, sensor.jpeg_quality)
    else:
        q = _h264(q, sensor.h264_crf, fps, sensor.h264_preset)
    return (q.astype(np.float32) / np.float32(255.0))


def capture_pair(clean_radiance: np.ndarray, glinty_radiance: np.ndarray, *, sensor: SensorModel,
                 rng: Any, exposure_ev: float = 0.0, vignetting: np.ndarray | None = None,
                 fps: float = 30.0) -> tuple[np.ndarray, np.ndarray]:
    """Photograph a radiance pair with one exposure and one noise draw.

    Parameters
    ----------
    clean_radiance, glinty_radiance : (T, H, W, 3) arrays
        Linear radiance (any common unit), ``glinty >= clean``.
    sensor : SensorModel
    rng : numpy.random.Generator or int
    exposure_ev : float
        Exposure offset from the target grey, stops.
    vignetting : (H, W) array, optional
        Relative illumination (:func:`vignetting_map`).
    fps : float
        Frame rate (for H.264).

    Returns
    -------
    clean, glinty : (T, H, W, 3) float32 in [0, 1]
    """
    check_finite_number("exposure_ev", exposure_ev, low=-10.0, high=10.0)
    rng = as_rng(rng)
    vig = np.float32(1.0) if vignetting is None else vignetting[..., np.newaxis]
    lum = float(np.mean(clean_radiance * vig, dtype=np.float64))
    gain = np.float32(sensor.target_grey * 2.0**exposure_ev / lum) if lum > 0 else np.float32(1.0)
    normals = rng.standard_normal(clean_radiance.shape, dtype=np.float32)
    out = []
    for rad in (clean_radiance, glinty_radiance):
        lin = expose_and_read(rad * (vig * gain), normals, sensor)
        out.append(encode(lin, sensor, fps=fps))
    return out[0], out[1]


__all__ = [
    "COMPRESSIONS", "SensorModel", "attitude_matrix", "attitude_view_vectors", "capture_pair",
    "encode", "expose_and_read", "srgb_decode", "srgb_encode", "vignetting_map",
]
