"""The deglinting methods by name: the paper's and the clean-frame estimates beyond it.

Methods
-------
``tmf``
    The paper's residual, eq. (6) (condition folder ``residual``): the glint estimate.
``tmf-min``
    The baseline ``Ĝ`` itself, eq. (5), as an estimate of the clean frame (the paper's
    conclusion proposes training on it).
``median``, ``percentile``
    The temporal median / a low temporal percentile over the same window.
``achromatic``
    Past the paper: glint is white light (eq. (3) adds it equally to R, G, B), so it is
    removed along the grey axis, with the sequence's own water colour line telling how bright
    each chroma should be; saturated samples fall back to ``tmf-min``.
``glint-mask``
    Glint detected per pixel as an outlier above the temporal median of the window (robust
    MAD threshold on the RGB mean); only those samples are replaced, by linear interpolation in
    time between the nearest non-glint samples of that pixel.  Unflagged samples are kept as
    they are, so glint-free input passes nearly untouched.

All methods take ``(frames, *, window)`` and return frames of the same shape and dtype.
Frames are ``(T, H, W, 3)`` (or ``(T, H, W)``) ``float`` in ``[0, 1]`` or ``uint8``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from wavealt.deglint.temporal import (
    DEFAULT_WINDOW,
    _check_sequence,
    _half_window,
    temporal_minimum,
    tmf_residual,
    window_bounds,
)

PERCENTILE_Q = 25.0
GLINT_MAD_K = 3.0
GLINT_MIN_EXCESS = 0.03
ACHROMATIC_ITERATIONS = 4


# -- clean-image estimates --------------------------------------------------------------
def _as_float(x: np.ndarray) -> np.ndarray:
    return x.astype(np.float32) / 255.0 if x.dtype == np.uint8 else x


def _like(est: np.ndarray, x: np.ndarray) -> np.ndarray:
    if x.dtype == np.uint8:
        return np.round(np.clip(est, 0.0, 1.0) * 255.0).astype(np.uint8)
    return np.clip(est, 0.0, 1.0).astype(x.dtype, copy=False)


def _per_window(x: np.ndarray, window: int,
                reduce: Callable[[np.ndarray, int], np.ndarray]) -> np.ndarray:
    """Apply ``reduce(frames[lo:hi+1], t - lo) -> (H, W, ...)`` for each frame ``t``."""
    n = x.shape[0]
    out = np.empty(x.shape, np.float32 if x.dtype == np.uint8 else x.dtype)
    for t in range(n):
        lo, hi = window_bounds(t, n, window)
        out[t] = reduce(x[lo:hi + 1], t - lo)
    return out


def temporal_min_estimate(frames: np.ndarray, *, window: int = DEFAULT_WINDOW) -> np.ndarray:
    """``tmf-min``: the eq. (5) baseline as the clean-frame estimate (paper §5)."""
    return temporal_minimum(frames, window=window)


def temporal_median(frames: np.ndarray, *, window: int = DEFAULT_WINDOW) -> np.ndarray:
    """``median``: per-pixel temporal median over the eq. (5) window, same shape and dtype."""
    return temporal_percentile(frames, window=window, q=50.0)


def temporal_percentile(frames: np.ndarray, *, window: int = DEFAULT_WINDOW,
                        q: float = PERCENTILE_Q) -> np.ndarray:
    """``percentile``: per-pixel ``q``-th temporal percentile (linear interpolation) over the
    eq. (5) window; between the minimum (``q = 0``) and the median (``q = 50``)."""
    _half_window(window)
    x = _check_sequence(frames)
    if not 0.0 <= float(q) <= 100.0:
        msg = f"q must be in [0, 100]; got {q!r}"
        raise ValueError(msg)
    xf = _as_float(x)
    est = _per_window(xf, window, lambda w, _i: np.percentile(w, q, axis=0))
    return _like(est, x)


def glint_mask(frames: np.ndarray, *, window: int = DEFAULT_WINDOW, k: float = GLINT_MAD_K,
               min_excess: float = GLINT_MIN_EXCESS) -> np.ndarray:
    """Boolean ``(T, H, W)`` mask of glint samples (outliers above the temporal median).

    A sample is glint where its RGB mean exceeds the median of its pixel's eq. (5) window by
    more than ``max(k * 1.4826 * MAD, min_excess)`` (MAD: median absolute deviation over the
    window; ``min_excess`` in intensity units keeps 8-bit noise and flat pixels unflagged).
    Glint is white light added to every channel (paper eq. (3)), so one mask serves all three.
    """
    _half_window(window)
    x = _check_sequence(frames)
    lum = _as_float(x)
    if lum.ndim == 4:
        lum = lum.mean(axis=-1, dtype=np.float32)
    n = lum.shape[0]
    mask = np.empty(lum.shape, bool)
    for t in range(n):
        lo, hi = window_bounds(t, n, window)
        w = lum[lo:hi + 1]
        med = np.median(w, axis=0)
        mad = np.median(np.abs(w - med), axis=0)
        thr = np.maximum(k * 1.4826 * mad, min_excess)
        mask[t] = lum[t] - med > thr
    return mask


def glint_masked(frames: np.ndarray, *, window: int = DEFAULT_WINDOW, k: float = GLINT_MAD_K,
                 min_excess: float = GLINT_MIN_EXCESS) -> np.ndarray:
    """``glint-mask``: replace only the glint samples of :func:`glint_mask`.

    Each flagged sample is linearly interpolated in time between the nearest unflagged samples
    of the same pixel before and after it (the nearest one alone at the sequence ends); a pixel
    flagged in every frame keeps its temporal minimum.  Unflagged samples are returned as they
    are.  Same shape and dtype as ``frames``.
    """
    x = _check_sequence(frames)
    mask = glint_mask(x, window=window, k=k, min_excess=min_excess)
    xf = _as_float(x)
    n = x.shape[0]
    good = ~mask
    idx = np.arange(n).reshape((n,) + (1,) * (mask.ndim - 1))
    # index of the nearest good sample at or before t (-1: none) and at or after t (n: none)
    before = np.maximum.accumulate(np.where(good, idx, -1), axis=0)
    after = np.minimum.accumulate(np.where(good, idx, n)[::-1], axis=0)[::-1]
    has_b, has_a = before >= 0, after < n
    b = np.clip(before, 0, n - 1)
    a = np.clip(after, 0, n - 1)
    span = np.maximum(after - before, 1)
    wa = np.where(has_b & has_a, (idx - before) / span, np.where(has_a, 1.0, 0.0))
    if xf.ndim == 4:
        b, a, wa = b[..., None], a[..., None], wa[..., None]
    vb = np.take_along_axis(xf, np.broadcast_to(b, xf.shape), axis=0)
    va = np.take_along_axis(xf, np.broadcast_to(a, xf.shape), axis=0)
    est = (1.0 - wa) * vb + wa * va
    none = ~(has_b | has_a)
    if none.any():
        tmin = np.broadcast_to(_as_float(temporal_minimum(x, window=window)), xf.shape)
        sel = none[..., None] if xf.ndim == 4 else none
        est = np.where(sel, tmin, est)
    keep = good[..., None] if xf.ndim == 4 else good
    out = np.where(keep, xf, est)
    if x.dtype == np.uint8:
        out = np.where(keep, x, _like(out, x))
        return out.astype(np.uint8)
    return out.astype(x.dtype, copy=False)


def achromatic(frames: np.ndarray, *, window: int = DEFAULT_WINDOW,
               iterations: int = ACHROMATIC_ITERATIONS) -> np.ndarray:
    """``achromatic``: remove glint as white light, using the colour of the water.

    Paper eq. (3) renders a frame as a water/sky colour mix plus a glint lobe added equally
    to R, G and B (specular sun glint is spectrally flat, the property remote-sensing
    deglinting relies on).  So the chroma ``d = I - mean_c(I)`` does not see glint, and the
    clean colours of a sequence lie on one line ``a + b F`` (``F``: the Fresnel sky weight):
    the clean RGB mean is an affine function ``p + q s`` of the chroma coordinate ``s`` along
    that line.  Per sequence: ``s`` is the principal axis of ``d``; ``(p, q)`` is fitted to the
    lower envelope of ``(s, mean_c I)`` (least squares, ``iterations`` times keeping the samples
    below the median residual, since glint only adds light); the estimate is
    ``min(mean_c I, p + q s) + d``.  Samples with a saturated channel (>= 0.995, chroma lost
    to clipping) take the eq. (5) temporal minimum over ``window`` instead.

    Needs RGB ``(T, H, W, 3)`` frames.  Same shape and dtype as ``frames``.  On real sea
    imagery the colour line holds only roughly (foam, turbidity, sky gradients); here it is
    exact up to 8-bit rounding, which flatters this method.
    """
    _half_window(window)
    x = _check_sequence(frames)
    if x.ndim != 4:
        msg = f"achromatic needs RGB frames (T, H, W, 3); got shape {x.shape}"
        raise ValueError(msg)
    xf = _as_float(x).astype(np.float64)
    lum = xf.mean(axis=-1)
    chroma = xf - lum[..., None]
    ok = xf.max(axis=-1) < 0.995
    tmin = _as_float(temporal_minimum(x, window=window))
    if ok.sum() < 16:
        return _like(tmin, x)
    dv = chroma[ok]
    centre = dv.mean(axis=0)
    axis = np.linalg.svd(dv - centre, full_matrices=False)[2][0]
    coord = (chroma - centre) @ axis
    s_ok, l_ok = coord[ok], lum[ok]
    sel = np.ones(s_ok.shape, bool)

    def fit(mask: np.ndarray) -> tuple[float, float]:
        ss, ll = s_ok[mask], l_ok[mask]
        var = ss.var()
        q = 0.0 if var <= 1e-12 else float(np.mean((ss - ss.mean()) * (ll - ll.mean())) / var)
        return float(ll.mean() - q * ss.mean()), q

    for _ in range(int(iterations)):
        p, q = fit(sel)
        resid = l_ok - (p + q * s_ok)
        new = resid <= np.median(resid[sel])
        if new.sum() < 16:
            break
        sel = new
    p, q = fit(sel)
    est = np.minimum(lum, p + q * coord)[..., None] + chroma
    est = np.where(ok[..., None], est, tmin)
    return _like(est, x)


METHODS: dict[str, Callable[..., np.ndarray]] = {
    "tmf-min": temporal_min_estimate,
    "median": temporal_median,
    "percentile": temporal_percentile,
    "glint-mask": glint_masked,
    "achromatic": achromatic,
}
PAPER_METHOD = "tmf"
METHOD_DESCRIPTIONS = {
    "tmf": "paper eq. (6) residual clip(I - min_window I, 0, 1): the estimated glint",
    "tmf-min": "paper eq. (5) temporal minimum over the window: estimated clean frame",
    "median": "temporal median over the eq. (5) window: estimated clean frame",
    "percentile": f"temporal {PERCENTILE_Q:g}th percentile over the eq. (5) window: estimated clean frame",
    "glint-mask": ("glint samples (RGB mean above the window median by > max(3 MAD, "
                   f"{GLINT_MIN_EXCESS:g})) interpolated in time from non-glint samples"),
    "achromatic": ("glint removed as white light: per-sequence water colour line fitted to "
                   "the chroma; saturated samples take the window minimum"),
}


def method_names() -> list[str]:
    """Every valid method name: ``tmf`` (the paper's residual) then :data:`METHODS`."""
    return [PAPER_METHOD, *METHODS]


def _check_method(method: Any) -> str:
    if method not in method_names():
        msg = f"method must be one of {', '.join(method_names())}; got {method!r}"
        raise ValueError(msg)
    return method


def apply_method(frames: np.ndarray, method: str, *,
                 window: int = DEFAULT_WINDOW) -> np.ndarray:
    """Run deglinting method ``method`` (``tmf`` gives the eq. (6) residual)."""
    _check_method(method)
    if method == PAPER_METHOD:
        return tmf_residual(frames, window=window)
    return METHODS[method](frames, window=window)


def condition_name(method: str) -> str:
    """Condition folder of a method: ``tmf`` -> ``residual``, others their own name."""
    _check_method(method)
    return "residual" if method == PAPER_METHOD else method
