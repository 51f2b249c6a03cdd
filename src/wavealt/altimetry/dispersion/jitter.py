"""A shaking camera's image jitter, from its corner tiles' mode series, and its removal.

A camera that rolls or pitches by a small angle ``a`` moves the whole image by about
``f a`` px (``f`` the focal length): half a degree is 2 px at a 60-degree view of 256 px.
Over a second a camera on a vehicle without a gimbal shakes by that much, back and forth,
and the sea's phase steps, which the fit reads as the waves' dispersion and the drift, are
no longer steady: half a degree of roll and pitch at 0.7-2 Hz throws a fit that takes
them as steady far off (``docs/dispersion.md``, twenty-fifth session).

The shake moves every spatial mode ``k`` of a tile by the same shift ``s_t``: its phase
steps are ``psi_k - k . (s_{t+1} - s_t)``, ``psi_k`` the mode's own steady step (the waves
and the drift).  Each mode's lag-one cross-spectrum ``C_k = sum_t X_{t+1} conj(X_t)`` gives
``psi_k`` (the steady part), and the angle of ``X_{t+1} conj(X_t) conj(C_k)`` is then
``-k . e_t``, ``e_t`` the step's departure from the clip's mean step: one Tukey-weighted
regression on ``k`` per frame pair (weights the pair's power times the mode's squared
coherence; the modes up to ``JITTER_MAX_KAPPA``, whose phases the shake does not wrap).
Summed, ``e`` gives the shake less its mean motion (a steady turn moves the image as a
drift does; the fit takes that in the velocity).  The four corner tiles measure it each on
their own modes; their mean is the estimate and their scatter its noise, so a shake is
removed only where the tiles agree on it (``JITTER_MIN_RATIO``).  Removal multiplies each
mode's series by ``exp(i k . s_t)``; the periodogram then moves the tiles themselves back
by the shake and windows them again, and reads what remains (:func:`steady_tiles`): taken
out of the windowed modes' phases alone, a shake leaves the window where it was while the
sea moves through it.  Marine-radar image sequences are registered for the platform's
motion the same way, by its common phase (Young, Rosenthal & Ziemer 1985, for a ship's
radar).  A camera whose heading also wavers turns the image about its centre, which
moves each tile along its own tangent: the four tiles' mean is untouched, but they agree on
it less; where the tiles show such a rotation above their noise it is read and removed with
the shift (:func:`remove_motion`).
"""

from __future__ import annotations

import contextvars
import math
from collections.abc import Callable

import numpy as np
import scipy.fft

from wavealt.altimetry.dispersion.constants import (
    JITTER_MAX_KAPPA,
    JITTER_MIN_TURNS,
    JITTER_MODES,
    JITTER_MIN_RATIO,
    JITTER_PASSES,
    JITTER_PIXEL_PASSES,
)

#: A signed multiple of one realisation of the tiles' shake-reading noise
#: (:func:`shake_noise`, on the series the shake is read on: the recorded values where the
#: normal scores are fitted), added to the first reading before the tiles are moved back
#: (:meth:`~.spectra._Spectra._share_table`): set while a trusted steadied fit is made again
#: to see how far its shake's own error moves it
#: (:meth:`~.turn._Turn._shake_uncertain`); 0 otherwise.
SHAKE_OFF: contextvars.ContextVar[float] = contextvars.ContextVar("wavealt_shake_off",
                                                                   default=0.0)
#: The signs of the four corner tiles (top left, top right, bottom left, bottom right) in
#: :func:`shake_noise`'s contrast: a shift they share and a rotation about the centre
#: (which moves opposite corners opposite ways) both cancel in it.
_NOISE_SIGNS = np.array([1.0, -1.0, -1.0, 1.0])

#: Tukey's biweight constant and the regression's reweighting steps.
_TUKEY = 4.685
_TUKEY_STEPS = 4


def _wrap(x: np.ndarray) -> np.ndarray:
    """``x`` to (-pi, pi] (a rounding, cheaper than a remainder)."""
    return x - np.float32(2.0 * np.pi) * np.round(x * np.float32(0.5 / np.pi))


def _phasor(phase: np.ndarray) -> np.ndarray:
    """``exp(i phase)`` in single precision (float32 sine and cosine, no complex128)."""
    phase = phase.astype(np.float32)
    out = np.empty(phase.shape, dtype=np.complex64)
    out.real = np.cos(phase)
    out.imag = np.sin(phase)
    return out


def tile_shake(series: np.ndarray, kx: np.ndarray, ky: np.ndarray) -> np.ndarray:
    """The image shift of every frame, ``(T, 2)`` px (x, y), of one tile's mean-free mode
    series ``series`` ``(T, modes)`` complex of wavenumbers ``kx, ky`` (rad/px), less its
    mean motion over the clip (no trend, mean zero); zeros where too few modes hold a
    steady phase step.  A frame's step is not measured (0) where its least-squares solve is
    singular, or longer than half the longest readable mode's wavelength, which the modes'
    phases cannot hold (a near-singular solve, the modes still weighted all pointing one
    way)."""
    return _shakes(series[None], kx, ky)[0]


def _shakes(series: np.ndarray, kx: np.ndarray, ky: np.ndarray) -> np.ndarray:
    """:func:`tile_shake` of each of the tiles ``series`` ``(tiles, T, modes)``, at once:
    ``(tiles, T, 2)``."""
    n, t = series.shape[:2]
    use = np.flatnonzero(np.hypot(kx, ky) <= JITTER_MAX_KAPPA)
    x = series[:, :, use].astype(np.complex64)
    if use.size > JITTER_MODES:  # the tiles' strongest modes carry the shift
        power = (x.real**2 + x.imag**2).sum(axis=(0, 1))
        keep = np.sort(np.argpartition(power, -JITTER_MODES)[-JITTER_MODES:])
        x, use = x[:, :, keep], use[keep]
    ax, ay = kx[use].astype(np.float32), ky[use].astype(np.float32)
    shift = np.zeros((n, t, 2))
    if t < 4 or ax.size < 8:
        return shift
    lag = x[:, 1:] * np.conj(x[:, :-1])  # (tiles, T-1, modes)
    c = lag.sum(axis=1, keepdims=True)
    power = np.abs(lag)
    coherence = np.abs(c) / np.maximum(power.sum(axis=1, keepdims=True), np.float32(1e-30))
    # The series are mean-free, and a steady phasor of step psi less its mean over the
    # clip steps unevenly: its mean, D(psi) / T of it (D Dirichlet's kernel), has a phase
    # fixed by psi alone, so every mode of that step leans the same way at the same frame,
    # in every tile.  Each mode's residual is taken against that of its own steady phasor,
    # made mean-free the same way; those that turn too little to read (within
    # ``JITTER_MIN_TURNS`` cycles of standing still) are left out.
    psi = np.angle(c)  # (tiles, 1, modes)
    model = _phasor(psi * np.arange(t, dtype=np.float32)[None, :, None])
    model -= model.mean(axis=1, keepdims=True)
    mlag = model[:, 1:] * np.conj(model[:, :-1])
    # -k . e_t, wrapped: each pair's step against its mode's steady step and its lean
    resid = np.angle(lag * np.conj(c) * np.conj(mlag * np.conj(mlag.sum(axis=1, keepdims=True))))
    kept = np.abs(psi) >= JITTER_MIN_TURNS * 2.0 * np.pi / t
    w0 = power * (coherence**2 * kept)
    e = np.zeros((n, t - 1, 2), dtype=np.float32)
    reach = math.pi / max(float(np.min(np.hypot(ax, ay))), 1e-6)  # px: the longest step read
    for step in range(_TUKEY_STEPS + 1):  # least squares, then reweighted (Tukey)
        ex, ey = e[..., :1], e[..., 1:]
        r = _wrap(resid + ax * ex + ay * ey)
        w = w0
        if step:
            # the residuals' scale: the median absolute residual of every other mode
            scale = (np.float32(1.4826) * np.median(np.abs(r[..., ::2]), axis=-1, keepdims=True)
                     + np.float32(1e-12))
            # Tukey's biweight, 0 from |u| = 1 on (clipped first: a scale near zero, where
            # most modes' residuals vanish, must not overflow the square)
            u = np.fmin(np.abs(r / (_TUKEY * scale)), np.float32(1.0))
            w = w0 * (1.0 - u * u) ** 2
        base = r - ax * ex - ay * ey  # resid, unwrapped near e
        wx, wy = w * ax, w * ay
        sxx, sxy, syy = ((wx * ax).sum(-1, dtype=np.float64), (wx * ay).sum(-1, dtype=np.float64),
                         (wy * ay).sum(-1, dtype=np.float64))
        bx, by = -(wx * base).sum(-1, dtype=np.float64), -(wy * base).sum(-1, dtype=np.float64)
        det = sxx * syy - sxy * sxy
        ok = det > 1e-12 * np.maximum(sxx * syy, 1e-300)
        safe = np.where(ok, det, 1.0)
        solved = np.stack([(syy * bx - sxy * by) / safe, (sxx * by - sxy * bx) / safe], -1)
        # a step longer than half the longest mode's wavelength is beyond what the phases
        # hold (a near-singular solve, where the few modes still weighted point one way)
        ok &= np.hypot(solved[..., 0], solved[..., 1]) <= reach
        e = np.where(ok[..., None], solved, 0.0).astype(np.float32)
    e = e.astype(np.float64)
    e -= e.mean(axis=1, keepdims=True)
    shift[:, 1:] = np.cumsum(e, axis=1)
    # no trend: the mean motion is the drift's (least-squares line over the frames)
    return detrend(shift)


def detrend(series: np.ndarray) -> np.ndarray:
    """``series`` ``(..., T, C)`` less its mean and its least-squares line over the T axis
    (a shake less its mean motion)."""
    t = series.shape[-2]
    frames = np.arange(t, dtype=np.float64) - (t - 1) / 2.0
    out = series - series.mean(axis=-2, keepdims=True)
    slope = (frames[:, None] * out).sum(axis=-2, keepdims=True) / max(np.sum(frames**2), 1e-30)
    return out - slope * frames[:, None]


def common_shake(series: np.ndarray, kx: np.ndarray, ky: np.ndarray
                 ) -> tuple[np.ndarray, float]:
    """The shake the tiles' mode series ``series`` ``(tiles, T, modes)`` share, ``(T, 2)``
    px (their mean, :func:`tile_shake`), and how far it stands above the tiles' own noise:
    its mean square over that of the mean's noise (the tiles' scatter about the mean over
    their number; about 1 where no shake is shared)."""
    return _common(_shakes(series, kx, ky))


def _common(shakes: np.ndarray) -> tuple[np.ndarray, float]:
    """:func:`common_shake` of the tiles' shifts ``shakes`` ``(tiles, T, 2)``."""
    n = shakes.shape[0]
    mean = shakes.mean(axis=0)
    if n < 2:
        return mean, 0.0
    noise = float(((shakes - mean) ** 2).sum() / (n - 1)) / n
    return mean, float((mean**2).sum()) / max(noise, 1e-30)


def remove_shake(series: np.ndarray, kx: np.ndarray, ky: np.ndarray,
                 min_ratio: float = JITTER_MIN_RATIO) -> tuple[np.ndarray, np.ndarray | None]:
    """The tiles' mode series ``series`` ``(tiles, T, modes)`` complex64 with the shake they
    share removed, mean-free again (a new array), and the shake removed ``(T, 2)`` px; the
    series themselves and None where the tiles share none (``min_ratio``).
    ``JITTER_PASSES`` passes, each on what the last left: a mode's steady step is read on
    the shaken series, and the first pass reads about nine tenths of the shake."""
    return _remove_shake(series, kx, ky, min_ratio)


def _remove_shake(series: np.ndarray, kx: np.ndarray, ky: np.ndarray, min_ratio: float,
                  first: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    """:func:`remove_shake`; ``first``: the first pass's tile shifts, already taken."""
    total = None
    out = series
    for k in range(JITTER_PASSES):
        shake, ratio = _common(first if k == 0 and first is not None
                               else _shakes(out, kx, ky))
        if not np.all(np.isfinite(shake)) or (total is None and not ratio >= min_ratio):
            break  # no shake the tiles agree on (later passes refine the one found)
        out = _unmove(out, kx, ky, shake)
        total = shake if total is None else total + shake
    return out, total


def _unmove(series: np.ndarray, kx: np.ndarray, ky: np.ndarray, shift: np.ndarray,
            theta: np.ndarray | None = None, perp: np.ndarray | None = None) -> np.ndarray:
    """Tiles' mode series ``series`` ``(tiles, T, modes)`` with a motion taken out, mean-free
    again (a new array): the image shift ``shift`` ``(T, 2)`` px they share, and where given
    a rotation ``theta`` ``(T,)`` rad about the centre, which moves tile ``i`` by
    ``theta perp[i]`` (:func:`_tangents`)."""
    moved = _tile_motion(shift, theta, perp)
    phase = kx[None, None, :] * moved[..., :1] + ky[None, None, :] * moved[..., 1:]
    out = series * _phasor(phase)
    out -= out.mean(axis=1, keepdims=True)
    return out


def _tile_motion(shift: np.ndarray, theta: np.ndarray | None,
                 perp: np.ndarray | None) -> np.ndarray:
    """Each tile's own motion, ``(tiles or 1, T, 2)`` px: the shift ``(T, 2)`` the tiles
    share and, where given, the rotation ``theta`` ``(T,)`` rad about the image centre,
    which moves tile ``i`` by ``theta perp[i]`` (:func:`_tangents`)."""
    if theta is None:
        return shift[None]
    return shift[None] + theta[None, :, None] * perp[:, None, :]


def move_back(parts: list[np.ndarray], moved: np.ndarray) -> list[np.ndarray]:
    """Each tile ``parts[i]`` ``(T, h, w)`` moved back frame by frame by its own motion
    ``moved[i]`` ``(T, 2)`` px (x, y), float32: a circular sub-pixel shift (the phase
    :func:`_unmove` gives a mode, on the unwindowed tile; the strip that wraps round is
    where a Hann window is near zero)."""
    t, h, w = parts[0].shape
    ky = (2.0 * np.pi * np.fft.fftfreq(h))[None, :, None]
    kx = (2.0 * np.pi * np.fft.rfftfreq(w))[None, None, :]
    out = []
    for part, m in zip(parts, moved):
        plane = scipy.fft.rfft2(part, workers=1)
        plane *= _phasor(kx * m[:, 0, None, None] + ky * m[:, 1, None, None])
        out.append(scipy.fft.irfft2(plane, s=(h, w), workers=1).astype(np.float32, copy=False))
    return out


def shake_noise(series: np.ndarray, kx: np.ndarray, ky: np.ndarray) -> np.ndarray:
    """One realisation of the noise of the shake the four corner tiles' mode series
    ``series`` ``(4, T, modes)`` share, ``(T, 2)`` px: their shifts (:func:`_shakes`) summed
    with the signs ``_NOISE_SIGNS``, a contrast that holds no shared shift and no rotation
    about the centre, only the tiles' own scatter, over their number (the variance of their
    mean) and times ``sqrt(n / (n - 1))``; zeros for another number of tiles."""
    shakes = _shakes(series, kx, ky)
    n = shakes.shape[0]
    if n != _NOISE_SIGNS.size:
        return np.zeros(shakes.shape[1:])
    return np.tensordot(_NOISE_SIGNS, shakes, axes=1) / n * math.sqrt(n / (n - 1))


def steady_tiles(parts: list[np.ndarray],
                 transform: Callable[[list[np.ndarray]], tuple[np.ndarray, np.ndarray]],
                 kx: np.ndarray, ky: np.ndarray, centres: np.ndarray, shift: np.ndarray,
                 theta: np.ndarray | None, passes: int = JITTER_PIXEL_PASSES
                 ) -> tuple[list[np.ndarray], np.ndarray, np.ndarray, np.ndarray,
                            np.ndarray | None]:
    """The tiles ``parts`` steadied of the motion :func:`remove_motion` found in their
    modes (``shift`` ``(T, 2)`` px, the rotation ``theta`` or None), by moving the tiles
    themselves back (:func:`move_back`) and transforming them again (``transform(parts)``:
    their mean-free mode series ``(tiles, T, modes)`` of wavenumbers ``kx, ky`` and their
    planes).  Taken out of a windowed tile's modes by their phase, a shake leaves the window
    where it was while the sea moves through it: every mode's amplitude then pulses with
    the shake, and the shift read on the modes is off by as much.  ``passes`` times, each
    but the last reading the motion that remains on the steadied tiles (a rotation only
    where one was found) and adding it.  Returns the steadied tiles, their series and
    planes, and the motion taken out."""
    centres = np.asarray(centres, dtype=np.float64)
    perp = _tangents(centres)
    for k in range(passes):
        motion = _tile_motion(shift, theta, perp)
        moved = move_back(parts, np.broadcast_to(motion, (len(parts), *motion.shape[1:])))
        series, planes = transform(moved)
        if k + 1 == passes:
            break
        shakes = _shakes(series, kx, ky)
        more, turn = (_common(shakes)[0], None) if theta is None else _rigid(shakes, centres)[:2]
        if not (np.all(np.isfinite(more)) and (turn is None or np.all(np.isfinite(turn)))):
            break
        shift = shift + more
        theta = None if theta is None else theta + turn
    return moved, series, planes, shift, theta


def _tangents(centres: np.ndarray) -> np.ndarray:
    """How tiles at ``centres`` ``(tiles, 2)`` px from the image centre move per radian of
    rotation about it, ``(-c_y, c_x)``, less their mean (zero for tiles placed
    symmetrically): ``(tiles, 2)``."""
    perp = np.stack([-centres[:, 1], centres[:, 0]], axis=-1)
    return perp - perp.mean(axis=0)


def _rigid(shakes: np.ndarray, centres: np.ndarray
           ) -> tuple[np.ndarray, np.ndarray, float, float]:
    """The tiles' shifts ``shakes`` ``(tiles, T, 2)`` as one rigid motion of the image about
    its centre: a shift ``(T, 2)`` they share and a small rotation ``(T,)`` rad (tile ``i``
    at ``centres[i]`` px from the centre moves by ``theta (-c_y, c_x)``), least squares per
    frame; how far the shift stands above what is left (its mean square over that of its
    noise, as :func:`common_shake`'s ratio), and how far the rotation does (the same, about
    1 where the tiles turn no more than their noise)."""
    n = shakes.shape[0]
    shift = shakes.mean(axis=0)
    perp = _tangents(centres)
    rest = shakes - shift
    theta = np.einsum("itk,ik->t", rest, perp) / max(float((perp**2).sum()), 1e-30)
    rest = rest - theta[None, :, None] * perp[:, None, :]
    # the residual keeps 2 (n - 1) - 1 of the tiles' 2 n numbers a frame (the shift and the
    # rotation taken out): the noise of the shift's mean, as common_shake's, per axis
    var = float((rest**2).sum()) / max((2 * (n - 1) - 1) * shakes.shape[1], 1)
    noise = var * 2.0 * shakes.shape[1] / n
    # the rotation's own: its least-squares variance is var / sum |perp|^2 a frame
    turn = float((theta**2).sum()) * float((perp**2).sum()) / max(var * shakes.shape[1], 1e-30)
    return shift, theta, float((shift**2).sum()) / max(noise, 1e-30), turn


def remove_motion(series: np.ndarray, kx: np.ndarray, ky: np.ndarray, centres: np.ndarray,
                  min_ratio: float = JITTER_MIN_RATIO
                  ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
    """:func:`remove_shake` of a camera that also turns back and forth about its axis (a
    vehicle's heading wavering): each tile's shift is the shift the tiles share plus a
    rotation about the image centre (:func:`_rigid`; ``centres`` ``(tiles, 2)`` px), so the
    tiles agree on the shared shift once the rotation is taken out too.  The rotation is
    taken only where it stands ``min_ratio`` above the tiles' noise too; else this is
    :func:`remove_shake` (the same bits) and the rotation None.  Returns the series with
    what was found removed, the shift ``(T, 2)`` px and the rotation ``(T,)`` rad (each less
    its mean motion), or the series and None, None where the tiles share no shift."""
    centres = np.asarray(centres, dtype=np.float64)
    first = _shakes(series, kx, ky)
    fit = _rigid(first, centres)
    if not fit[3] >= min_ratio:
        # no rotation standing above the tiles' noise: the shift alone, as remove_shake
        # takes it (the same bits)
        return (*_remove_shake(series, kx, ky, min_ratio, first), None)
    perp = _tangents(centres)
    total = rot = None
    out = series
    for k in range(JITTER_PASSES):
        shift, theta, ratio, _ = fit if k == 0 else _rigid(_shakes(out, kx, ky), centres)
        if (not (np.all(np.isfinite(shift)) and np.all(np.isfinite(theta)))
                or (total is None and not ratio >= min_ratio)):
            break
        out = _unmove(out, kx, ky, shift, theta, perp)
        total = shift if total is None else total + shift
        rot = theta if rot is None else rot + theta
    return out, total, rot


def remove_motion_seen(series: np.ndarray, seen: np.ndarray, kx: np.ndarray, ky: np.ndarray,
                       centres: np.ndarray, min_ratio: float = JITTER_MIN_RATIO
                       ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
    """:func:`remove_motion` of ``series`` by the motion read on ``seen``: the same tiles'
    modes through another monotone map of their values (the values as recorded, where
    ``series`` are their normal scores; a camera's rigid features, glints and the sky's
    gradient among them, trace its shake most sharply as recorded).  The motion, shift and
    rotation, is removed from ``series`` whole; returns as :func:`remove_motion` does."""
    _, shift, rot = remove_motion(seen, kx, ky, centres, min_ratio)
    if shift is None:
        return series, None, None
    perp = None if rot is None else _tangents(np.asarray(centres, dtype=np.float64))
    return _unmove(series, kx, ky, shift, rot, perp), shift, rot
