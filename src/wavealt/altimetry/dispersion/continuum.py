"""The optics' square: the continuum of sum and difference products that a camera's
non-linear response to the sea's slope puts between the dispersion shells.

Near nadir every camera records the square of the slope beside its linear term (Fresnel's
reflectance and the sky's radiance both grow with the square of the reflected ray's tilt),
so an image is, to second order, ``I = a s + b s^2`` with ``s`` the slope along the view's
tilt.  For a Gaussian sea the square's space-time covariance is ``2 b^2 R(l, x)^2``, ``R``
the linear term's (Isserlis' theorem): its spectrum is the self-convolution of the linear
spectrum, the sum products ``(k1 + k2, omega1 + omega2)`` and difference products
``(k1 - k2, omega1 - omega2)`` of every pair of waves.  For a mode of wavenumber ``kappa``
they spread over phase steps on both sides of its shell: the difference products inside
the cone ``|omega| <= omega(kappa)`` (a slower shell, a higher camera), the short waves' sum
products between the shell and ``sqrt(2) omega(kappa)`` (a faster one, a lower camera).  A
periodogram whose bins are as wide as that gap (10 frames at 9-14 m) has each mode's peak
pulled by them (``docs/dispersion.md``, twenty-second and twenty-seventh sessions).

:func:`continuum_lags` predicts, per part and mode, the autocorrelation over frames that the
square adds to a mode's mean-free series, from the part's own frames: ``R`` is their
space-time autocovariance (which the linear term dominates), and the square's share of the
variance ``2 b^2 / (a^2 + 2 b^2)`` is the one whose skewness the part's pixels have
(:func:`square_share`: ``a s + b s^2`` of a unit normal ``s`` has skewness
``(6 beta - 4 beta^3)`` for ``beta = b / sqrt(a^2 + 2 b^2)``).  The periodogram subtracts its
expected explained energy at every phase step (:meth:`_Spectra._share_table`), so a mode's
share is that of its waves and noise.  The model is the square of a Gaussian linear term;
glint and foam, whose skewness is not a square's, are capped at the share of an image
that is all square (1).
"""

from __future__ import annotations

import functools
import math

import numpy as np
import scipy.fft

from wavealt.altimetry.dispersion.constants import CONTINUUM_SKEW_STEP
from wavealt.altimetry.dispersion.kernel import compiled_module

#: The largest skewness of ``a s + b s^2`` (all square: ``beta = 1 / sqrt(2)``).
_MAX_SKEW = 2.0 * math.sqrt(2.0)


def square_share(x: np.ndarray) -> float:
    """The share of the variance of ``x`` that the square term of ``a s + b s^2`` (``s`` a
    unit normal) holds, for the skewness ``x`` has: ``2 beta^2``, with ``beta`` in
    ``[0, 1 / sqrt(2)]`` solving ``6 beta - 4 beta^3 = |skewness|`` (monotone there); 1
    where the skewness is at least the largest a square gives; 0 for a constant ``x``."""
    v = x.astype(np.float64).ravel()
    v -= v.mean()
    var = float(np.dot(v, v)) / v.size
    if not var > 0.0:
        return 0.0
    g1 = abs(float(np.dot(v * v, v)) / v.size / var ** 1.5)
    if g1 >= _MAX_SKEW:
        return 1.0
    # the cubic's root in [0, 1/sqrt(2)], by Newton from the linear guess (monotone,
    # concave: the iterates rise to it)
    beta = g1 / 6.0
    for _ in range(50):
        f = 6.0 * beta - 4.0 * beta ** 3 - g1
        step = f / (6.0 - 12.0 * beta * beta)
        beta -= step
        if abs(step) < 1e-12:
            break
    beta = min(max(beta, 0.0), 1.0 / math.sqrt(2.0))
    return 2.0 * beta * beta


@functools.lru_cache(maxsize=8)
def centring_map(t: int) -> np.ndarray:
    """``A`` ``(t, 2 t - 1)`` float64: a stationary series of ``t`` frames with lag
    covariance ``rho(l)`` (``l = -(t-1) .. t-1``, by column ``l + t - 1``) has, once its
    mean over the frames is removed, the expected autocorrelation sums
    ``E sum_s Y_{s+l} conj(Y_s) = (A rho)_l`` at ``l = 0 .. t-1``; cached, read-only."""
    h = np.eye(t) - 1.0 / t
    a = np.zeros((t, 2 * t - 1))
    for m in range(-(t - 1), t):
        c = h @ np.eye(t, k=-m) @ h  # covariance of the centred series for rho = delta_m
        for lag in range(t):
            a[lag, m + t - 1] = np.trace(c, offset=-lag)
    a.flags.writeable = False
    return a


def lag_sums(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The real and imaginary parts ``(T, P)`` float32 of ``sum_s X_{s+l} conj(X_s)``
    (``l = 0 .. T-1``, the pairs ``s`` in ascending order) of each column of ``x`` ``(T, P)``
    complex64: the compiled loop (:func:`~wavealt.altimetry.dispersion.compiled.lag_sums`)
    where it is loaded, else :func:`lag_sums_arrays`, the same bits."""
    re, im = np.ascontiguousarray(x.real), np.ascontiguousarray(x.imag)
    out_re, out_im = np.empty_like(re), np.empty_like(im)
    ck = compiled_module()
    (lag_sums_arrays if ck is None else ck.lag_sums)(re, im, out_re, out_im)
    return out_re, out_im


def lag_sums_arrays(re: np.ndarray, im: np.ndarray, out_re: np.ndarray,
                    out_im: np.ndarray) -> None:
    """:func:`lag_sums` in numpy array passes, in place: one pass per first frame ``s`` of
    a pair over every lag at once, in real arithmetic (half the work of complex products)."""
    t = re.shape[0]
    out_re[:] = 0.0
    out_im[:] = 0.0
    for s in range(t):
        a_r, a_i, b_r, b_i = re[s:], im[s:], re[s], im[s]
        prod = a_r * b_r
        prod += a_i * b_i
        out_re[:t - s] += prod
        prod = a_i * b_r
        prod -= a_r * b_i
        out_im[:t - s] += prod


def continuum_lags(parts: list[np.ndarray], idx: np.ndarray, window: np.ndarray,
                   planes: np.ndarray | None = None) -> np.ndarray:
    """Per part, the autocorrelation sums ``r_l = sum_s X_{s+l} conj(X_s)``
    (``l = 0 .. T-1``) that the square of the part's linear term is expected to add to the
    mean-free series of its modes ``idx`` (flat rfft2 indices of the ``(h, w)`` plane), as
    the periodogram takes them (each frame times ``window``): ``(len(parts), len(idx),
    T)`` complex64.  ``planes``: the parts' windowed frames' rfft2 planes where already
    made (``(len(parts), T, h, w // 2 + 1)``; the part's mean times the window's plane is
    taken from them instead of transforming again).

    ``R(l, x)`` is the windowed frames' space-time autocovariance per pair of frames (the
    part's mean removed; circular in space, as the plane is); the square's covariance
    ``R^2`` goes back to the plane per lag (``R(-l, x) = R(l, -x)``: the negative lags are
    the conjugates), is scaled so that its energy is the square's share
    (:func:`square_share`) of the frames', and is centred (:func:`centring_map`)."""
    t, h, w = parts[0].shape
    pairs = np.arange(t, 0, -1, dtype=np.float32)[:, None, None]
    centre = centring_map(t).T.astype(np.complex64)  # (2t-1, t)
    out = np.zeros((len(parts), idx.size, t), dtype=np.complex64)
    lagged = None
    wplane = None if planes is None else scipy.fft.rfft2(window, workers=1)
    for i, part in enumerate(parts):
        share = square_share(part[:, ::CONTINUUM_SKEW_STEP, ::CONTINUUM_SKEW_STEP])
        if share <= 0.0:
            continue
        if planes is None:
            f = scipy.fft.rfft2((part - np.float32(part.mean())) * window, workers=1)
        else:
            f = planes[i] - np.float32(part.mean()) * wplane
        # sum over pairs s of X_{s+l} conj(X_s), every mode, per lag (compiled where loaded)
        lagged = np.empty_like(f) if lagged is None else lagged
        lag_re, lag_im = lag_sums(f.reshape(t, -1))
        lagged.real = lag_re.reshape(f.shape)
        lagged.imag = lag_im.reshape(f.shape)
        lagged /= pairs
        cov = scipy.fft.irfft2(lagged, s=(h, w), workers=1)  # R(l, x), l >= 0
        cov *= cov
        spec = scipy.fft.rfft2(cov, workers=1).reshape(t, -1)
        # scaled so that the square holds its share of the part's energy over the plane
        total = float(np.abs(spec[0].real).sum())
        if total > 0.0:
            scale = share * float(np.abs(lagged[0].real).sum()) / total
            spec = spec[:, idx] * np.float32(scale)  # (t, modes)
            rho = np.concatenate([np.conj(spec[:0:-1]), spec]).T  # lags -(t-1) .. t-1
            out[i] = rho @ centre
    return out


def explained_of_lags(r: np.ndarray, n_psi: int) -> np.ndarray:
    """``|z(psi_j)|^2 = sum_l r_l e^{i psi_j l}`` (``r_{-l} = conj(r_l)``) at the table's
    phase steps ``psi_j = 2 pi j / n_psi``: ``(modes, n_psi)`` real (float32 for complex64
    ``r``) of autocorrelation sums ``r`` ``(modes, T)``, one real inverse transform per mode
    (lags at or past half the table folded onto theirs modulo ``n_psi``)."""
    m, t = r.shape
    if t > n_psi // 2:  # lags reach half the table: folded (the sum stays Hermitian)
        c = np.zeros((m, n_psi), dtype=r.dtype)
        for lag in range(t):
            c[:, lag % n_psi] += r[:, lag]
            if lag:
                c[:, -lag % n_psi] += np.conj(r[:, lag])
        r = c[:, :n_psi // 2 + 1]
    explained = scipy.fft.irfft(r, n=n_psi, axis=1, workers=1)
    explained *= np.float32(n_psi)
    return explained
