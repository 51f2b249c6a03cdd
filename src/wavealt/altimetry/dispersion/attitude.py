"""The camera's attitude from the image scales of its corner tiles.

A pinhole of focal length ``f`` px at height ``H`` above a level sea, its axes turned by a
rotation ``R`` from those of a level camera looking straight down (OpenCV's axes,
:func:`wavealt.camera.tilt_rotation`), sees along pixel ``(x, y)`` (from the principal
point) the ray ``d = R (x, y, f)``.  The central projection onto the sea plane magnifies
the pixel's area by ``H^2 f / d_z^3`` (the solid angle of a pixel is ``f / |d|^3``, the
sea's area per solid angle ``H^2 |d|^3 / d_z^3``), so the altitude that a dispersion fit
which assumes one scale reads on a patch around ``(x, y)`` is

    ``h(x, y) = H (f / d_z)^1.5,  d_z = a x + b y + c f``,

with ``(a, b, c)`` the third row of ``R``: the sea's normal in the camera's axes.  Of
:func:`~wavealt.camera.tilt_rotation`'s roll ``r`` and pitch ``p``,
``(a, b, c) = (cos p sin r, sin p, cos p cos r)``.  The corner tiles' altitudes (each with
its own uncertainty) therefore give ``log H`` and the tilt ``(a, b)`` by weighted least
squares; against the level model (``a = b = 0``) the fall of the chi-square is a test of
the tilt with two degrees of freedom.  The same geometry levels frames for a known attitude
(:class:`wavealt.camera.NadirView`); marine-radar and stereo practice take the attitude from
an inertial unit, which a camera alone lacks.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.special import gammainccinv

from wavealt.altimetry.dispersion.constants import (
    TILE_AGREEMENT_SIGMAS,
    TILE_INFORMATION_SD_SCALE,
    TILE_SCATTER_LEVEL,
)

#: Gauss-Newton steps of the tilted fit: from level, four tiles and tilts within 30
#: degrees converge to 1e-9 in three to five.
_STEPS = 12


@dataclass(frozen=True)
class TiltFit:
    """The corner tiles' tilted fit (:func:`fit_tilt`).

    Attributes
    ----------
    a, b : float
        The sea's normal along the camera's x and y axes (its z part ``sqrt(1 - a^2 - b^2)``).
    cov : (3, 3) array
        Covariance of ``(log H, a, b)``.
    chi2_level, chi2_tilt : float
        Weighted squared residuals of the level and of the tilted model.
    chi2_stretched : float
        The tilted model's, each tile's variance with the oblique view's stretch added
        (:func:`stretch_var_log`; :meth:`fits`).
    level_var_log : float
        Variance of the level model's ``log H`` (the tiles' weighted mean).
    tiles : int
        How many tiles were fitted.
    """

    a: float
    b: float
    cov: np.ndarray
    chi2_level: float
    chi2_tilt: float
    level_var_log: float
    tiles: int
    chi2_stretched: float

    @property
    def roll_pitch_deg(self) -> tuple[float, float]:
        """Roll and pitch, degrees, of :func:`~wavealt.camera.tilt_rotation`'s convention."""
        c = math.sqrt(max(1.0 - self.a**2 - self.b**2, 0.0))
        return math.degrees(math.atan2(self.a, c)), math.degrees(math.asin(self.b))

    @property
    def tilt_deg(self) -> float:
        """Angle between the optical axis and the vertical, degrees."""
        return math.degrees(math.asin(min(math.hypot(self.a, self.b), 1.0)))

    def significant(self, level: float) -> bool:
        """Whether the tilt is significant at test level ``level``: the chi-square's fall
        from the level model exceeds its 2-degree-of-freedom quantile (the tiles' noise
        alone exceeds it with probability ``level``)."""
        return self.chi2_level - self.chi2_tilt > chi2_quantile(2, level)

    def fits(self, level: float) -> bool:
        """Whether the tilted model fits the tiles at test level ``level``: its chi-square
        within the quantile of its ``tiles - 3`` degrees of freedom (three tiles, which it
        fits exactly, always), each tile's variance its noise's and the part of the oblique
        view's stretch the model does not hold (:func:`stretch_var_log`; at 15 degrees as
        large as a tile's noise, so that without it a tilted camera's tiles fail the
        test).  Tiles that read a tilt's scales fit it within their noise;
        one tile's wrong peak does not, and the tilt it pulls from the others is no tilt
        of the camera: a nearly level camera then shows a large, significant tilt that the
        tilted model fits with a large chi-square (``docs/dispersion.md``, twenty-ninth
        session)."""
        dof = self.tiles - 3
        return dof <= 0 or self.chi2_stretched <= chi2_quantile(dof, level)

    def extra_var_log(self) -> float:
        """Variance that leaving the tilt free adds to the tiles' ``log H``: the tilted
        model's variance beyond the level model's (zero for tiles placed symmetrically and
        weighted alike, whose mean is unmoved by a tilt to first order)."""
        return max(float(self.cov[0, 0]) - self.level_var_log, 0.0)

    def tilt_var_rad(self) -> float:
        """Variance of the tilt angle, rad^2, along the direction of the tilt (both axes
        summed where the tilt is nil)."""
        s = math.hypot(self.a, self.b)
        c = self.cov[1:, 1:]
        if s < 1e-9:
            return float(np.trace(c))
        u = np.array([self.a, self.b]) / s
        return float(u @ c @ u) / max(1.0 - s * s, 1e-9)


def chi2_quantile(dof: int, level: float) -> float:
    """The value a chi-square variable of ``dof`` degrees of freedom exceeds with probability
    ``level`` (the regularised upper incomplete gamma function's inverse)."""
    return 2.0 * float(gammainccinv(0.5 * dof, level))


def cochran_q(fits: list[tuple[float, float]]) -> tuple[float, float, np.ndarray]:
    """Cochran's ``Q = sum w (x - xbar)^2`` of estimates ``fits`` (each ``(value, sd)``,
    ``w = 1 / sd^2``), their weighted mean ``xbar`` and the weights ``w``: ``Q`` is
    chi-square with ``len(fits) - 1`` degrees of freedom where the estimates share one
    value."""
    x = np.array([a for a, _ in fits], dtype=np.float64)
    w = 1.0 / np.maximum(np.array([s for _, s in fits], dtype=np.float64), 1e-6) ** 2
    mean = float(np.sum(w * x)) / float(w.sum())
    return float(np.sum(w * (x - mean) ** 2)), mean, w


def without_odd_tile(fits: list[tuple[float, float, float, float]], focal_px: float,
                     level: float) -> list[tuple[float, float, float, float]]:
    """Tiles ``fits`` (as for :func:`fit_tilt`) less the one whose altitude no camera
    attitude gives, where there is one: a tile whose fit found another peak than the
    shell (the optics' sum products, which read 0.5-0.9 of the altitude; a glint).

    Four tiles that scatter beyond their noise (Cochran's ``Q`` above its quantile at test
    level ``level``) and that the tilted model does not fit either (:meth:`TiltFit.fits`:
    one degree of freedom is left, the corners' twist, which no tilt makes) hold a tile off
    both models.  It is the one without which the other three read one scale (their ``Q``
    within its quantile), and which lies off their mean by more than
    ``TILE_AGREEMENT_SIGMAS``.  Three tiles at three corners read one scale only if the
    camera is level (any tilt parts them), so a tilt is never taken for a tile's wrong
    peak; a tilted camera's four tiles with one off are kept as they are.  The levelling
    measures a tilt without it
    (:meth:`~.levelling._Level._level`); the trust verdict keeps it, since an unseen turn
    of the camera also parts one tile from the others (``docs/dispersion.md``,
    thirty-fourth session)."""
    if len(fits) < 4:
        return fits
    logs = [(f[2], f[3]) for f in fits]
    if cochran_q(logs)[0] <= chi2_quantile(len(fits) - 1, level):
        return fits  # one scale within the noise
    tilted = fit_tilt(fits, focal_px)
    if tilted is not None and tilted.fits(level):
        return fits  # a tilt's scales
    rests = [cochran_q(logs[:j] + logs[j + 1:]) for j in range(len(logs))]
    i = min(range(len(logs)), key=lambda j: rests[j][0])
    q_rest, mean, w = rests[i]
    off = abs(logs[i][0] - mean) / math.hypot(logs[i][1], 1.0 / math.sqrt(float(w.sum())))
    if q_rest > chi2_quantile(len(fits) - 2, level) or off <= TILE_AGREEMENT_SIGMAS:
        return fits
    return fits[:i] + fits[i + 1:]


def tile_centres(shape: tuple[int, int], tile: tuple[int, int]) -> list[tuple[float, float]]:
    """Centres ``(x, y)``, px from the frame's centre, of the four corner tiles ``tile``
    ``(h, w)`` of a frame ``shape`` ``(H, W)``, in :func:`~.spectra._corners`'s order
    (top left, top right, bottom left, bottom right)."""
    (hh, ww), (th, tw) = shape, tile
    x = (tw - ww) / 2.0
    y = (th - hh) / 2.0
    return [(x, y), (-x, y), (x, -y), (-x, -y)]


def informative(fits: list[tuple[float, float, float, float]]
                ) -> list[tuple[float, float, float, float]]:
    """The tiles ``fits`` (``(x, y, log h, sd_log)``) with each sigma scaled to the
    information about a tilt that their heavy-tailed errors carry
    (``TILE_INFORMATION_SD_SCALE``, which says how it was measured)."""
    return [(x, y, lg, sd * TILE_INFORMATION_SD_SCALE) for x, y, lg, sd in fits]


def unmeasured_tilt_var_log(fits: list[tuple[float, float, float, float]], focal_px: float,
                            prior_sd: float,
                            centres: list[tuple[float, float]] | tuple = ()) -> float:
    """Variance of ``log H`` that a tilt the tiles ``fits`` do not measure adds to a fit read
    where they hold the waves; each tile ``(x, y, log h, sd_log)`` as for :func:`fit_tilt`,
    ``prior_sd`` the prior standard deviation of each of the normal's parts ``a`` and ``b``
    (the sine of a tilt about each axis).

    To first order in the tilt, a tile at ``(x, y)`` reads ``log h = log H - 1.5 (a x + b y)
    / f``.  The fit reads about where its evidence lies, the tiles' weighted centroid ``g``
    (weights ``w = 1 / sd^2``), so it misses ``log H`` by ``1.5 (a, b) . g / f``.  The tiles'
    differences from one another measure the tilt with the information ``M = 2.25 sum w
    (p - g)(p - g)^T / f^2`` (``p`` a tile's place); along an eigenvector of ``M`` whose
    eigenvalue exceeds the prior's ``1 / s^2`` the tiles measure the tilt better than the
    prior knows it (:func:`fit_tilt`, :meth:`TiltFit.significant` and the levelling act on
    it), along the others the prior stands.  The variance is ``2.25 s^2 |P g|^2 / f^2``,
    ``P`` the projection onto those unmeasured directions: the whole centroid for one
    tile, its part across the line through two, nothing for three or four precise corner
    tiles (never collinear); a tile too imprecise to tell a tilt within the prior measures
    nothing.  Where no tile holds the waves alone, nothing measures the tilt, nor says
    where in the frame the fit reads: it is taken to read at the farthest of the tiles'
    ``centres``, as one tile there (nothing without them).  The tiles' sigma is taken at
    the information of their errors' distribution (:func:`informative`).
    """
    if not fits:
        r2 = max((x * x + y * y for x, y in centres), default=0.0)
        return 2.25 * prior_sd**2 * r2 / focal_px**2
    info, centre = _tilt_information(informative(fits), focal_px)
    value, vec = np.linalg.eigh(info)
    free = vec[:, value * prior_sd**2 < 1.0]
    part = free.T @ centre
    return 2.25 * prior_sd**2 * float(part @ part)


def unlevelled_tilt_var_log(fits: list[tuple[float, float, float, float]], focal_px: float,
                            prior_sd: float, tile: tuple[int, int]) -> float | None:
    """Variance of ``log H`` that a tilt within what tiles ``fits`` (as for :func:`fit_tilt`,
    each ``tile`` ``(h, w)`` px) allow adds to a fit of frames that were not levelled; None
    for fewer than three tiles or no tilted fit (:func:`unmeasured_tilt_var_log` holds it).

    To first order in the tilt, a place ``(x, y)`` of the frame reads ``log H - 1.5 (a x +
    b y) / f`` (:func:`unmeasured_tilt_var_log`), and the fit reads about where its evidence
    lies: the tiles' weighted centroid ``g`` (weights ``1 / sd^2``), give or take where in
    each tile the waves show best, the same for all, spread evenly over a tile (second
    moment ``G = g g^T + diag(w^2, h^2) / 12 f^2``).  A tilted camera sees the sea on the
    side it looks toward at a steeper incidence, brighter and with more contrast (Fresnel's
    reflectance, a sky brighter toward the horizon), so where noise hides the waves on the
    other side every tile and the frame read the far side's scale while the tiles, too
    imprecise, show no tilt to level by.  The tilt is the tiles' tilted fit
    (:func:`fit_tilt`, a tile off both models set aside, :func:`without_odd_tile`) joined
    to the prior ``N(0, prior_sd^2)`` on each of ``a`` and ``b``: mean ``m``, covariance
    ``V``.  The variance is ``2.25 tr((m m^T + V) G)``; along a direction the tiles do not
    measure, ``V`` is the prior's and the centroid's part is
    :func:`unmeasured_tilt_var_log`'s.  The tiles' sigma is taken at the information of
    their errors' distribution (:func:`informative`).
    """
    kept = without_odd_tile(informative(fits), focal_px, TILE_SCATTER_LEVEL)
    tilt = fit_tilt(kept, focal_px)
    if tilt is None:
        return None
    info = np.linalg.inv(tilt.cov[1:, 1:])
    post = np.linalg.inv(info + np.eye(2) / prior_sd**2)
    mean = post @ info @ np.array([tilt.a, tilt.b])
    centre = _tilt_information(kept, focal_px)[1]
    th, tw = tile
    where = np.outer(centre, centre) + np.diag([tw * tw, th * th]) / (12.0 * focal_px**2)
    return 2.25 * float(np.trace((np.outer(mean, mean) + post) @ where))


def fit_tilt(fits: list[tuple[float, float, float, float]],
             focal_px: float) -> TiltFit | None:
    """The tilted fit of tiles ``fits``, each ``(x, y, log h, sd_log)`` (centre px from the
    principal point, its altitude's log and that log's sigma), for a camera of focal length
    ``focal_px``; None for fewer than three tiles (three unknowns) or a fit that leaves the
    range of tilts a camera can see the sea at (``|(a, b)| >= 0.9``)."""
    if len(fits) < 3:
        return None
    arr = np.asarray(fits, dtype=np.float64)
    x, y, obs = arr[:, 0] / focal_px, arr[:, 1] / focal_px, arr[:, 2]
    w = 1.0 / np.maximum(arr[:, 3], 1e-6) ** 2
    sw = float(w.sum())

    def residuals(a: float, b: float) -> tuple[float, np.ndarray, np.ndarray]:
        """``c``, ``d_z / f`` and the tiles' residuals from the model at the tilt ``(a, b)``
        with its best ``log H`` (the weighted mean of ``log h + 1.5 log(d_z / f)``)."""
        c = math.sqrt(1.0 - a * a - b * b)
        dz = a * x + b * y + c
        resid = obs - (-1.5 * np.log(dz))
        resid -= float(np.sum(w * resid)) / sw
        return c, dz, resid

    # level (a = b = 0): the residuals from the tiles' weighted mean
    chi2_level = float(np.sum(w * residuals(0.0, 0.0)[2] ** 2))
    a = b = 0.0
    normal = np.empty((3, 3))
    for _ in range(_STEPS):
        c, dz, resid = residuals(a, b)
        # d log h / d(log H, a, b): 1, -1.5 (x - a / c) / dz, -1.5 (y - b / c) / dz
        jac = np.stack([np.ones_like(x), -1.5 * (x - a / c) / dz, -1.5 * (y - b / c) / dz], 1)
        normal = jac.T @ (w[:, None] * jac)
        step = np.linalg.lstsq(normal, jac.T @ (w * resid), rcond=None)[0]
        a, b = a + float(step[1]), b + float(step[2])
        if math.hypot(a, b) >= 0.9:
            return None
        if abs(step[1]) + abs(step[2]) < 1e-10:
            break
    resid = residuals(a, b)[2]
    chi2_tilt = float(np.sum(w * resid**2))
    # the same residuals, each tile's variance with the stretch the model does not hold
    ws = 1.0 / (1.0 / w + stretch_var_log(x, y, a, b))
    resid -= float(np.sum(ws * resid)) / float(ws.sum())  # (centred on the w-weighted mean)
    chi2_stretched = float(np.sum(ws * resid**2))
    try:
        cov = np.linalg.inv(normal)
    except np.linalg.LinAlgError:
        return None
    return TiltFit(a, b, cov, chi2_level, chi2_tilt, 1.0 / sw, len(fits), chi2_stretched)


def stretch_var_log(x: np.ndarray, y: np.ndarray, a: float, b: float) -> np.ndarray:
    """Variance of the log altitude that a tile at ``(x, y)`` (over the focal length) of a
    camera whose sea normal is ``(a, b, c)`` reads beyond the model's ``-1.5 log(d_z / f)``.

    An oblique view stretches the sea: a small patch of it maps to the image with two
    principal scales (the singular values of the plane's projection, ``(I - r n^T / n.r)``
    on the image axes, ``r = (x, y, 1)``), equal only where the view is square to the sea.
    The model holds their geometric mean; a dispersion fit reads between them as the
    waves' directions fall, taken as spread evenly over the log of their ratio ``L``:
    ``L^2 / 12`` (15 degrees from nadir, corner tiles 0.35 f off the axes: ``L`` 0.10-0.17;
    level: zero)."""
    n = np.array([a, b, math.sqrt(max(1.0 - a * a - b * b, 0.0))])
    r = np.stack([x, y, np.ones_like(x)], -1)[..., :, None]  # (..., 3, 1)
    proj = np.eye(3) - r * n / (r * n[:, None]).sum(-2, keepdims=True)
    sv = np.linalg.svd(proj[..., :2], compute_uv=False)
    return np.log(sv[..., 0] / sv[..., 1]) ** 2 / 12.0


def measures_tilt(fits: list[tuple[float, float, float, float]], focal_px: float,
                  prior_sd: float, direction: tuple[float, float]) -> bool:
    """Whether tiles ``fits`` (as for :func:`fit_tilt`) measure a tilt along ``direction``
    (the normal's ``(a, b)`` parts; its sense and size do not matter) better than the prior
    ``prior_sd`` knows it: the information ``2.25 sum w (u . (p - g))^2 / f^2`` along its
    unit vector ``u`` exceeds ``1 / prior_sd^2`` (the criterion of
    :func:`unmeasured_tilt_var_log`).  Two tiles in one row do not measure a tilt about the
    frame's horizontal axis, however well they agree."""
    norm = math.hypot(*direction)
    if len(fits) < 2 or norm == 0.0:
        return False
    u = np.asarray(direction, dtype=np.float64) / norm
    return float(u @ _tilt_information(fits, focal_px)[0] @ u) * prior_sd**2 >= 1.0


def _tilt_information(fits: list[tuple[float, float, float, float]], focal_px: float
                      ) -> tuple[np.ndarray, np.ndarray]:
    """The information ``M = 2.25 sum w (p - g)(p - g)^T / f^2`` ``(2, 2)`` that tiles
    ``fits`` (as for :func:`fit_tilt`; ``w = 1 / sd^2``) hold on a tilt's ``(a, b)``, and
    their weighted centroid ``g / f``."""
    arr = np.asarray(fits, dtype=np.float64)
    pos = arr[:, :2] / focal_px
    w = 1.0 / np.maximum(arr[:, 3], 1e-6) ** 2
    centre = w @ pos / float(w.sum())
    d = pos - centre
    return 2.25 * (d * w[:, None]).T @ d, centre


def roll_pitch(rot: np.ndarray) -> tuple[float, float]:
    """Roll and pitch, degrees, of :func:`wavealt.camera.tilt_rotation` whose sea normal
    (third row) is that of rotation ``rot``."""
    a, b, c = (float(v) for v in rot[2])
    return math.degrees(math.atan2(a, c)), math.degrees(math.asin(max(-1.0, min(b, 1.0))))
