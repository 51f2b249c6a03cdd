"""The corner tiles' mode series: those a periodogram already took, reused where they hold
every mode another needs, and a carried pattern's component removed from them."""

from __future__ import annotations

import numpy as np

from wavealt.altimetry.dispersion.constants import STATIC_NORM_FRACTION


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
