"""The corner tiles' mode series: the share of each one's energy that one travelling wave
explains at each phase step, those a periodogram already took reused where they hold every
mode another needs, and a carried pattern's component removed from them."""

from __future__ import annotations

import functools

import numpy as np
import scipy.fft

from wavealt.altimetry.dispersion.constants import STATIC_NORM_FRACTION
from wavealt.altimetry.dispersion.continuum import explained_of_lags


def remove_carried(g: np.ndarray, psi0: np.ndarray) -> None:
    """Remove from mean-free mode series ``g`` ``(parts, T, modes)``, in place, each mode's
    least-squares component ``a (e^{-i psi0 t} - mean)`` at its phase step ``psi0`` per frame
    (a pattern carried across the image without changing: foam riding with the water).

    Its coefficient is ``z(psi0) / D(psi0)`` (the periodogram's,
    :meth:`~wavealt.altimetry.dispersion.spectra._Spectra._periodogram`); a mode whose
    ``psi0`` is so near zero that removing the mean took the pattern (the table's own bound
    for a static pattern, ``STATIC_NORM_FRACTION``) is kept as it is.
    """
    t = g.shape[1]
    e = np.exp(-1j * np.outer(np.arange(t), psi0))  # (T, modes)
    e -= e.mean(axis=0, keepdims=True)
    d0 = np.einsum("tm,tm->m", e.real, e.real) + np.einsum("tm,tm->m", e.imag, e.imag)
    z0 = np.einsum("tm,ptm->pm", np.conj(e), g)  # (parts, modes)
    coef = np.where(d0 >= STATIC_NORM_FRACTION * t, 1.0, 0.0) * z0 / np.maximum(d0, 1e-9)
    g -= (coef[:, None, :] * e[None]).astype(g.dtype)


def modes_within(series: tuple[np.ndarray | None, np.ndarray | None] | None,
                 shape: tuple[int, int], idx: np.ndarray
                 ) -> tuple[np.ndarray | None, np.ndarray | None]:
    """Mode series ``series = (g, modes)`` (``g`` ``(parts, T, len(modes))``, ``modes`` the
    plane's sorted indices of its modes) that hold every mode of ``idx`` (sorted) for parts
    and frames ``shape``: ``(g, None)`` where they are the same modes, ``(g, positions of
    idx in modes)`` where ``idx`` is a subset; ``(None, None)`` where they are not given,
    are of other parts or frames, or lack a mode."""
    if series is None or series[0] is None or series[0].shape[:2] != shape:
        return None, None
    g, modes = series
    if modes is None or (modes.size == idx.size and np.array_equal(modes, idx)):
        return (g, None) if g.shape[2] == idx.size else (None, None)
    pos = np.searchsorted(modes, idx)
    if pos.size and (pos[-1] >= modes.size or not np.array_equal(modes[pos], idx)):
        return None, None
    return g, pos


@functools.lru_cache(maxsize=8)
def share_basis(t: int, n_psi: int) -> tuple[np.ndarray, np.ndarray]:
    """The share table's matrix and norms for ``t`` frames and ``n_psi`` phase steps
    ``psi_j = 2 pi j / n_psi`` (:meth:`~.spectra._Spectra._periodogram`): ``basis``
    ``(2 n_psi, 2 t)`` float32, with ``[Re z; Im z] = basis @ [Re X; Im X]`` for
    ``z_j = sum_t X_t e^{+i psi_j t}``, and ``D(psi_j)``; cached, read-only."""
    psi = 2.0 * np.pi * np.arange(n_psi) / n_psi
    arg = np.outer(np.arange(t), psi)
    cos, sin = np.cos(arg).T, np.sin(arg).T  # (n_psi, T)
    basis = np.block([[cos, -sin], [sin, cos]]).astype(np.float32)
    dirichlet = np.abs(np.exp(1j * np.outer(psi, np.arange(t))).sum(axis=1)) ** 2
    denom = np.maximum(t - dirichlet / t, 1e-9)
    basis.flags.writeable = False
    denom.flags.writeable = False
    return basis, denom


def explained_energy(g: np.ndarray, basis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``|z_j|^2`` summed over the parts, ``(modes, n_psi)`` float32, and each mode's energy
    ``E = sum_t |X_t|^2`` summed over the parts (float64), of mean-free mode series ``g``
    ``(parts, T, modes)`` complex64: ``z_j = sum_t X_t e^{+i psi_j t}`` at the table's steps
    ``psi_j = 2 pi j / n_psi`` (``basis``: :func:`share_basis`'s).

    Where the work is small (one part, or a short clip: ``parts T n_psi <= 4096``), as one
    real matrix product per part, ``[Re z; Im z] = basis @ [Re X; Im X]``, the squares
    summed over the parts in order.  Else through the series' autocorrelation summed over
    the parts, ``r_l = sum_t X_{t+l} conj(X_t)`` (``r_{-l} = conj(r_l)``):
    ``|z(psi)|^2 = sum_l r_l e^{i psi l}``, a real trigonometric polynomial of degree
    ``T - 1``, and ``E = r_0``; ``r`` is the inverse transform of the parts' power spectra
    (zero-padded to at least ``2 T - 1``: no lag wraps), summed, and the table one real
    inverse transform of ``r`` per mode (lags at or past half the table folded onto
    theirs modulo ``n_psi``).  The same sums to float32 rounding; the transforms cost less
    than the products where parts, frames and table steps are many, more where they are
    few (the bound above).
    """
    n_parts, t, m = g.shape
    n_psi = basis.shape[0] // 2
    if n_parts * t * n_psi <= 4096:
        x = np.concatenate([g.real, g.imag], axis=1)  # (parts, 2T, modes)
        energy = np.einsum("ptm,ptm->m", x, x).astype(np.float64)
        acc = np.matmul(basis, x[0])
        acc *= acc
        z = np.empty_like(acc) if n_parts > 1 else None
        for part in x[1:]:  # one part's product at a time
            np.matmul(basis, part, out=z)
            np.multiply(z, z, out=z)
            acc += z
        return np.ascontiguousarray((acc[:n_psi] + acc[n_psi:]).T), energy
    f = scipy.fft.fft(np.ascontiguousarray(g.transpose(0, 2, 1)),
                      n=1 << (2 * t - 2).bit_length(), axis=2, workers=1)
    power = f.real ** 2
    power += f.imag ** 2
    r = scipy.fft.ifft(power.sum(axis=0), axis=1, workers=1)[:, :t]
    energy = r[:, 0].real.astype(np.float64)
    explained = explained_of_lags(r, n_psi)
    np.maximum(explained, np.float32(0.0), out=explained)  # rounding below 0
    return explained, energy
