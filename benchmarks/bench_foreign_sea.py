"""Out-of-distribution check of the dispersion altimeter on seas from an independent generator.

    python benchmarks/bench_foreign_sea.py [--clips 40] [--seed 1000] [--out run.json]
        [--rows blind30,blind15,exact10,prior10] [--workers 1] [--prior-sigma 1.0]
        [--max-current 1.0] [--max-tilt-deg 0] [--sky gradient|cie|clouds]
        [--camera rolling,blur,autoexposure] [--tell-readout] [--depth-m D|LO,HI]
        [--tell-depth] [--one-way] [--supersample N] [--attitude-sigma-deg S] [--h264-crf C]
        [--lens-k1 K [--tell-calibration]] [--choppy L]
        [--save-clips DIR] [--self-check]

The generator is written from the physics alone; it shares no code with ``wavealt.sim``.

* Sea: linear, on a periodic 640 x 640 px grid (2.5 x the 256 px frame: only every fifth
  bin is periodic in the centre crop), every wavenumber up to the pixel Nyquist.  A JONSWAP
  wind sea (Hasselmann et al. 1973; gamma = 1: Pierson & Moskowitz 1964) in wavenumber,
  ``S(k) = alpha/2 k^-3 exp(-5/4 (kp/k)^2) gamma^r``, ``kp = 0.731 g / U10^2``, spread as
  cos^2s(dtheta/2) (Longuet-Higgins et al. 1963), plus a weaker, younger sea running against
  it.  Gravity-capillary dispersion ``omega^2 = (g k + (0.074/1025) k^3) tanh(k d)``: deep
  water (``d`` infinite) unless ``--depth-m`` gives the water a finite depth (Lamb 1932,
  §228 and §267), in which the wavenumber spectrum keeps its shape (Kitaigorodskii, Krasitskii
  & Zaslavskii, J. Phys. Oceanogr. 1975: the saturation range in k does not depend on depth).
* With ``--choppy L`` the water moves on its orbits (first-order Lagrangian, the Gerstner
  sea; Tessendorf's "choppy waves"): each surface point is carried sideways by L times the
  linear field's displacement, so crests sharpen, troughs broaden and every wave carries
  harmonics bound to it (:func:`_lagrangian`); L = 1 is the physical orbit. Kinematic only:
  a short wave keeps its frequency where the orbits compress it (the sea's would change
  with its local wavenumber; Longuet-Higgins & Stewart 1960), and the sea is still drawn
  on its mean plane.
* Motion, exact, as spectral phase: a component k has phase ``k.x - (omega + k.current) t``
  and the frame at t samples the sea at ``x + drift t``: the camera's velocity over the water
  is ``drift - current``.
* Radiance: Schlick's (1994) Fresnel factor (n = 1.34) of each facet for the pixel's ray of a
  pinhole camera at nadir; sky ``L(theta) = 1 + c sin^2 theta`` with a slight azimuthal
  gradient, or with ``--sky cie`` the CIE standard clear sky (ISO 15469 type 12: brighter
  toward the horizon and steeply toward the clip's sun, whose reflection is far from linear
  in the slope), or with ``--sky clouds`` the gradient sky under fair-weather cumulus (cells
  of 150-800 m under a 1-km base covering 20-70 % of the sky, 1.5-4 times the zenith's
  radiance, their edges sharp or soft; :func:`cloud_cover`); upwelling ``(1 - R) L_water``.
  In a third of the clips a sun at 15-50 deg
  zenith adds glitter: a Gaussian in the facet slope about the pixel's specular slope, its
  variance a fraction of Cox & Munk's (1954) ``0.003 + 0.00512 U10``; in the others the sun
  lies outside every facet's specular cone, and the term is left out.
* Camera: level, or with ``--max-tilt-deg`` tilted (even over the disc of that radius,
  toward a random direction; the altimeter is not told): each pixel's ray meets the sea
  plane (the grid linearly interpolated there) and its own view angle sets the Fresnel
  factor, sky and glitter.
* Sensor: exposure locked on frame 0 (median 0.3-0.5 of full scale after gamma), Poisson shot
  noise, read noise, gamma 1/2.2, 8 bits; JPEG (quality 70-92) in half of the clips.
* ``--camera`` adds what a drone's CMOS camera does, each drawn per clip from a stream of its
  own (the scene is the same): ``rolling``, a rolling shutter whose rows are read 10-30 ms
  apart from first to last (row y exposed ``y / 256`` of that later); ``blur``, an exposure
  of 2-16 ms over which each row's radiance is averaged (the waves and the camera move
  during it); ``autoexposure``, the gain not locked but following each frame's median, a
  fraction 0.2-0.6 of the log error a frame, with a jitter of 0.5-3 % a frame.  The
  radiance is rendered on a grid of sub-frame times at most ``SUB_STEP_S`` apart and
  interpolated linearly in time for each row.

Axes: x = image columns (right), y = rows (down), for every vector here.  The altimeter's
``velocity_mps`` is the camera's velocity over the water (``estimate``'s docstring; a camera
hovering over water that drifts at c passes -c): ``drift - current``.  ``--self-check``
confirms it: exact 10-frame fits at 5 m are within 1.5 % with it and 36-89 % off with its
negative or with x and y swapped.

Prints the summary as one JSON object on stdout (``benchmarks/run_all.py`` collects it);
``--out`` gets it with every window's record.  Exit code 0: a report, not a gate.
"""

from __future__ import annotations

import argparse
import io
import json
import math
import os
import sys
import time
from contextlib import nullcontext
from dataclasses import asdict, dataclass, replace
from functools import lru_cache, partial
from multiprocessing import Pool
from pathlib import Path
from statistics import NormalDist
from typing import Any

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402
from PIL import Image  # noqa: E402
from scipy import fft as sfft  # noqa: E402
from scipy import ndimage  # noqa: E402
from scipy.special import gammaln  # noqa: E402
from tqdm import tqdm  # noqa: E402

G = 9.81  # m/s^2
TENSION = 0.074 / 1025.0  # surface tension over density of sea water, m^3/s^2
ALPHA = 0.0081  # Phillips constant of the Pierson-Moskowitz spectrum
R0 = ((1.34 - 1.0) / (1.34 + 1.0)) ** 2  # normal-incidence Fresnel reflectance
SIZE, GRID, FPS, FRAMES = 256, 640, 30.0, 30
GRID_PER_SIZE = GRID  # the sea's grid points per 256 px of frame (--size)
#: row name -> (mode, frames per window); each 30-frame clip is cut into disjoint windows
ROWS = {"blind30": ("blind", 30), "blind15": ("blind", 15),
        "exact10": ("exact", 10), "prior10": ("prior", 10)}
PRIOR_SIGMA_MPS = 1.0  # the prior row's default sigma (--prior-sigma)
#: sky radiance models (--sky): a level plus a horizon brightening and a slight gradient, or
#: the CIE standard general sky type 12, clear and low turbidity (ISO 15469:2004 / CIE S 011,
#: Darula & Kittler 2002), whose circumsolar brightening makes the reflected sky strongly
#: non-linear in the facet slope; or the gradient sky with fair-weather cumulus (``clouds``:
#: :func:`cloud_cover`)
SKIES = ("gradient", "cie", "clouds")
#: the spreading exponent s of ``--one-way`` seas (cos^2s of half the angle: 15-40 puts half
#: the energy within about +-10-17 degrees of the wind), drawn from the clip's stream
#: ``(seed, 7)``
ONE_WAY_SPREAD = (15.0, 40.0)
#: the cumulus deck of ``--sky clouds``, in the tangent plane of the reflected ray
#: (``(rx, ry) / rz``: horizontal distance over the cloud base's height): cosine waves of
#: wavelength CLOUD_SCALE (0.15-0.8: 150-800 m cells under a 1-km base), their sum a unit
#: normal field, thresholded to cover CLOUD_COVER of the sky with edges CLOUD_EDGE (in the
#: field's sd) wide; the cloud CLOUD_BRIGHTNESS times the zenith's radiance (sunlit cumulus
#: against a blue sky)
CLOUD_WAVES = 24
CLOUD_SCALE = (0.15, 0.8)
CLOUD_COVER = (0.2, 0.7)
CLOUD_EDGE = (0.05, 0.5)
CLOUD_BRIGHTNESS = (1.5, 4.0)
#: camera effects (--camera): a rolling shutter, motion blur over the exposure, automatic
#: exposure
CAMERA_EFFECTS = ("rolling", "blur", "autoexposure")
#: the sub-frame render times' largest spacing with a rolling shutter or blur (linear in
#: time between them: 0.6 % of the texture at most at 4 m with a 0.7 m/s drift; 2.5 % at 4 ms)
SUB_STEP_S = 0.002
CIE_CLEAR = (-1.0, -0.32, 10.0, -3.0, 0.45)  # a, b, c, d, e of type 12
#: the Lagrangian sea (--choppy): fixed-point steps tracing a pixel's point back to the
#: particle there (each shrinks the error by about the orbits' strain, |grad D| ~ the slope),
#: and the least Jacobian ``det(I + grad D)`` kept where the surface would fold (a crest
#: breaking; its slopes, held finite, stay steep)
LAGRANGE_ITERATIONS = 8
FOLD_MIN = 0.05
MAX_CHOPPY = 1.5

Vec = tuple[float, float]


def omega(k: np.ndarray, depth_m: float = math.inf) -> np.ndarray:
    """Gravity-capillary angular frequency, rad/s, of wavenumber k, rad/m, in water
    ``depth_m`` deep (inf: deep water)."""
    deep = G * k + TENSION * k**3
    return np.sqrt(deep if math.isinf(depth_m) else deep * np.tanh(k * depth_m))


@dataclass(frozen=True)
class Scene:
    """What one clip is made of; vectors in image axes (x columns, y rows), m/s, radians."""

    seed: int
    altitude_m: float
    hfov_deg: float
    u10: float
    gamma: float  # JONSWAP peak enhancement; 1 = Pierson-Moskowitz
    spread_s: float
    wind_dir: float  # direction the wind sea travels to
    counter_share: float  # energy of the counter-running sea relative to the wind sea
    counter_kp_ratio: float  # its peak wavenumber over the wind sea's (younger: shorter)
    counter_dir: float
    drift: Vec  # camera over ground
    current: Vec  # water over ground
    sky_c: float
    sky_grad: Vec
    water: float  # upwelling radiance, in units of the zenith sky radiance
    glinty: bool
    sun_zenith_deg: float
    sun_azimuth: float
    glint_width: float  # glint slope variance as a fraction of Cox-Munk's
    glint_gain: float
    exposure: float  # median level of frame 0 after gamma, fraction of full scale
    full_well: float
    read_e: float
    jpeg_quality: int | None
    tilt_deg: float = 0.0  # the optical axis from the vertical
    tilt_toward: float = 0.0  # the image direction (from +x toward +y) it swings toward
    sky: str = "gradient"  # SKIES: the sky radiance model
    readout_s: float = 0.0  # rolling shutter: the last row is exposed this much after the first
    shutter_s: float = 0.0  # exposure time over which the radiance is averaged
    ae_rate: float = 0.0  # automatic exposure: share of the log gain error corrected a frame
    ae_jitter: float = 0.0  # ... and the sd of its log gain's jitter a frame
    depth_m: float = math.inf  # the water's depth (inf: deep water)
    lens_k1: float = 0.0  # the lens's radial distortion (OpenCV's k1; 0: a pinhole)
    choppy: float = 0.0  # the orbits' horizontal share (0: the linear, Eulerian sea; 1: Gerstner)

    @property
    def focal_px(self) -> float:
        return SIZE / 2 / math.tan(math.radians(self.hfov_deg) / 2)

    @property
    def gsd(self) -> float:
        """Ground sample distance, m per pixel."""
        return self.altitude_m / self.focal_px

    @property
    def over_water(self) -> Vec:
        """The camera's velocity over the water, m/s."""
        return (self.drift[0] - self.current[0], self.drift[1] - self.current[1])


def draw_scene(seed: int, max_current: float = 1.0, max_tilt_deg: float = 0.0,
               sky: str = "gradient", camera: tuple[str, ...] = (),
               depth_m: tuple[float, float] | None = None, one_way: bool = False) -> Scene:
    """The scene of clip ``seed`` (every parameter drawn from ``seed`` alone; the current's
    speed is its draw scaled to ``max_current``; the camera's tilt, even over the disc of
    radius ``max_tilt_deg``, its ``camera`` effects (:data:`CAMERA_EFFECTS`) and the water's
    depth, log-uniform over ``depth_m = (lo, hi)`` (None: deep water), from streams of their
    own, so that the rest is the same; ``sky`` draws nothing)."""
    r = np.random.default_rng(seed)
    depth = (math.inf if depth_m is None else
             math.exp(np.random.default_rng((seed, 5)).uniform(*np.log(depth_m))))
    t = np.random.default_rng((seed, 3))
    tilt, toward = max_tilt_deg * math.sqrt(t.random()), t.uniform(0, 2 * math.pi)
    c = np.random.default_rng((seed, 4))
    readout, shutter = c.uniform(0.010, 0.030), c.uniform(0.002, 0.016)
    ae_rate, ae_jitter = c.uniform(0.2, 0.6), c.uniform(0.005, 0.03)
    effects = {"readout_s": readout if "rolling" in camera else 0.0,
               "shutter_s": shutter if "blur" in camera else 0.0,
               "ae_rate": ae_rate if "autoexposure" in camera else 0.0,
               "ae_jitter": ae_jitter if "autoexposure" in camera else 0.0}

    def vec(top: float) -> Vec:
        speed, angle = r.uniform(0, top), r.uniform(0, 2 * math.pi)
        return (speed * math.cos(angle), speed * math.sin(angle))

    h = math.exp(r.uniform(0.0, math.log(15.0)))
    hfov, u10 = r.uniform(50, 70), r.uniform(2, 12)
    gamma = 1.0 if r.random() < 0.5 else r.uniform(1.5, 5.0)
    spread, wind = r.uniform(2, 10), r.uniform(0, 2 * math.pi)
    share, kp_ratio = r.uniform(0.1, 0.5), r.uniform(2, 6)
    counter = wind + math.pi + r.normal(0, math.radians(30))
    drift, current = vec(1.0), vec(max_current)
    sky_c, sky_grad, water = r.uniform(0.5, 2.0), vec(0.3), r.uniform(0.02, 0.3)
    glinty = bool(r.random() < 1 / 3)
    sun_z, sun_az = r.uniform(15, 50), r.uniform(0, 2 * math.pi)
    width, gain = r.uniform(0.05, 0.3), r.uniform(20, 100)
    exposure, full_well, read_e = r.uniform(0.3, 0.5), r.uniform(1000, 5000), r.uniform(2, 10)
    jpeg = int(r.integers(70, 93)) if r.random() < 0.5 else None
    if one_way:  # a young sea running one way: no counter sea, a narrow spread (own stream)
        share, spread = 0.0, np.random.default_rng((seed, 7)).uniform(*ONE_WAY_SPREAD)
    return Scene(seed, h, hfov, u10, gamma, spread, wind, share, kp_ratio, counter, drift,
                 current, sky_c, sky_grad, water, glinty, sun_z, sun_az, width, gain,
                 exposure, full_well, read_e, jpeg, tilt, toward, sky, **effects,
                 depth_m=depth)


def pixel_slopes(sc: Scene) -> tuple[np.ndarray, np.ndarray]:
    """Each pixel's ray slopes along x (columns) and y (rows) in its camera's axes: a
    pinhole's, or through a lens with OpenCV's radial distortion ``sc.lens_k1`` (the pixel
    at ``r_d`` from the centre, over the focal length, sees the ray of slope ``r`` with
    ``r_d = r (1 + k1 r^2)``: barrel for k1 < 0), solved by Newton's method."""
    c = (np.arange(SIZE) - (SIZE - 1) / 2) / sc.focal_px
    px, py = np.meshgrid(c, c)
    k1 = sc.lens_k1
    if k1 == 0.0:
        return px, py
    rd = np.hypot(px, py)
    if k1 < 0.0 and float(rd.max()) >= 2.0 / (3.0 * math.sqrt(-3.0 * k1)):
        msg = f"a lens of k1 = {k1:g} folds inside a {sc.hfov_deg:.0f}-degree frame"
        raise ValueError(msg)
    r = rd.copy()
    for _ in range(50):
        r -= (r * (1.0 + k1 * r * r) - rd) / (1.0 + 3.0 * k1 * r * r)
    scale = np.divide(r, rd, out=np.ones_like(r), where=rd > 0)
    return px * scale, py * scale


def lens_calibration(sc: Scene) -> Any:
    """The calibration of the frames of ``sc`` (:class:`wavealt.camera.Calibration`: the
    pinhole at the frame's centre and the lens's k1), as a user would give it."""
    from wavealt.camera import Calibration

    f, c = frame_focal_px(sc), (SIZE // SUPERSAMPLE - 1) / 2
    return Calibration(np.array([[f, 0.0, c], [0.0, f, c], [0.0, 0.0, 1.0]]),
                       np.array([sc.lens_k1, 0.0, 0.0, 0.0, 0.0]))


def camera_rays(sc: Scene) -> tuple[np.ndarray, ...]:
    """Per pixel of a camera (:func:`pixel_slopes`: a pinhole, or a lens that distorts)
    whose optical axis is tilted ``sc.tilt_deg`` from the vertical
    toward image direction ``sc.tilt_toward`` (a rotation about the image-plane axis
    perpendicular to it, Rodrigues): the point its ray meets the sea, grid coordinates
    (column, row; the level camera's centre pixel at the grid's centre), and the unit
    vector from the sea toward the camera ``(vx, vy, vz)``, z up, in the level camera's
    image axes."""
    px, py = pixel_slopes(sc)
    ray = np.stack([px, py, np.ones_like(px)])  # camera axes, z toward the sea
    th, phi = math.radians(sc.tilt_deg), sc.tilt_toward
    a = np.array([-math.sin(phi), math.cos(phi), 0.0])  # rotation axis
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    rot = np.eye(3) + math.sin(th) * k + (1 - math.cos(th)) * (k @ k)
    d = np.einsum("ij,jyx->iyx", rot, ray)
    n = np.sqrt(np.sum(d**2, axis=0))
    centre = (GRID - 1) / 2
    col = centre + sc.altitude_m * d[0] / d[2] / sc.gsd
    row = centre + sc.altitude_m * d[1] / d[2] / sc.gsd
    return col, row, -d[0] / n, -d[1] / n, d[2] / n


def omni_spectrum(k: np.ndarray, kp: float, gamma: float) -> np.ndarray:
    """JONSWAP elevation spectrum in wavenumber, m^2/(rad/m), k > 0: the frequency form
    ``alpha g^2 w^-5 exp(-5/4 (wp/w)^4) gamma^r`` mapped through ``w^2 = g k``."""
    sigma = np.where(k < kp, 0.07, 0.09)
    r = np.exp(-((np.sqrt(k / kp) - 1.0) ** 2) / (2 * sigma**2))
    return 0.5 * ALPHA * k**-3 * np.exp(-1.25 * (kp / k) ** 2) * gamma**r


def spreading(dtheta: np.ndarray, s: float) -> np.ndarray:
    """Longuet-Higgins cos^2s(dtheta/2) directional distribution, unit integral over 2 pi."""
    norm = math.exp(gammaln(s + 1) - gammaln(s + 0.5)) / (2 * math.sqrt(math.pi))
    return norm * np.abs(np.cos(dtheta / 2)) ** (2 * s)


def sea_spectrum(sc: Scene, kx: np.ndarray, ky: np.ndarray) -> np.ndarray:
    """Directional elevation spectrum ``Psi(kx, ky)``, m^2/(rad/m)^2 (0 at k = 0)."""
    k = np.hypot(kx, ky)
    ks = np.where(k > 0, k, 1.0)
    theta = np.arctan2(ky, kx)
    kp = 0.731 * G / sc.u10**2
    psi = (omni_spectrum(ks, kp, sc.gamma) * spreading(theta - sc.wind_dir, sc.spread_s)
           + sc.counter_share * omni_spectrum(ks, kp * sc.counter_kp_ratio, sc.gamma)
           * spreading(theta - sc.counter_dir, sc.spread_s))
    return np.where(k > 0, psi / ks, 0.0)


def wavenumbers(sc: Scene) -> tuple[np.ndarray, np.ndarray]:
    """(kx, ky), rad/m, of the synthesis grid in FFT order (axis 0: rows, axis 1: columns)."""
    k1 = 2 * math.pi * np.fft.fftfreq(GRID, sc.gsd)
    ky, kx = np.meshgrid(k1, k1, indexing="ij")
    return kx, ky


def random_amplitudes(sc: Scene, rng: np.random.Generator) -> np.ndarray:
    """Complex amplitudes ``A(k)`` of ``eta = Re sum A exp(i(k.x - w t))``, E|A|^2 / 2 =
    ``Psi dk^2``, up to the pixel Nyquist wavenumber (a disc: no anisotropic corners)."""
    kx, ky = wavenumbers(sc)
    dk = 2 * math.pi / (GRID * sc.gsd)
    psi = np.where(np.hypot(kx, ky) <= math.pi / sc.gsd, sea_spectrum(sc, kx, ky), 0.0)
    noise = rng.standard_normal((2, GRID, GRID))
    return np.sqrt(psi) * dk * (noise[0] + 1j * noise[1])


def slope_frames(sc: Scene, amp: np.ndarray, n_frames: int,
                 points: tuple[np.ndarray, np.ndarray] | None = None
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Surface slopes (d eta/dx, d eta/dy) of the centre crop seen at frames 0..n-1, or with
    ``points`` (grid column and row of each pixel, :func:`camera_rays`) at those points of
    the periodic grid, linearly interpolated.

    The field's spectrum at k holds the wave travelling along k, ``A(k)``, and the one along
    -k, ``conj A(-k)``; the slopes are ``i k`` times it, and one complex inverse FFT gives
    ``sx + i sy``.  The drift and the current enter only as phase:
    ``exp(i (k.(drift - current) -+ w) t)``.
    """
    p, q, adv, w = _slope_spectra(sc, amp)
    step_p, step_q = np.exp(1j * (adv - w) / FPS), np.exp(1j * (adv + w) / FPS)
    out = np.empty((n_frames, SIZE, SIZE), np.complex128)
    for t in range(n_frames):
        out[t] = _synthesise(p + q, points, sc)
        p *= step_p
        q *= step_q
    return out.real, out.imag


def _slope_spectra(sc: Scene, amp: np.ndarray) -> tuple[np.ndarray, ...]:
    """The slope field's two spectra at t = 0, ``i k A(k) / 2`` (waves along k) and
    ``i k conj A(-k) / 2`` (along -k), and the phase rates' parts ``k.(drift - current)``
    and ``omega(k)``, rad/s (:func:`slope_frames`)."""
    kx, ky = wavenumbers(sc)
    w = omega(np.hypot(kx, ky), sc.depth_m)
    ux, uy = sc.over_water
    adv = kx * ux + ky * uy
    grad = 0.5j * (kx + 1j * ky)
    p = grad * amp
    q = grad * np.conj(np.roll(amp[::-1, ::-1], 1, axis=(0, 1)))
    return p, q, adv, w


def _synthesise(spec: np.ndarray, points: tuple[np.ndarray, np.ndarray] | None,
                sc: Scene | None = None) -> np.ndarray:
    """``sx + i sy`` of the slope spectrum ``spec``: the centre crop, or at ``points`` (grid
    column and row of each pixel) of the periodic grid, linearly interpolated; with
    ``sc.choppy`` the surface of the Lagrangian sea (:func:`_lagrangian`)."""
    if sc is not None and sc.choppy:
        return _lagrangian(spec, points, sc)
    if points is None:
        lo = (GRID - SIZE) // 2
        rows = sfft.ifft(spec, axis=0, norm="forward")[lo:lo + SIZE]
        return sfft.ifft(rows, axis=1, norm="forward")[:, lo:lo + SIZE]
    field = sfft.ifft2(spec, norm="forward")
    at = [points[1], points[0]]
    out = np.empty((SIZE, SIZE), np.complex128)
    out.real = ndimage.map_coordinates(field.real, at, order=1, mode="grid-wrap")
    out.imag = ndimage.map_coordinates(field.imag, at, order=1, mode="grid-wrap")
    return out


def _lagrangian(spec: np.ndarray, points: tuple[np.ndarray, np.ndarray] | None,
                sc: Scene) -> np.ndarray:
    """``sx + i sy`` of a sea whose water moves on its orbits (first-order Lagrangian, the
    Gerstner sea of Tessendorf's "choppy waves"): the particle at rest at ``x0`` lies at
    ``x0 + D(x0)``, ``D = choppy * sum i k/|k| H(k) exp(i k.x0)`` (``H`` the height
    spectrum, ``spec = i (kx + i ky) H``), at height ``eta(x0)``; ``choppy = 1`` is the
    physical orbit (a wave ``A cos(k x0 - w t)`` at ``x0 - A sin(k x0 - w t)``: crests
    sharp, troughs broad, its harmonics bound to it).  Each pixel's point ``x`` is traced
    back to its ``x0`` by fixed-point iteration (``x0 = x - D(x0)``; ``|grad D|``, about
    the slopes, is well below 1), and the surface's slope there is ``M^-1 grad eta`` with
    ``M = I + grad D`` (the chain rule through ``x0 -> x``); where the surface would fold
    (``det M`` near 0: a breaking crest) ``det M`` is held at ``FOLD_MIN``."""
    kx, ky = wavenumbers(sc)
    k = np.hypot(kx, ky)
    kk = np.where(k > 0, k, 1.0)
    height = np.where(k > 0, spec / (1j * (kx + 1j * ky) + (k == 0)), 0.0)
    lam = sc.choppy
    fields = [sfft.ifft2(s, norm="forward") for s in (
        spec,                                          # eta_x + i eta_y
        lam * spec / kk / sc.gsd,                      # (Dx + i Dy) in grid points
        -lam * (kx**2 + 1j * ky**2) / kk * height,     # dDx/dx + i dDy/dy
        -lam * kx * ky / kk * height)]                 # dDx/dy (= dDy/dx)
    if points is None:
        lo = (GRID - SIZE) // 2
        row, col = np.mgrid[lo:lo + SIZE, lo:lo + SIZE].astype(np.float64)
    else:
        col, row = points

    def at(field: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        return ndimage.map_coordinates(field, [y, x], order=1, mode="grid-wrap")

    x0, y0 = col, row
    for _ in range(LAGRANGE_ITERATIONS):
        x0 = col - at(fields[1].real, x0, y0)
        y0 = row - at(fields[1].imag, x0, y0)
    p, q = at(fields[0].real, x0, y0), at(fields[0].imag, x0, y0)
    a, b = at(fields[2].real, x0, y0), at(fields[2].imag, x0, y0)
    c = at(fields[3].real, x0, y0)
    det = np.maximum((1 + a) * (1 + b) - c * c, FOLD_MIN)
    return ((1 + b) * p - c * q) / det + 1j * ((1 + a) * q - c * p) / det


def slopes_at(sc: Scene, amp: np.ndarray, times: np.ndarray,
              points: tuple[np.ndarray, np.ndarray] | None = None
              ) -> tuple[np.ndarray, np.ndarray]:
    """Surface slopes as :func:`slope_frames` gives them, at arbitrary ``times`` (s): each
    component's phase ``exp(i (k.(drift - current) -+ w) t)`` taken whole, or where the
    times are evenly spaced, taken whole at the first and stepped from there."""
    p, q, adv, w = _slope_spectra(sc, amp)
    out = np.empty((len(times), SIZE, SIZE), np.complex128)
    # evenly spaced times (a frame's sub-frame renders): the phases stepped from the first
    gaps = np.diff(times)
    even = gaps.size > 0 and bool(np.allclose(gaps, gaps[0], rtol=0.0, atol=1e-12))
    if even:
        p = p * np.exp(1j * (adv - w) * times[0])
        q = q * np.exp(1j * (adv + w) * times[0])
        step_p, step_q = np.exp(1j * (adv - w) * gaps[0]), np.exp(1j * (adv + w) * gaps[0])
    for i, t in enumerate(times):
        if even:
            out[i] = _synthesise(p + q, points, sc)
            p *= step_p
            q *= step_q
        else:
            out[i] = _synthesise(p * np.exp(1j * (adv - w) * t) + q * np.exp(1j * (adv + w) * t),
                                 points, sc)
    return out.real, out.imag


def exposed_radiance(sc: Scene, amp: np.ndarray, n_frames: int,
                     points: tuple[np.ndarray, np.ndarray] | None = None,
                     view: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
                     ) -> np.ndarray:
    """Radiance of each frame as a rolling shutter reads it (row y exposed from
    ``y / SIZE * readout_s`` after the frame's start), averaged over the exposure
    ``shutter_s``; the radiance is rendered at sub-frame times at most ``SUB_STEP_S`` apart
    and interpolated linearly in time for each row, at instants across the exposure at most
    ``SUB_STEP_S`` apart."""
    span = sc.readout_s + sc.shutter_s
    taus = np.linspace(0.0, span, max(2, math.ceil(span / SUB_STEP_S) + 1))
    starts = np.arange(SIZE) / SIZE * sc.readout_s
    n_inst = max(1, math.ceil(sc.shutter_s / SUB_STEP_S))
    instants = (np.arange(n_inst) + 0.5) / n_inst * sc.shutter_s
    rows = np.arange(SIZE)
    out = np.empty((n_frames, SIZE, SIZE))
    for f in range(n_frames):
        sub = radiance(sc, *slopes_at(sc, amp, f / FPS + taus, points), view)
        acc = np.zeros((SIZE, SIZE))
        for d in instants:
            pos = np.interp(starts + d, taus, np.arange(taus.size))
            j = np.minimum(pos.astype(int), taus.size - 2)
            frac = (pos - j)[:, None]
            acc += (1 - frac) * sub[j, rows] + frac * sub[j + 1, rows]
        out[f] = acc / instants.size
    return out


def schlick(cos_i: np.ndarray) -> np.ndarray:
    """Fresnel reflectance of water by Schlick's approximation."""
    return R0 + (1 - R0) * (1 - cos_i) ** 5


def sun_direction(sc: Scene) -> tuple[float, float, float]:
    """Unit vector toward the sun, image axes (x columns, y rows, z up)."""
    z, az = math.radians(sc.sun_zenith_deg), sc.sun_azimuth
    return math.sin(z) * math.cos(az), math.sin(z) * math.sin(az), math.cos(z)


def sky_radiance(sc: Scene, rx: np.ndarray, ry: np.ndarray, rz: np.ndarray) -> np.ndarray:
    """Sky radiance along unit rays ``(rx, ry, rz)``, in units of the zenith's: ``gradient``,
    ``1 + c sin^2 theta`` times a slight linear gradient; ``cie``, the CIE standard general
    sky type 12, ``f(chi) phi(Z) / (f(Z_s) phi(0))`` with ``phi(Z) = 1 + a exp(b / cos Z)``,
    ``f(chi) = 1 + c (exp(d chi) - exp(d pi / 2)) + e cos^2 chi`` (``Z`` the ray's zenith
    angle, ``chi`` its angle from the sun, ``Z_s`` the sun's zenith angle); a ray below the
    horizon takes the horizon's gradation."""
    if sc.sky in ("gradient", "clouds"):
        blue = (1 + sc.sky_c * (1 - np.clip(rz, 0, 1) ** 2)) * (
            1 + sc.sky_grad[0] * rx + sc.sky_grad[1] * ry)
        if sc.sky == "gradient":
            return blue
        cover, bright = cloud_cover(sc, rx, ry, rz)
        return blue * (1 - cover) + bright * cover
    a, b, c, d, e = CIE_CLEAR
    sun = sun_direction(sc)

    def indicatrix(cos_chi: np.ndarray | float) -> np.ndarray | float:
        chi = np.arccos(np.clip(cos_chi, -1.0, 1.0))
        return 1 + c * (np.exp(d * chi) - math.exp(d * math.pi / 2)) + e * np.cos(chi) ** 2

    cos_z = np.maximum(rz, 1e-3)
    gradation = 1 + a * np.exp(b / cos_z)
    cos_chi = (rx * sun[0] + ry * sun[1] + rz * sun[2]) / np.sqrt(rx**2 + ry**2 + rz**2)
    return indicatrix(cos_chi) * gradation / (indicatrix(sun[2]) * (1 + a * math.exp(b)))


def cloud_deck(sc: Scene) -> dict[str, Any]:
    """The cumulus deck of ``--sky clouds`` over clip ``sc``, drawn from the clip's stream
    ``(seed, 6)`` alone (the scene is the one drawn without it): its cover, edge width and
    brightness, and its waves' wavenumbers, directions and phases (:data:`CLOUD_WAVES`)."""
    g = np.random.default_rng((sc.seed, 6))
    scale = g.uniform(*CLOUD_SCALE)
    cover, edge, bright = (g.uniform(*CLOUD_COVER), g.uniform(*CLOUD_EDGE),
                           g.uniform(*CLOUD_BRIGHTNESS))
    angle = g.uniform(0, 2 * math.pi, CLOUD_WAVES)
    k = 2 * math.pi / (scale * g.uniform(0.7, 1.4, CLOUD_WAVES))
    phase = g.uniform(0, 2 * math.pi, CLOUD_WAVES)
    return {"cover": cover, "edge": edge, "bright": bright, "k": k, "angle": angle,
            "phase": phase}


def cloud_cover(sc: Scene, rx: np.ndarray, ry: np.ndarray,
                rz: np.ndarray) -> tuple[np.ndarray, float]:
    """The share of each ray ``(rx, ry, rz)`` that the cumulus deck (:func:`cloud_deck`)
    covers (0 to 1), and the clouds' radiance in units of the zenith's.  The deck is fixed
    to the sky: a camera that moves sees its reflection stay put (the clouds, at infinity,
    do not move in 1 s), the waves' slopes carrying it back and forth."""
    deck = cloud_deck(sc)
    tz = np.maximum(rz, 0.05)  # a ray at the horizon sees the deck's far edge
    u, v = rx / tz, ry / tz
    field = np.zeros(np.broadcast(u, v).shape)
    for kj, aj, pj in zip(deck["k"], deck["angle"], deck["phase"]):
        field += np.cos(kj * (math.cos(aj) * u + math.sin(aj) * v) + pj)
    field *= math.sqrt(2.0 / CLOUD_WAVES)  # unit variance
    # the threshold that the unit normal exceeds with probability ``cover``, smoothed
    thr = float(NormalDist().inv_cdf(1.0 - deck["cover"]))
    x = np.clip((field - thr) / deck["edge"] + 0.5, 0.0, 1.0)
    return x * x * (3 - 2 * x), deck["bright"]


def radiance(sc: Scene, sx: np.ndarray, sy: np.ndarray,
             view: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """Linear radiance of each pixel (units of the zenith sky) from the facet slopes;
    ``view``: each pixel's unit vector from the sea toward the camera (a tilted camera's,
    :func:`camera_rays`), else a level camera's."""
    if view is None:
        px, py = pixel_slopes(sc)
        nv = np.sqrt(1 + px**2 + py**2)
        view = (-px / nv, -py / nv, 1 / nv)  # unit vector from the sea toward the camera
    vx, vy, vz = view
    inv = 1 / np.sqrt(1 + sx**2 + sy**2)
    nx, ny, nz = -sx * inv, -sy * inv, inv  # facet normal
    cos_i = np.clip(nx * vx + ny * vy + nz * vz, 0.0, 1.0)
    rx, ry, rz = 2 * cos_i * nx - vx, 2 * cos_i * ny - vy, 2 * cos_i * nz - vz
    sky = sky_radiance(sc, rx, ry, rz)
    fres = schlick(cos_i)
    lum = fres * sky + (1 - fres) * sc.water
    if sc.glinty:
        sun = sun_direction(sc)
        hx, hy, hz = sun[0] + vx, sun[1] + vy, sun[2] + vz  # half vector, unnormalised
        hn = np.sqrt(hx**2 + hy**2 + hz**2)
        var = sc.glint_width * (0.003 + 0.00512 * sc.u10)  # Cox-Munk mean-square slope part
        d2 = (sx + hx / hz) ** 2 + (sy + hy / hz) ** 2
        fres_sun = schlick((hx * vx + hy * vy + hz * vz) / hn)
        lum = lum + sc.glint_gain * (R0 + sc.water) * fres_sun / R0 * np.exp(-d2 / var)
    return lum


def exposure_gains(sc: Scene, lum: np.ndarray) -> np.ndarray:
    """Each frame's gain: locked on frame 0 (its median at ``exposure`` after gamma), or with
    automatic exposure (``ae_rate > 0``) moved each frame by ``ae_rate`` of the log error
    against that frame's own target, plus a jitter (a stream of its own)."""
    target = np.log(sc.exposure**2.2 / np.median(lum.reshape(len(lum), -1), axis=1))
    if sc.ae_rate == 0.0:
        return np.full(len(lum), math.exp(target[0]))
    jitter = np.random.default_rng((sc.seed, 5)).normal(0.0, sc.ae_jitter, len(lum))
    log_gain = np.empty(len(lum))
    log_gain[0] = target[0]
    for t in range(1, len(lum)):
        log_gain[t] = log_gain[t - 1] + sc.ae_rate * (target[t] - log_gain[t - 1]) + jitter[t]
    return np.exp(log_gain)


def capture(sc: Scene, lum: np.ndarray,
            rng: np.random.Generator) -> tuple[np.ndarray, dict[str, float]]:
    """8-bit frames (exposure locked or automatic, shot and read noise, gamma 1/2.2, optional
    JPEG), and the standard deviations (8-bit steps) of frame 0 without noise and of its
    noise."""
    gains = exposure_gains(sc, lum)
    scale = gains[:, None, None] if sc.ae_rate else float(gains[0])
    electrons = rng.poisson(np.minimum(lum * scale, 2.0) * sc.full_well)
    signal = (electrons + rng.normal(0.0, sc.read_e, lum.shape)) / sc.full_well
    frames = np.round(np.clip(signal, 0, 1) ** (1 / 2.2) * 255).astype(np.uint8)
    if H264_CRF is not None:  # a video camera: the clip coded as a stream, not as stills
        frames = h264_round_trip(frames, H264_CRF)
    elif sc.jpeg_quality is not None:
        for t, frame in enumerate(frames):
            buf = io.BytesIO()
            Image.fromarray(frame).save(buf, format="JPEG", quality=sc.jpeg_quality)
            frames[t] = np.asarray(Image.open(buf))
    clean = np.clip(lum[0] * gains[0], 0, 1) ** (1 / 2.2) * 255
    return frames, {"texture_dn": float(np.std(clean)),
                    "noise_dn": float(np.std(frames[0] - clean))}


def h264_round_trip(frames: np.ndarray, crf: int) -> np.ndarray:
    """Grey uint8 frames ``(T, H, W)`` coded with libx264 (its default preset, ``medium``:
    quarter-pixel motion, B-frames) at ``crf`` and decoded again (the luma)."""
    import av

    buf = io.BytesIO()
    with av.open(buf, mode="w", format="mp4") as box:
        stream = box.add_stream("libx264", rate=round(FPS))
        stream.width, stream.height, stream.pix_fmt = frames.shape[2], frames.shape[1], "yuv420p"
        stream.options = {"crf": str(int(crf)), "preset": "medium", "threads": "1"}
        for f in frames:
            for pkt in stream.encode(av.VideoFrame.from_ndarray(f, format="gray")):
                box.mux(pkt)
        for pkt in stream.encode():
            box.mux(pkt)
    buf.seek(0)
    with av.open(buf) as box:
        out = np.stack([f.to_ndarray(format="gray") for f in box.decode(video=0)])
    if out.shape != frames.shape:
        msg = f"H.264 round trip gave {out.shape} for {frames.shape}"
        raise ValueError(msg)
    return out


def render_clip(sc: Scene, n_frames: int = FRAMES) -> tuple[np.ndarray, dict[str, float]]:
    """The clip of scene ``sc``, uint8 ``(T, 256, 256)``, and its contrast (``capture``)."""
    rng = np.random.default_rng((sc.seed, 1))
    amp = random_amplitudes(sc, rng)
    points, view = None, None
    if sc.tilt_deg != 0.0 or sc.lens_k1 != 0.0:
        col, row, *rays = camera_rays(sc)
        points, view = (col, row), tuple(rays)
    if sc.readout_s > 0 or sc.shutter_s > 0:
        return capture(sc, pixel_means(exposed_radiance(sc, amp, n_frames, points, view)), rng)
    sx, sy = slope_frames(sc, amp, n_frames, points)
    return capture(sc, pixel_means(radiance(sc, sx, sy, view)), rng)


def pixel_means(lum: np.ndarray) -> np.ndarray:
    """Radiance ``(T, SIZE, SIZE)`` as the frame's pixels integrate it: the mean of each
    ``SUPERSAMPLE`` x ``SUPERSAMPLE`` block (itself where ``SUPERSAMPLE`` is 1)."""
    s = SUPERSAMPLE
    if s == 1:
        return lum
    t, n = lum.shape[0], lum.shape[1] // s
    return lum.reshape(t, n, s, n, s).mean(axis=(2, 4))


def frame_focal_px(sc: Scene) -> float:
    """The focal length, px, of the frames the altimeter is given (:func:`pixel_means`)."""
    return sc.focal_px / SUPERSAMPLE


#: the altimeter's working scale (``--working-px``; None: its default)
WORKING_PX: int | None = None
#: the clips coded as H.264 video at this constant rate factor (``--h264-crf``; None: not)
H264_CRF: int | None = None
#: the altimeter told that the camera looks straight down within this many degrees a side
#: (``--attitude-sigma-deg``, ``DispersionAltimeter(attitude_sigma_deg=)``; None: not told)
ATTITUDE_SIGMA_DEG: float | None = None
#: each frame's pixel the mean of SUPERSAMPLE x SUPERSAMPLE radiance samples (``--supersample``):
#: a pixel integrates the radiance over its area, so the optics' non-linear products of the
#: waves finer than it average out instead of aliasing into the band; the sea is rendered at
#: ``SIZE`` px, the frames are ``SIZE / SUPERSAMPLE``
SUPERSAMPLE = 1
#: the camera's lens distorts radially, OpenCV's k1 (``--lens-k1``; 0: a pinhole), and the
#: altimeter is given the frames as they are, or, with ``--tell-calibration``, turned to a
#: pinhole's view by the calibration (:class:`wavealt.camera.NadirView`, as ``wavealt
#: altitude --calibration`` turns them)
LENS_K1 = 0.0
TELL_CALIBRATION = False
#: the water's orbits' horizontal share (``--choppy``, :func:`_lagrangian`; 0: the linear sea)
CHOPPY = 0.0
#: the most radial distortion ``--lens-k1`` takes: a wide drone lens left uncorrected (the
#: model's radius ``r (1 + k1 r^2)`` folds at ``2 / (3 sqrt(-3 k1))`` of the focal length,
#: 1.11 at -0.12, beyond the corner of a 70-degree frame at 0.99)
MAX_LENS_K1 = 0.12


def set_size(size: int, working_px: int | None = None, fps: float = 30.0,
             h264_crf: int | None = None, attitude_sigma_deg: float | None = None,
             supersample: int = 1, lens_k1: float = 0.0,
             tell_calibration: bool = False, choppy: float = 0.0) -> None:
    """Render ``size``-px frames over the same field of view (``--size``; the sea's grid
    grows with them, its margin around the frame in the same proportion), ``fps`` of them a
    second (``--fps``; a row keeps its frame count, so its clip lasts ``frames / fps`` s),
    fitted at the altimeter's working scale ``working_px`` (None: its default), coded as
    H.264 video at ``h264_crf`` (``--h264-crf``; None: 8-bit frames), each pixel the mean
    of ``supersample`` x ``supersample`` radiance samples (the sea rendered at
    ``size * supersample`` px, :data:`SUPERSAMPLE`), through a lens of radial distortion
    ``lens_k1``, told (``tell_calibration``) or not (:data:`LENS_K1`), over a sea whose
    orbits have the horizontal share ``choppy`` (:data:`CHOPPY`); also each worker's
    initializer."""
    global SIZE, GRID, WORKING_PX, FPS, H264_CRF, ATTITUDE_SIGMA_DEG, SUPERSAMPLE, LENS_K1
    global TELL_CALIBRATION, CHOPPY
    LENS_K1, TELL_CALIBRATION, CHOPPY = float(lens_k1), bool(tell_calibration), float(choppy)
    size *= supersample
    SIZE, GRID, WORKING_PX, FPS = size, GRID_PER_SIZE * size // 256, working_px, float(fps)
    H264_CRF, ATTITUDE_SIGMA_DEG, SUPERSAMPLE = h264_crf, attitude_sigma_deg, supersample
    _altimeter.cache_clear()


@lru_cache(maxsize=4)
def _altimeter(water_depth_m: float | None = None) -> Any:
    """The altimeter the clips are read with; ``water_depth_m``: told the water's depth
    (None: deep water, the altimeter's default)."""
    from wavealt.altimetry.dispersion import DispersionAltimeter

    kw = {} if WORKING_PX is None else {"working_px": WORKING_PX}
    return DispersionAltimeter(dispersion="gravity-capillary", water_depth_m=water_depth_m,
                               attitude_sigma_deg=ATTITUDE_SIGMA_DEG, **kw)


def mode_velocity(sc: Scene, prior_sigma: float = PRIOR_SIGMA_MPS) -> dict[str, dict]:
    """Per mode, what the altimeter is told of clip ``sc``'s velocity: nothing (blind), the
    camera's velocity over the water (exact), or the drift with ``prior_sigma`` (prior)."""
    return {"blind": {}, "exact": {"velocity_mps": sc.over_water},
            "prior": {"velocity_mps": sc.drift, "velocity_sigma_mps": prior_sigma}}


def evaluate_clip(seed: int, rows: tuple[str, ...], save_dir: str | None,
                  prior_sigma: float = PRIOR_SIGMA_MPS, max_current: float = 1.0,
                  max_tilt_deg: float = 0.0, sky: str = "gradient",
                  camera: tuple[str, ...] = (), tell_readout: bool = False,
                  depth_m: tuple[float, float] | None = None,
                  tell_depth: bool = False, one_way: bool = False,
                  aspect: tuple[int, int] | None = None) -> list[dict]:
    """One record per window of every row of clip ``seed``; ``tell_readout``: the altimeter
    is given the rolling shutter's readout time; ``tell_depth``: the water's depth (drawn
    from ``depth_m``, :func:`draw_scene`); ``one_way``: a sea running one way; ``aspect``:
    the frames cropped to this width : height (:func:`crop_to_aspect`)."""
    sc = replace(draw_scene(seed, max_current, max_tilt_deg, sky, camera, depth_m, one_way),
                 lens_k1=LENS_K1, choppy=CHOPPY)
    altimeter = _altimeter(sc.depth_m if tell_depth and math.isfinite(sc.depth_m) else None)
    frames, contrast = render_clip(sc)
    truth = {**asdict(sc), "focal_px": frame_focal_px(sc), "over_water": sc.over_water,
             **contrast}
    truth["depth_m"] = None if math.isinf(sc.depth_m) else sc.depth_m  # (JSON has no inf)
    if save_dir:
        np.save(Path(save_dir) / f"clip{seed}.npy", frames)
        (Path(save_dir) / f"clip{seed}.json").write_text(json.dumps(truth, indent=1))
    focal = frame_focal_px(sc)
    saturated = float(np.mean(frames == 255))  # the camera's frames, not a view of them
    if TELL_CALIBRATION and sc.lens_k1 != 0.0:  # the frames a pinhole's view, as given
        from wavealt.camera import NadirView

        view = NadirView(lens_calibration(sc), frames.shape[2], frames.shape[1])
        frames, focal = view(frames), view.focal_px
    if aspect is not None:
        frames = crop_to_aspect(frames, aspect)
    base = {k: truth[k] for k in ("seed", "altitude_m", "u10", "hfov_deg", "drift", "current",
                                  "glinty", "jpeg_quality", "texture_dn", "noise_dn",
                                  "tilt_deg", "tilt_toward", "readout_s", "shutter_s",
                                  "ae_rate", "ae_jitter", "depth_m", "lens_k1", "choppy")}
    base["saturated_share"] = saturated
    velocity = mode_velocity(sc, prior_sigma)
    records = []
    for row in rows:
        mode, n = ROWS[row]
        for start in range(0, FRAMES - n + 1, n):
            t0 = time.perf_counter()
            try:
                res = altimeter.estimate(frames[start:start + n], fps=FPS,
                                            focal_px=focal, **velocity[mode],
                                            readout_s=sc.readout_s if tell_readout else 0.0)
                out = {"est": res.altitude_m, "std": res.altitude_std_m,
                       "trusted": bool(res.trusted), "reason": res.reason,
                       "quality": res.quality, "signal": res.signal,
                       "est_velocity": list(res.camera_velocity_mps)}
            except ValueError as exc:  # e.g. frames without texture
                out = {"est": math.nan, "std": math.nan, "trusted": False, "reason": str(exc)}
            records.append({**base, "row": row, "mode": mode, "start": start,
                            "latency_s": time.perf_counter() - t0, **out})
    return records


def parse_aspect(text: str) -> tuple[int, int]:
    """``--aspect W:H`` as ``(W, H)``; ValueError naming it where it is not two whole numbers
    within 1:4-4:1."""
    parts = text.split(":")
    if (len(parts) != 2 or not all(p.isdigit() and int(p) > 0 for p in parts)
            or not 1 / 4 <= int(parts[0]) / int(parts[1]) <= 4):
        msg = f"--aspect must be W:H, two whole numbers within 1:4-4:1; got {text!r}"
        raise ValueError(msg)
    return int(parts[0]), int(parts[1])


def crop_to_aspect(frames: np.ndarray, aspect: tuple[int, int]) -> np.ndarray:
    """The middle of square frames ``(T, N, N[, 3])`` whose width : height is ``aspect``, the
    longer side kept whole (``--aspect``; 16:9 of 512 px: 512 x 288): a video camera's frame,
    whose focal length is quoted across its width, with the same optics and pixels."""
    n = frames.shape[1]
    w, h = aspect
    rows = n if h >= w else 2 * round(n * h / w / 2)
    cols = n if w >= h else 2 * round(n * w / h / 2)
    top, left = (n - rows) // 2, (n - cols) // 2
    return np.ascontiguousarray(frames[:, top:top + rows, left:left + cols])


def _stats(recs: list[dict]) -> dict[str, Any]:
    """Metrics of a set of window records (all windows, estimates that raised excluded), and
    the kinds of reason the untrusted ones gave (figures as N, most frequent first)."""
    from wavealt.altimetry.dispersion.result import reason_counts

    if not recs:
        return {"windows": 0}
    h, est, std, tr = (np.array([r[key] for r in recs])
                       for key in ("altitude_m", "est", "std", "trusted"))
    ok = np.isfinite(est)
    rel, ratio = np.abs(est - h) / h, est / h
    covered = np.abs(est - h) <= 3 * std
    off = [{"seed": r["seed"], "start": r["start"], "altitude_m": round(r["altitude_m"], 3),
            "est": round(r["est"], 3), "std": round(r["std"], 3), "rel_err": round(e, 4),
            "reason": r["reason"], "signal": r.get("signal")}
           for r, e in zip(recs, rel, strict=True) if r["trusted"] and e > 0.1]
    half, double = ok & (ratio >= 0.45) & (ratio <= 0.55), ok & (ratio >= 1.8) & (ratio <= 2.2)

    def mean(x: np.ndarray, f: Any = np.mean) -> float | None:
        return float(f(x)) if x.size else None

    return {"windows": len(recs), "no_estimate": int(np.sum(~ok)),
            "rel_mae": mean(rel[ok]), "median_rel_err": mean(rel[ok], np.median),
            "median_signed_rel_err": mean((ratio - 1)[ok], np.median),
            "trusted_share": float(np.mean(tr)), "trusted_rel_mae": mean(rel[tr]),
            "trusted_over_10pct": len(off), "trusted_over_10pct_list": off,
            "coverage_3sigma": mean(covered[ok]), "coverage_3sigma_trusted": mean(covered[tr]),
            "near_half": int(half.sum()), "near_half_trusted": int((half & tr).sum()),
            "near_double": int(double.sum()), "near_double_trusted": int((double & tr).sum()),
            "median_texture_snr": float(np.median([r["texture_dn"] / r["noise_dn"]
                                                   for r in recs])),
            "median_latency_s": float(np.median([r["latency_s"] for r in recs])),
            "untrusted_reasons": reason_counts(r["reason"] for r in recs
                                               if not r["trusted"])}


def summarize(records: list[dict], rows: tuple[str, ...]) -> dict[str, Any]:
    """Per row: the metrics over all windows, the glinty clips' and the non-glinty ones'."""
    out = {}
    for row in rows:
        rr = [r for r in records if r["row"] == row]
        out[row] = {"all": _stats(rr), "glinty": _stats([r for r in rr if r["glinty"]]),
                    "non_glinty": _stats([r for r in rr if not r["glinty"]])}
    return out


def self_check() -> bool:
    """Check the generator's physics (and the altimeter's velocity sign); print PASS/FAIL."""
    ok = True

    def report(name: str, passed: bool, detail: str) -> None:
        nonlocal ok
        ok &= passed
        print(f"{'PASS' if passed else 'FAIL'} {name}: {detail}")

    base = replace(draw_scene(7), altitude_m=4.0, glinty=False, drift=(0.7, -0.2),
                   current=(-0.3, 0.5))
    # (1) one wave of grid bin (50, -25) (crop bin (20, -10)); the static background removed
    kx, ky = wavenumbers(base)
    iy, ix, amp = -25 % GRID, 50, np.zeros((GRID, GRID), complex)
    k_px = np.array([kx[iy, ix], ky[iy, ix]]) * base.gsd
    amp[iy, ix] = 0.02 * base.gsd / math.hypot(*k_px)  # slope amplitude 0.02
    lum = radiance(base, *slope_frames(base, amp, FRAMES))
    lum -= radiance(base, *slope_frames(base, 0 * amp, FRAMES))
    phase = np.angle(np.fft.fft2(lum)[:, -10 % SIZE, 20])
    step = np.angle(np.exp(1j * np.diff(phase)))
    u_px = np.array(base.over_water) / (base.gsd * FPS)
    w = float(omega(np.hypot(kx[iy, ix], ky[iy, ix])))
    want = float(np.angle(np.exp(1j * (k_px @ u_px - w / FPS))))
    err = float(np.max(np.abs(np.angle(np.exp(1j * (step - want))))))
    report("phase step of one wave", err < 1e-3,
           f"want k.u - omega/fps = {want:+.6f} rad/frame, max error {err:.1e}")
    # (2) current = drift: the pattern does not move; the drift alone moves it
    sea = random_amplitudes(base, np.random.default_rng(3))
    still = slope_frames(replace(base, drift=(0.0, 0.0), current=(0.0, 0.0)), sea, 10)[0]
    d_same, d_moved = (float(np.max(np.abs(slope_frames(sc, sea, 10)[0] - still)) / np.std(still))
                       for sc in (replace(base, current=base.drift),
                                  replace(base, current=(0.0, 0.0))))
    report("advection vanishes when current = drift", d_same < 1e-9 and d_moved > 0.1,
           f"max |diff| / std {d_same:.1e} (drift alone: {d_moved:.2f})")
    # (3) mean slope variance of the frames against the spectrum's integral: over the grid's
    # cells (the exact expectation; 8 seas x 8 draws, the lowest cells carry much of it) and
    # over the band they cover, ``int k^2 S(k) dk`` (the discretisation)
    got, grid_over_band = [], []
    for seed in range(8):
        sc = draw_scene(100 + seed)
        kx, ky = wavenumbers(sc)
        dk, kp = 2 * math.pi / (GRID * sc.gsd), 0.731 * G / sc.u10**2
        want = float(np.sum((kx**2 + ky**2) * sea_spectrum(sc, kx, ky)
                            * (np.hypot(kx, ky) <= math.pi / sc.gsd)) * dk**2)
        k = np.exp(np.linspace(math.log(dk / math.sqrt(math.pi)), math.log(math.pi / sc.gsd),
                               20001))
        band = k**3 * (omni_spectrum(k, kp, sc.gamma) + sc.counter_share
                       * omni_spectrum(k, kp * sc.counter_kp_ratio, sc.gamma))
        grid_over_band.append(want / float(np.trapezoid(band, np.log(k))))
        for draw in range(8):
            sx, sy = slope_frames(sc, random_amplitudes(sc, np.random.default_rng((seed, draw))),
                                  1)
            got.append(float(np.mean(sx**2 + sy**2)) / want)
    r, lo, hi = float(np.mean(got)), min(grid_over_band), max(grid_over_band)
    report("slope variance / spectrum integral", abs(r - 1) < 0.03 and 0.97 < lo <= hi < 1.03,
           f"frames / grid sum {r:.4f} (64 draws); grid sum / int k^2 S dk {lo:.3f}-{hi:.3f}")
    # (4) the altimeter's velocity convention: exact fits at 5 m with u, -u, swapped axes
    errs: dict[str, list[float]] = {"u": [], "-u": [], "swap": []}
    for seed in (11, 12, 13):
        sc = replace(draw_scene(seed), altitude_m=5.0, glinty=False, jpeg_quality=None,
                     drift=(0.8, 0.3), current=(-0.2, 0.5))
        frames, (ux, uy) = render_clip(sc, 10)[0], sc.over_water
        for name, v in (("u", (ux, uy)), ("-u", (-ux, -uy)), ("swap", (uy, ux))):
            est = _altimeter().estimate(frames, fps=FPS, focal_px=sc.focal_px, velocity_mps=v)
            errs[name].append(round(100 * (est.altitude_m / 5.0 - 1), 1))
    right = max(abs(e) for e in errs["u"])
    wrong = min(abs(e) for e in errs["-u"] + errs["swap"])
    report("velocity_mps = drift - current (x columns, y rows)", right < 5 and wrong > 20,
           f"exact-mode errors %: {errs}")
    # (5) the tilted camera's rays: untilted they sample the nadir crop itself; tilted by
    # 12 deg toward +y, the optical axis meets the sea H tan(12 deg) along +y
    col, row, *view = camera_rays(base)
    sx, sy = slope_frames(base, sea, 2)
    ray_sx, ray_sy = slope_frames(base, sea, 2, (col, row))
    same = float(max(np.max(np.abs(sx - ray_sx)), np.max(np.abs(sy - ray_sy))))
    tilted = replace(base, tilt_deg=12.0, tilt_toward=math.pi / 2)
    col, row, *_ = camera_rays(tilted)
    mid = (GRID - 1) / 2
    axis = [float(np.mean(a[SIZE // 2 - 1:SIZE // 2 + 1, SIZE // 2 - 1:SIZE // 2 + 1]))
            for a in (col, row)]
    reach = (axis[1] - mid) * tilted.gsd / (tilted.altitude_m * math.tan(math.radians(12)))
    report("tilted camera rays", same == 0.0 and abs(reach - 1) < 1e-3
           and abs(axis[0] - mid) < 1e-9,
           f"level rays vs crop {same:.1e}; axis reaches {reach:.5f} x H tan(tilt)")
    # (6) the CIE clear sky: 1 at the zenith; in the sun's vertical 3 deg from the sun
    # brighter than 90 deg away; with the sun overhead, a ray 80 deg from the zenith at
    # f(80 deg) phi(80 deg) / (f(0) phi(0)), the gradation phi(80 deg) / phi(0) = 3.07 (ISO
    # 15469 type 12: phi(Z) = 1 - exp(-0.32 / cos Z))
    cie = replace(base, sky="cie", sun_zenith_deg=40.0, sun_azimuth=0.0)

    def ray(zen_deg: float, az: float) -> tuple[np.ndarray, ...]:
        z = math.radians(zen_deg)
        return tuple(np.array([v]) for v in (math.sin(z) * math.cos(az),
                                             math.sin(z) * math.sin(az), math.cos(z)))

    zenith = float(sky_radiance(cie, *ray(0.0, 0.0))[0])
    near, far = (float(sky_radiance(cie, *ray(zen, 0.0))[0]) for zen in (43.0, -50.0))
    z80 = math.radians(80.0)
    phi = (1 - math.exp(-0.32 / math.cos(z80))) / (1 - math.exp(-0.32))
    f80, f0 = (1 + 10 * (math.exp(-3 * chi) - math.exp(-3 * math.pi / 2))
               + 0.45 * math.cos(chi) ** 2 for chi in (z80, 0.0))
    low = float(sky_radiance(replace(cie, sun_zenith_deg=0.0), *ray(80.0, 1.0))[0])
    report("CIE clear sky", abs(zenith - 1) < 1e-12 and near > far
           and abs(low - phi * f80 / f0) < 1e-12,
           f"zenith {zenith:.3f}, 3 deg from the sun {near:.2f}, 90 deg from it {far:.2f}, "
           f"gradation at 80 deg {phi:.2f} x zenith")
    # (7) the camera effects: phases taken whole at the frame times give the stepped field;
    # a rolling shutter's row y is the radiance at y / SIZE of the readout (a row between
    # sub-frame renders to the interpolation's error); automatic exposure with a full
    # correction a frame and no jitter puts every frame's median at the exposure
    whole = [a[[0, 2, 1]] for a in slopes_at(base, sea, np.array([0.0, 2.0, 1.0]) / FPS)]
    stepped = slope_frames(base, sea, 3)
    phase_err = max(float(np.max(np.abs(a - b))) for a, b in zip(whole, stepped))
    rolling = replace(base, readout_s=0.03)
    lum = exposed_radiance(rolling, sea, 2)
    y = 201  # read 23.6 ms after row 0, between two sub-frame renders
    direct = radiance(rolling, *slopes_at(rolling, sea, np.array([1 / FPS + y / SIZE * 0.03])))
    row_err = float(np.max(np.abs(lum[1, y] - direct[0, y])) / np.std(direct[0]))
    auto = replace(base, ae_rate=1.0, ae_jitter=0.0)
    ramp = radiance(base, *slope_frames(base, sea, 3)) * np.array([1.0, 1.5, 0.7])[:, None, None]
    medians = np.median((ramp * exposure_gains(auto, ramp)[:, None, None]).reshape(3, -1), axis=1)
    report("camera effects", phase_err < 1e-9 and row_err < 0.01
           and float(np.max(np.abs(medians / base.exposure**2.2 - 1))) < 1e-12,
           f"whole vs stepped phases {phase_err:.1e}; rolling-shutter row vs direct "
           f"{row_err:.4f} of the texture; auto-exposed medians {medians.round(4).tolist()}")
    # (8) the cumulus deck: over a wide stretch of the sky (60 x 60 of the base's height) it
    # covers the share drawn, to within the sampling of its 24 waves; its radiance lies
    # between the blue sky's and the clouds'; a scene under it is the one drawn without it
    cloudy = replace(base, sky="clouds")
    drawn = cloud_deck(cloudy)["cover"]
    u = np.linspace(-30.0, 30.0, 600)
    uu, vv = np.meshgrid(u, u)
    rays = np.stack([uu, vv, np.ones_like(uu)]) / np.sqrt(1 + uu**2 + vv**2)
    cover, bright = cloud_cover(cloudy, *rays)
    lum, blue = sky_radiance(cloudy, *rays), sky_radiance(base, *rays)
    between = bool(np.all(lum >= np.minimum(blue, bright) - 1e-12)
                   and np.all(lum <= np.maximum(blue, bright) + 1e-12))
    same = draw_scene(1, sky="clouds") == replace(draw_scene(1), sky="clouds")
    report("cumulus deck", abs(float(np.mean(cover > 0.5)) - drawn) < 0.05 and between
           and same, f"covers {float(np.mean(cover > 0.5)):.3f} of the sky, drawn "
           f"{drawn:.3f}; clouds {bright:.2f} x the zenith")
    # (9) a lens that distorts: OpenCV's own forward model (``cv2.projectPoints``) takes
    # each pixel's ray back to the pixel, for barrel and pincushion; a pinhole's rays are
    # the pixels' slopes
    import cv2

    lens_err = 0.0
    for k1 in (-MAX_LENS_K1, 0.05):
        lens = replace(base, lens_k1=k1)
        sx, sy = pixel_slopes(lens)
        rays = np.stack([sx.ravel(), sy.ravel(), np.ones(sx.size)], 1)
        calib = lens_calibration(lens)
        px = cv2.projectPoints(rays, np.zeros(3), np.zeros(3), calib.camera_matrix,
                               calib.dist_coeffs)[0].reshape(SIZE, SIZE, 2)
        cols, rows = np.meshgrid(np.arange(SIZE), np.arange(SIZE))
        lens_err = max(lens_err, float(np.max(np.hypot(px[..., 0] - cols, px[..., 1] - rows))))
    pin = pixel_slopes(base)[0][0] * base.focal_px + (SIZE - 1) / 2
    report("lens distortion", lens_err < 1e-6 and float(np.max(np.abs(pin - np.arange(SIZE))))
           < 1e-9, f"pixel rays projected back by OpenCV: {lens_err:.1e} px at most")
    # (10) the Lagrangian sea: one wave ``A cos(k x0)`` of steepness 0.3 along x, its water
    # on Gerstner's orbits (choppy 1), against the curve ``x = x0 - A sin(k x0)``, whose
    # slope is ``-A k sin / (1 - A k cos)`` (its steepest 1 / sqrt(1 - 0.3^2) = 1.048 times the
    # linear wave's); the Lagrangian path with no orbit (choppy 0, called past the guard
    # that keeps the linear path) samples the linear sea itself, to rounding
    one = np.zeros((GRID, GRID), complex)
    k_one = float(wavenumbers(base)[0][0, 10])
    one[0, 10] = 0.3 / k_one
    lin = slope_frames(base, one.copy(), 1)[0][0]
    sea_spec = sum(_slope_spectra(base, sea)[:2])
    same = float(np.max(np.abs(_lagrangian(sea_spec, None, replace(base, choppy=0.0))
                               - _synthesise(sea_spec, None))))
    gx = slope_frames(replace(base, choppy=1.0), one.copy(), 1)[0][0]
    theta = np.linspace(-math.pi, math.pi, 20001)
    x_of = theta / k_one - 0.3 / k_one * np.sin(theta)
    curve = -0.3 * np.sin(theta) / (1 - 0.3 * np.cos(theta))
    cols = ((GRID - SIZE) // 2 + np.arange(SIZE)) * base.gsd
    wrapped = np.mod(cols + math.pi / k_one, 2 * math.pi / k_one) - math.pi / k_one
    want = np.interp(wrapped, x_of, curve)
    gerstner = float(np.max(np.abs(gx[SIZE // 2] - want)))
    report("Lagrangian (Gerstner) sea", same < 1e-12 and gerstner < 0.003
           and float(np.max(gx)) > 1.04 * float(np.max(lin)),
           f"one wave of steepness 0.3: slope off the curve by {gerstner:.1e} at most; its "
           f"steepest slope {float(np.max(gx)):.3f} against the linear sea's "
           f"{float(np.max(lin)):.3f}; no orbit against the linear sea {same:.1e}")
    t0 = time.perf_counter()
    render_clip(draw_scene(1))
    print(f"INFO render of a 30-frame clip: {time.perf_counter() - t0:.2f} s")
    t0 = time.perf_counter()
    render_clip(draw_scene(1, camera=CAMERA_EFFECTS))
    print(f"INFO with every camera effect: {time.perf_counter() - t0:.2f} s")
    return ok


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--clips", type=int, default=40)
    ap.add_argument("--seed", type=int, default=1000)
    ap.add_argument("--out", type=Path, help="JSON with the summary and every window's record")
    ap.add_argument("--rows", default=",".join(ROWS), help=f"comma list of {', '.join(ROWS)}")
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--prior-sigma", type=float, default=PRIOR_SIGMA_MPS,
                    help="the prior row's velocity sigma, m/s")
    ap.add_argument("--max-current", type=float, default=1.0,
                    help="the water current's top speed, m/s (the prior's error)")
    ap.add_argument("--max-tilt-deg", type=float, default=0.0,
                    help="tilt the camera by up to this many degrees from nadir (even over "
                         "the disc), toward a random direction; the altimeter is not told")
    ap.add_argument("--sky", choices=SKIES, default="gradient",
                    help="the sky's radiance: a level, a horizon brightening and a slight "
                         "gradient, or the CIE clear sky (type 12) around the clip's sun")
    ap.add_argument("--camera", default="",
                    help=f"comma list of camera effects ({', '.join(CAMERA_EFFECTS)}): a "
                         "rolling shutter, motion blur, automatic exposure; default none")
    ap.add_argument("--tell-readout", action="store_true",
                    help="give the altimeter the rolling shutter's readout time (readout_s)")
    ap.add_argument("--size", type=int, default=SIZE,
                    help="frame side, px, over the same field of view (default 256)")
    ap.add_argument("--aspect", metavar="W:H",
                    help="crop each frame's middle to this width : height, the longer side "
                         "kept (16:9 of 512 px: 512 x 288; a video camera's frame, its focal "
                         "length quoted across its width); default square")
    ap.add_argument("--fps", type=float, default=FPS,
                    help="frames per second of the clips (default 30); a row keeps its frame "
                         "count, so blind30 lasts 30 / FPS s")
    ap.add_argument("--working-px", type=int, default=None,
                    help="the altimeter's working scale (DispersionAltimeter(working_px=); "
                         "0: frames as they are; default: the altimeter's)")
    ap.add_argument("--depth-m", default=None, metavar="D|LO,HI",
                    help="water of finite depth, m: one depth for every clip, or each clip's "
                         "drawn log-uniform over LO-HI; default deep water")
    ap.add_argument("--one-way", action="store_true",
                    help="a young sea running one way: no counter-running sea, and a narrow "
                         "spread (cos^2s with s drawn in 15-40 instead of 2-10)")
    ap.add_argument("--tell-depth", action="store_true",
                    help="give the altimeter the water's depth (water_depth_m)")
    ap.add_argument("--h264-crf", type=int, default=None,
                    help="code each clip as H.264 video (libx264, its default preset) at this "
                         "constant rate factor, 0-51, instead of 8-bit frames or JPEG stills")
    ap.add_argument("--attitude-sigma-deg", type=float, default=None, metavar="S",
                    help="tell the altimeter that the camera looks straight down within S "
                         "degrees a side, one sigma (a gimbal's prior of the tilt it "
                         "measures; draw tilts to match with --max-tilt-deg 2S); default: not "
                         "told")
    ap.add_argument("--lens-k1", type=float, default=0.0, metavar="K",
                    help="the camera's lens distorts radially by OpenCV's k1 = K (-0.12 to "
                         "0.12; negative: barrel), not told to the altimeter")
    ap.add_argument("--tell-calibration", action="store_true",
                    help="with --lens-k1: the frames turned to a pinhole's view by the "
                         "lens's calibration first, as --calibration does")
    ap.add_argument("--choppy", type=float, default=0.0, metavar="L",
                    help="a sea whose water moves on its orbits (first-order Lagrangian: "
                         "each surface point carried sideways by L times the linear field's "
                         "displacement; 1: the Gerstner sea, crests sharp and troughs broad; "
                         f"0-{MAX_CHOPPY:g}); default 0, the linear sea")
    ap.add_argument("--supersample", type=int, default=1, metavar="N",
                    help="each pixel the mean of N x N radiance samples (a pixel integrates "
                         "the light over its area; 1: one sample at its centre, the default)")
    ap.add_argument("--figure", type=Path, default=None, metavar="PNG",
                    help="also draw each row's windows here: estimate against truth, and the "
                         "share within k stated sigmas against k")
    ap.add_argument("--redraw", type=Path, default=None, metavar="JSON",
                    help="with --figure: draw the windows of a run's --out JSON (or its .gz) "
                         "instead of running")
    ap.add_argument("--save-clips", metavar="DIR", help="write each clip (.npy) and its truth")
    ap.add_argument("--self-check", action="store_true", help="check the generator and exit")
    a = ap.parse_args()
    if a.redraw is not None:
        if a.figure is None:
            ap.error("--redraw needs --figure (the PNG to draw)")
        from plot_conditions import load_run  # a run's records, its .gz too

        try:
            print(draw_windows(load_run(a.redraw), a.figure))
        except (ValueError, KeyError, TypeError) as exc:  # records without a window's fields
            ap.error(f"--redraw: {exc}")
        return 0
    if not 5.0 <= a.fps <= 240.0:
        ap.error(f"--fps must be within 5-240; got {a.fps:g}")
    if a.self_check:
        set_size(SIZE, None, a.fps)
        return 0 if self_check() else 1
    rows = tuple(r.strip() for r in a.rows.split(",") if r.strip())
    if set(rows) - set(ROWS):
        ap.error(f"unknown rows: {', '.join(sorted(set(rows) - set(ROWS)))}")
    camera = tuple(e.strip() for e in a.camera.split(",") if e.strip())
    if set(camera) - set(CAMERA_EFFECTS):
        unknown = ", ".join(sorted(set(camera) - set(CAMERA_EFFECTS)))
        ap.error(f"unknown camera effects: {unknown} (known: {', '.join(CAMERA_EFFECTS)})")
    if not 64 <= a.size <= 2048:
        ap.error(f"--size must be within 64-2048 px; got {a.size}")
    if a.working_px is not None and a.working_px < 0:
        ap.error(f"--working-px must be >= 0; got {a.working_px}")
    if a.h264_crf is not None and not 0 <= a.h264_crf <= 51:
        ap.error(f"--h264-crf must be within 0-51; got {a.h264_crf}")
    depth = None
    if a.depth_m is not None:
        try:
            vals = [float(v) for v in a.depth_m.split(",")]
        except ValueError:
            vals = []
        if (len(vals) not in (1, 2) or not all(math.isfinite(v) and v > 0 for v in vals)
                or vals[0] > vals[-1]):
            ap.error(f"--depth-m must be D or LO,HI with 0 < LO <= HI, m; got {a.depth_m!r}")
        depth = (vals[0], vals[-1])
    if a.tell_depth and depth is None:
        ap.error("--tell-depth needs --depth-m")
    if a.attitude_sigma_deg is not None:
        from wavealt.altimetry.dispersion.levelling import check_attitude_sigma

        try:
            check_attitude_sigma("--attitude-sigma-deg", a.attitude_sigma_deg)
        except ValueError as exc:
            ap.error(str(exc))
    if not 1 <= a.supersample <= 4 or not 64 <= a.size * a.supersample <= 2048:
        ap.error(f"--supersample must be within 1-4, and --size times it within 64-2048 px; "
                 f"got {a.supersample} and {a.size}")
    if not -MAX_LENS_K1 <= a.lens_k1 <= MAX_LENS_K1:
        ap.error(f"--lens-k1 must be within +-{MAX_LENS_K1:g}; got {a.lens_k1:g}")
    if a.tell_calibration and a.lens_k1 == 0.0:
        ap.error("--tell-calibration needs --lens-k1")
    if not 0.0 <= a.choppy <= MAX_CHOPPY:
        ap.error(f"--choppy must be within 0-{MAX_CHOPPY:g}; got {a.choppy:g}")
    try:
        aspect = None if a.aspect is None else parse_aspect(a.aspect)
    except ValueError as exc:
        ap.error(str(exc))
    set_size(a.size, a.working_px, a.fps, a.h264_crf, a.attitude_sigma_deg, a.supersample,
             a.lens_k1, a.tell_calibration, a.choppy)
    if a.save_clips:
        Path(a.save_clips).mkdir(parents=True, exist_ok=True)
    seeds = range(a.seed, a.seed + a.clips)
    if not 0.0 <= a.max_tilt_deg <= 30.0:
        ap.error(f"--max-tilt-deg must be within 0-30; got {a.max_tilt_deg:g}")
    job = partial(evaluate_clip, rows=rows, save_dir=a.save_clips, prior_sigma=a.prior_sigma,
                  max_current=a.max_current, max_tilt_deg=a.max_tilt_deg, sky=a.sky,
                  camera=camera, tell_readout=a.tell_readout, depth_m=depth,
                  tell_depth=a.tell_depth, one_way=a.one_way, aspect=aspect)
    t0, records = time.perf_counter(), list[dict]()
    pool_of = partial(Pool, a.workers, initializer=set_size, initargs=(a.size, a.working_px, a.fps,
                                                                     a.h264_crf,
                                                                     a.attitude_sigma_deg,
                                                                     a.supersample,
                                                                     a.lens_k1,
                                                                     a.tell_calibration,
                                                                     a.choppy))
    with pool_of() if a.workers > 1 else nullcontext() as pool:
        results = pool.imap_unordered(job, seeds) if pool else map(job, seeds)
        for recs in tqdm(results, total=len(seeds), desc="clips", file=sys.stderr):
            records.extend(recs)
    records.sort(key=lambda r: (r["seed"], list(ROWS).index(r["row"]), r["start"]))
    glinty = {r["seed"] for r in records if r["glinty"]}
    summary = {"benchmark": "bench_foreign_sea", "clips": a.clips, "seed": a.seed,
               "rows": list(rows), "glinty_clips": len(glinty),
               "prior_sigma_mps": a.prior_sigma, "max_current_mps": a.max_current,
               "max_tilt_deg": a.max_tilt_deg, "sky": a.sky, "camera": list(camera),
               "tell_readout": a.tell_readout, "depth_m": a.depth_m,
               "tell_depth": a.tell_depth, "one_way": a.one_way, "size": a.size,
               "aspect": a.aspect,
               "supersample": a.supersample, "lens_k1": a.lens_k1,
               "tell_calibration": a.tell_calibration, "choppy": a.choppy,
               "working_px": a.working_px,
               "h264_crf": a.h264_crf, "attitude_sigma_deg": a.attitude_sigma_deg,
               "fps": a.fps,
               "seconds": round(time.perf_counter() - t0, 1),
               "metrics": summarize(records, rows)}
    report(summary, records, a.out)
    if a.figure is not None:
        draw_windows(records, a.figure)
    return 0


def draw_windows(records: list[dict], path: Path) -> Path:
    """:func:`wavealt.plots.figure_altimeter_windows` of a run's window ``records``, one
    line a row (its clips together)."""
    from wavealt.plots import figure_altimeter_windows, windows_by_row

    return figure_altimeter_windows(
        windows_by_row(records, ("altitude_m", "est", "std", "trusted"), tuple(ROWS)), path,
        title="Independent sea generator: estimates and their stated uncertainty")


def report(summary: dict[str, Any], records: list[dict], out: Path | None) -> None:
    """Print ``summary`` as one JSON object; with ``out``, write it there with every
    window's ``records`` (``--out``)."""
    if out:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps({**summary, "records": records}, indent=1))
    print(json.dumps(summary, indent=1))


if __name__ == "__main__":
    sys.exit(main())
