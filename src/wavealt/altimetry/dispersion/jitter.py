"""A shaking camera's image jitter, from its corner tiles' mode series, and its removal.

A camera that rolls or pitches by a small angle ``a`` moves the whole image by about
``f a`` px (``f`` the focal length): half a degree is 2 px at a 60-degree view of 256 px.
Over a second a camera on a vehicle without a gimbal shakes by that much, back and forth,
and the sea's phase steps, which the fit reads as the waves' dispersion and the drift, are
no longer steady: the realistic renderer's sea seen through half a degree of roll and
pitch at 0.7-2 Hz read 16 % off (median, blind 1-s windows).

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
mode's series by ``exp(i k . s_t)``.  Marine-radar image sequences are registered for the
platform's motion the same way, by its common phase (Young, Rosenthal & Ziemer 1985, for a
ship's radar).
"""

from __future__ import annotations

import numpy as np

from wavealt.altimetry.dispersion.constants import (
    JITTER_MAX_KAPPA,
    JITTER_MIN_TURNS,
    JITTER_MIN_RATIO,
    JITTER_PASSES,
)

#: Tukey's biweight constant and the regression's reweighting steps.
_TUKEY = 4.685
_TUKEY_STEPS = 4


def _wrap(x: np.ndarray) -> np.ndarray:
    return (x + np.pi) % (2.0 * np.pi) - np.pi


def tile_shake(series: np.ndarray, kx: np.ndarray, ky: np.ndarray) -> np.ndarray:
    """The image shift of every frame, ``(T, 2)`` px (x, y), of one tile's mean-free mode
    series ``series`` ``(T, modes)`` complex of wavenumbers ``kx, ky`` (rad/px), less its
    mean motion over the clip (no trend, mean zero); zeros where too few modes hold a
    steady phase step."""
    t = series.shape[0]
    use = np.hypot(kx, ky) <= JITTER_MAX_KAPPA
    x = series[:, use].astype(np.complex128)
    ax, ay = kx[use], ky[use]
    shift = np.zeros((t, 2))
    if t < 4 or ax.size < 8:
        return shift
    lag = x[1:] * np.conj(x[:-1])  # (T-1, modes)
    c = lag.sum(axis=0)
    power = np.abs(lag)
    coherence = np.abs(c) / np.maximum(power.sum(axis=0), 1e-300)
    resid = np.angle(lag * np.conj(c)[None, :])  # -k . e_t, wrapped
    # The series are mean-free, and a steady phasor of step psi less its mean over the
    # clip steps unevenly: its mean, D(psi) / T of it (D Dirichlet's kernel), has a phase
    # fixed by psi alone, so every mode of that step leans the same way at the same frame,
    # in every tile.  Each mode's residual is taken against that of its own steady phasor,
    # made mean-free the same way; those that turn too little to read (within
    # ``JITTER_MIN_TURNS`` cycles of standing still) are left out.
    psi = np.angle(c)
    frames = np.arange(t, dtype=np.float64)[:, None]
    model = np.exp(1j * psi[None, :] * frames)
    model -= model.mean(axis=0)
    mlag = model[1:] * np.conj(model[:-1])
    resid = _wrap(resid - np.angle(mlag * np.conj(mlag.sum(axis=0))[None, :]))
    kept = (np.abs(psi) >= JITTER_MIN_TURNS * 2.0 * np.pi / t).astype(np.float64)
    w0 = power * (coherence**2 * kept)[None, :]
    e = np.zeros((t - 1, 2))
    for step in range(_TUKEY_STEPS + 1):  # least squares, then reweighted (Tukey)
        r = _wrap(resid + ax[None, :] * e[:, :1] + ay[None, :] * e[:, 1:])
        w = w0
        if step:
            scale = 1.4826 * np.median(np.abs(r), axis=1, keepdims=True) + 1e-12
            u = r / (_TUKEY * scale)
            w = w0 * np.where(np.abs(u) < 1.0, (1.0 - u * u) ** 2, 0.0)
        base = r - ax[None, :] * e[:, :1] - ay[None, :] * e[:, 1:]  # resid, unwrapped near e
        sxx, sxy, syy = (w * ax * ax).sum(1), (w * ax * ay).sum(1), (w * ay * ay).sum(1)
        bx, by = -(w * ax * base).sum(1), -(w * ay * base).sum(1)
        det = sxx * syy - sxy * sxy
        ok = det > 1e-12 * np.maximum(sxx * syy, 1e-300)
        e = np.where(ok[:, None], np.stack([(syy * bx - sxy * by), (sxx * by - sxy * bx)], 1)
                     / np.where(ok, det, 1.0)[:, None], 0.0)
    e -= e.mean(axis=0)
    shift[1:] = np.cumsum(e, axis=0)
    frames = np.arange(t, dtype=np.float64)  # (T,)
    for c_ in range(2):  # no trend: the mean motion is the drift's
        shift[:, c_] -= np.polyval(np.polyfit(frames, shift[:, c_], 1), frames)
    return shift


def common_shake(series: np.ndarray, kx: np.ndarray, ky: np.ndarray
                 ) -> tuple[np.ndarray, float]:
    """The shake the tiles' mode series ``series`` ``(tiles, T, modes)`` share, ``(T, 2)``
    px (their mean, :func:`tile_shake`), and how far it stands above the tiles' own noise:
    its mean square over that of the mean's noise (the tiles' scatter about the mean over
    their number; about 1 where no shake is shared)."""
    shakes = np.stack([tile_shake(s, kx, ky) for s in series])
    n = shakes.shape[0]
    mean = shakes.mean(axis=0)
    if n < 2:
        return mean, 0.0
    noise = float(((shakes - mean) ** 2).sum() / (n - 1)) / n
    return mean, float((mean**2).sum()) / max(noise, 1e-30)


def remove_shake(series: np.ndarray, kx: np.ndarray, ky: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray | None]:
    """The tiles' mode series ``series`` ``(tiles, T, modes)`` complex64 with the shake they
    share removed, mean-free again (a new array), and the shake removed ``(T, 2)`` px; the
    series themselves and None where the tiles share none (``JITTER_MIN_RATIO``).
    ``JITTER_PASSES`` passes, each on what the last left: a mode's steady step is read on
    the shaken series, and the first pass reads about nine tenths of the shake."""
    total = None
    out = series
    for _ in range(JITTER_PASSES):
        shake, ratio = common_shake(out, kx, ky)
        if total is None and ratio < JITTER_MIN_RATIO:
            break  # no shake the tiles agree on (later passes refine the one found)
        phase = kx[None, :] * shake[:, :1] + ky[None, :] * shake[:, 1:]  # (T, modes)
        out = out * np.exp(1j * phase).astype(np.complex64)[None]
        out -= out.mean(axis=1, keepdims=True)
        total = shake if total is None else total + shake
    return out, total
