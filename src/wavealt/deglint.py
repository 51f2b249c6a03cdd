"""Temporal deglinting (paper §3.3) and its measured quality.

The paper models an observed frame as ``I = T + G`` (eq. (4)): a steady wave texture ``T``
plus transient sun glint ``G``.  A pixel struck by glint in one frame is usually not struck
in the next ones, so the temporal minimum over a short window (eq. (5)) estimates the
glint-free baseline and the residual ``clip(I - Ĝ, 0, 1)`` (eq. (6)) holds mostly the glint.

Window convention (eq. (5), taken literally)
---------------------------------------------
``Ĝ(t) = min I(t')`` over the integer frames ``t'`` with ``t - w/2 <= t' <= t + w/2``, i.e.
``t' in [t - h, t + h]`` with ``h = w // 2``, truncated to ``[0, T - 1]`` at the ends of the
sequence.  The window is centred (time-reversal symmetric) and spans ``2 h + 1`` frames, so an
even ``w`` and ``w + 1`` give the same window; ``w = 1`` is the frame itself (zero residual).
With the paper's ``w = 10`` on 10-frame sequences, frame 0 sees frames 0-5, frames 4-5 see the
whole sequence, frame 9 sees frames 4-9.

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

import json
import sys
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
from scipy import ndimage

from wavealt._checks import check_frames

DEFAULT_WINDOW = 10
PERCENTILE_Q = 25.0
GLINT_MAD_K = 3.0
GLINT_MIN_EXCESS = 0.03
ACHROMATIC_ITERATIONS = 4
SSIM_SIGMA_PX = 1.5
SSIM_TRUNCATE = 3.5  # radius 5 px: the 11x11 Gaussian window of Wang et al. (2004)


# -- validation -------------------------------------------------------------------------
def _half_window(window: Any) -> int:
    """``h = w // 2`` of eq. (5) after checking ``window`` is an integer >= 1."""
    if isinstance(window, bool) or not isinstance(window, (int, np.integer)):
        msg = f"window must be an integer number of frames >= 1; got {window!r}"
        raise ValueError(msg)
    if window < 1:
        msg = f"window must be >= 1 frame; got {int(window)}"
        raise ValueError(msg)
    return int(window) // 2


def _check_sequence(frames: Any) -> np.ndarray:
    return check_frames(frames, name="frames", min_frames=2, allow_gray=True)


def window_bounds(t: int, n_frames: int, window: int) -> tuple[int, int]:
    """First and last frame (inclusive) of the eq. (5) window of frame ``t``.

    ``[max(0, t - h), min(T - 1, t + h)]`` with ``h = window // 2``.
    """
    h = _half_window(window)
    return max(0, t - h), min(n_frames - 1, t + h)


# -- eq. (5) and (6) --------------------------------------------------------------------
# bytes of one frame tile: ~3 (2h + 1) tiles stay in the last-level cache, and the tiles are
# large enough that Python's per-call overhead stays small (measured best: 128-512 KiB)
TILE_BYTES = 256 * 1024


def _block_outputs(prev: list[np.ndarray], cur: list[np.ndarray],
                   outs: list[np.ndarray], tile_bytes: int | None = None) -> None:
    """van Herk / Gil-Werman step: fill ``outs[r] = min(prev[r:] + cur[:r])``.

    ``prev`` is a complete block of ``L`` frames, ``cur`` the next ``k`` frames (``k < L`` only
    at the end of a stream) and ``len(outs) <= min(L, k + 1)``.  Window ``r`` is the suffix
    minimum of ``prev`` from ``r`` and the prefix minimum of ``cur`` up to ``r - 1``.  The work
    runs tile by tile (rows of the frame) so every frame is read from memory once per block
    and the intermediate minima stay in cache; about 3 comparisons per pixel per frame.
    """
    tile_bytes = TILE_BYTES if tile_bytes is None else tile_bytes
    span = len(prev)
    top = len(outs) - 1
    frame = prev[0]
    row_bytes = max(1, frame[0].nbytes) if frame.ndim > 1 else max(1, frame.itemsize)
    rows = max(1, tile_bytes // row_bytes)
    scratch = np.empty((rows,) + frame.shape[1:], frame.dtype)
    for r0 in range(0, frame.shape[0], rows):
        sl = slice(r0, min(r0 + rows, frame.shape[0]))
        acc = scratch[:sl.stop - sl.start]
        # suffix minima of the previous block, written straight into the outputs
        if top == span - 1:
            np.copyto(outs[top][sl], prev[top][sl])
        else:
            np.copyto(acc, prev[span - 1][sl])
            for r in range(span - 2, top, -1):
                np.minimum(prev[r][sl], acc, out=acc)
            np.minimum(prev[top][sl], acc, out=outs[top][sl])
        for r in range(top - 1, -1, -1):
            np.minimum(prev[r][sl], outs[r + 1][sl], out=outs[r][sl])
        # prefix minima of the current block
        if top >= 1:
            np.minimum(outs[1][sl], cur[0][sl], out=outs[1][sl])
        if top >= 2:
            np.minimum(cur[0][sl], cur[1][sl], out=acc)
            np.minimum(outs[2][sl], acc, out=outs[2][sl])
            for r in range(3, top + 1):
                np.minimum(acc, cur[r - 1][sl], out=acc)
                np.minimum(outs[r][sl], acc, out=outs[r][sl])


def _sliding_min_blocks(frames: Iterator[np.ndarray], first: np.ndarray, h: int,
                        alloc: Callable[[int], list[np.ndarray]]) -> Iterator[list[np.ndarray]]:
    """Eq. (5) minima, a block at a time, of ``first`` followed by ``frames``.

    The stream is padded with ``h`` copies of its first and last frames, which leaves every
    truncated window minimum unchanged, and cut into blocks of ``L = 2h + 1`` frames; once block
    ``b + 1`` is complete the ``L`` windows starting in block ``b`` are known.  Holds at most
    ``3 L`` frames.  ``alloc(n)`` gives the ``n`` output frames of the next block.
    """
    span = 2 * h + 1
    prev: list[np.ndarray] | None = None
    cur: list[np.ndarray] = []
    last = first

    def padded() -> Iterator[np.ndarray]:
        nonlocal last
        for _ in range(h + 1):
            yield first
        for f in frames:
            last = f
            yield f
        for _ in range(h):
            yield last

    for f in padded():
        cur.append(f)
        if len(cur) == span:
            if prev is not None:
                outs = alloc(span)
                _block_outputs(prev, cur, outs)
                yield outs
            prev, cur = cur, []
    outs = alloc(len(cur) + 1)
    _block_outputs(prev, cur, outs)
    yield outs


def temporal_minimum(frames: np.ndarray, *, window: int = DEFAULT_WINDOW) -> np.ndarray:
    """Glint-free baseline ``Ĝ`` of paper eq. (5): sliding temporal minimum per pixel.

    Parameters
    ----------
    frames : (T, H, W, 3) or (T, H, W) array, float in [0, 1] or uint8, T >= 2
    window : int
        ``w`` of eq. (5), >= 1; frame ``t`` sees frames ``max(0, t - w//2)`` to
        ``min(T - 1, t + w//2)`` (see the module docstring).

    Returns
    -------
    (T, H, W, 3) array, same shape and dtype as ``frames``.

    Notes
    -----
    van Herk (1992) / Gil & Werman (1993): blocks of ``2h + 1`` frames, each window the
    minimum of a block suffix and the next block's prefix (:func:`_block_outputs`), run over
    the whole sequence one band of rows at a time so that the band stays in cache: about three
    comparisons per pixel per frame whatever ``w``, and one memory read and write per pixel.
    """
    h = _half_window(window)
    x = _check_sequence(frames)
    out = np.empty(x.shape, x.dtype)
    if h == 0:
        out[...] = x
        return out
    # All frames are at hand: run the whole sequence one spatial tile (band of rows) at a
    # time, so each input pixel is read from memory once and each output written once.
    row_bytes = max(1, x[0, 0].nbytes)
    rows = max(1, TILE_BYTES // row_bytes)
    for r0 in range(0, x.shape[1], rows):
        sl = slice(r0, min(r0 + rows, x.shape[1]))
        tile = x[:, sl]
        pos = 0

        def alloc(n: int, sl: slice = sl) -> list[np.ndarray]:
            nonlocal pos
            views = [out[pos + i, sl] for i in range(n)]
            pos += n
            return views

        for _ in _sliding_min_blocks(iter(tile[1:]), tile[0], h, alloc):
            pass
    return out


def tmf_residual(frames: np.ndarray, *, window: int = DEFAULT_WINDOW) -> np.ndarray:
    """Recovered texture of paper eq. (6): ``clip(I - Ĝ, 0, 1)``, same shape and dtype.

    Since ``Ĝ <= I`` pointwise the clip never bites on valid input; it is kept as the paper
    writes it.  Holds mostly the transient glint (paper Fig. 4 and Fig. 7).
    """
    x = _check_sequence(frames)
    base = temporal_minimum(x, window=window)
    if x.dtype == np.uint8:
        return np.subtract(x, base, out=base)  # base <= x: no wrap-around
    np.subtract(x, base, out=base)
    return np.clip(base, 0.0, 1.0, out=base)


# -- streaming --------------------------------------------------------------------------
def _check_stream_frame(frame: Any, first: np.ndarray | None, index: int) -> np.ndarray:
    arr = np.asarray(frame)
    if first is None:
        if arr.ndim not in (2, 3) or (arr.ndim == 3 and arr.shape[-1] != 3):
            msg = f"frame 0 must be (H, W, 3) or (H, W); got shape {arr.shape}"
            raise ValueError(msg)
        if arr.dtype != np.uint8 and not np.issubdtype(arr.dtype, np.floating):
            msg = f"frames must be float in [0, 1] or uint8; got dtype {arr.dtype}"
            raise ValueError(msg)
    elif arr.shape != first.shape or arr.dtype != first.dtype:
        msg = (f"frame {index} is {arr.shape} {arr.dtype}; every frame must match frame 0 "
               f"({first.shape} {first.dtype})")
        raise ValueError(msg)
    if arr.dtype != np.uint8:
        lo, hi = arr.min(), arr.max()  # NaN propagates through min/max and fails the test
        if not (lo >= 0.0 and hi <= 1.0):
            msg = f"frame {index} must be finite and in [0, 1]; got values in [{lo:.4g}, {hi:.4g}]"
            raise ValueError(msg)
    return arr


def sliding_min_stream(frames_iter: Iterable[np.ndarray], *, window: int = DEFAULT_WINDOW,
                       copy: bool = True) -> Iterator[np.ndarray]:
    """Eq. (5) over a stream of frames: yields ``Ĝ(t)`` for each frame, in order.

    Bit-identical to :func:`temporal_minimum` (same truncated, centred window), but holds
    about ``3 (2h + 1) + 2`` frames (``h = window // 2``: a ring of ``2 (2h + 1) + 1`` arrival
    copies and one block of outputs), plus whatever outputs the consumer keeps, so a long
    video needs memory O(window x frame).  ``Ĝ(t)`` comes out within ``2 (2h + 1)`` frames
    after frame ``t``.

    Parameters
    ----------
    frames_iter : iterable of (H, W, 3) or (H, W) arrays
        uint8, or float (float32, float64) in [0, 1]; all of one shape and dtype, at least 2.
    window : int
        ``w`` of eq. (5), >= 1.
    copy : bool
        Copy each frame on arrival (default), so a producer may reuse its buffer.  Pass
        ``False`` when every yielded frame is a fresh array that nobody changes afterwards
        (a video decoder's ``to_ndarray()``, slices of an array): it saves a memory pass.

    Yields
    ------
    (H, W, 3) array of the input dtype, a fresh array each time.

    Notes
    -----
    van Herk (1992) / Gil & Werman (1993) on the stream padded with ``h`` copies of its first
    and last frames, a block of ``L = 2h + 1`` frames at a time (:func:`_block_outputs`):
    about three comparisons per pixel per frame and each frame read from memory twice.  Bad
    frames (shape, dtype, NaN, range) raise ``ValueError`` when they are reached, after the
    outputs already yielded.
    """
    h = _half_window(window)
    it = iter(frames_iter)
    try:
        first = next(it)
    except StopIteration:
        msg = "frames_iter yielded no frames; need at least 2"
        raise ValueError(msg) from None
    first = _check_stream_frame(first, None, 0)
    shape, dtype = first.shape, first.dtype
    span = 2 * h + 1
    # Arrival copies go round a ring: the blocks never hold more than the 2L newest frames,
    # so slot n % (2L + 1) is free again when frame n arrives (no allocation per frame).
    ring = [np.empty(shape, dtype) for _ in range(2 * span + 1)] if copy and h else []
    first = first.copy() if copy else first
    count = 1

    def checked() -> Iterator[np.ndarray]:
        nonlocal count
        for frame in it:
            arr = _check_stream_frame(frame, first, count)
            if copy:
                slot = ring[count % len(ring)] if ring else np.empty(shape, dtype)
                np.copyto(slot, arr)
                arr = slot
            count += 1
            yield arr
        if count < 2:
            msg = "frames_iter yielded 1 frame; deglinting needs at least 2"
            raise ValueError(msg)

    if h == 0:
        yield first.copy() if not copy else first
        for f in checked():
            yield f.copy() if not copy else f
        return

    # Output buffers are recycled only once nobody but this pool refers to them (CPython
    # reference count), so every yielded array stays the consumer's for as long as it is
    # kept; reuse saves the page faults of a fresh multi-MB allocation per frame.
    pool: list[np.ndarray] = []

    def alloc(n: int) -> list[np.ndarray]:
        free = [i for i in range(len(pool)) if sys.getrefcount(pool[i]) == 2]
        outs = [pool[i] for i in free[:n]]
        while len(outs) < n:
            buf = np.empty(shape, dtype)
            if len(pool) < 3 * span:
                pool.append(buf)
            outs.append(buf)
        return outs

    for outs in _sliding_min_blocks(checked(), first, h, alloc):
        outs.reverse()
        while outs:  # hand each output over without keeping a reference to it
            yield outs.pop()


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


# -- quality metrics --------------------------------------------------------------------
def _pair(estimate: np.ndarray, reference: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    a = np.asarray(estimate)
    b = np.asarray(reference)
    if a.shape != b.shape:
        msg = f"estimate and reference must have one shape; got {a.shape} and {b.shape}"
        raise ValueError(msg)
    return _as_float(a).astype(np.float64), _as_float(b).astype(np.float64)


def mae(estimate: np.ndarray, reference: np.ndarray) -> float:
    """Mean absolute error in intensity units (images in [0, 1])."""
    a, b = _pair(estimate, reference)
    return float(np.mean(np.abs(a - b)))


def psnr_db(estimate: np.ndarray, reference: np.ndarray) -> float:
    """Peak signal-to-noise ratio ``10 log10(1 / MSE)`` in dB (peak 1); ``inf`` if equal."""
    a, b = _pair(estimate, reference)
    mse = float(np.mean((a - b) ** 2))
    return float("inf") if mse == 0.0 else float(10.0 * np.log10(1.0 / mse))


def ssim(estimate: np.ndarray, reference: np.ndarray) -> float:
    """Mean structural similarity (Wang et al. 2004) of images in [0, 1].

    Accepts ``(H, W)``, ``(H, W, 3)`` or a stack ``(T, H, W[, 3])``: each channel of each
    frame is compared on its own and the SSIM maps are averaged.  Gaussian window sigma 1.5 px
    (11 x 11), ``K1 = 0.01``, ``K2 = 0.03``, data range 1, population (not sample) statistics,
    reflected borders, and the 5-px border cropped before averaging (as scikit-image does with
    ``gaussian_weights=True``) when the frames are larger than 11 px.
    """
    a, b = _pair(estimate, reference)
    if a.ndim < 2:
        msg = f"ssim needs images of at least 2 dimensions; got shape {a.shape}"
        raise ValueError(msg)
    # float32 halves the filtering time; its rounding (~1e-7) is far below C2 = 9e-4
    a, b = a.astype(np.float32), b.astype(np.float32)
    if a.ndim == 2:
        spatial = (0, 1)
    elif a.ndim == 3 and a.shape[-1] == 3:
        spatial = (0, 1)
    elif a.ndim == 3:
        spatial = (1, 2)
    else:
        spatial = (a.ndim - 3, a.ndim - 2)
    sigma = [SSIM_SIGMA_PX if ax in spatial else 0.0 for ax in range(a.ndim)]

    def blur(z: np.ndarray) -> np.ndarray:
        return ndimage.gaussian_filter(z, sigma=sigma, truncate=SSIM_TRUNCATE, mode="reflect")

    c1, c2 = 0.01 ** 2, 0.03 ** 2
    mu_a, mu_b = blur(a), blur(b)
    var_a = blur(a * a) - mu_a * mu_a
    var_b = blur(b * b) - mu_b * mu_b
    cov = blur(a * b) - mu_a * mu_b
    smap = ((2 * mu_a * mu_b + c1) * (2 * cov + c2)) / (
        (mu_a ** 2 + mu_b ** 2 + c1) * (var_a + var_b + c2))
    pad = int(SSIM_TRUNCATE * SSIM_SIGMA_PX + 0.5)
    crop = [slice(None)] * a.ndim
    if all(a.shape[ax] > 2 * pad + 1 for ax in spatial):
        for ax in spatial:
            crop[ax] = slice(pad, a.shape[ax] - pad)
    return float(smap[tuple(crop)].mean())


class _QualityAccumulator:
    """Pools squared and absolute errors and per-frame SSIM over many sequences."""

    def __init__(self) -> None:
        self.sq = 0.0
        self.ab = 0.0
        self.n_values = 0
        self.ssim_sum = 0.0
        self.n_frames = 0
        self.n_sequences = 0

    def add(self, estimate: np.ndarray, reference: np.ndarray) -> None:
        a, b = _pair(estimate, reference)
        d = a - b
        self.sq += float(np.sum(d * d))
        self.ab += float(np.sum(np.abs(d)))
        self.n_values += d.size
        self.ssim_sum += ssim(a, b) * a.shape[0]
        self.n_frames += a.shape[0]
        self.n_sequences += 1

    def result(self) -> dict[str, Any]:
        mse = self.sq / self.n_values
        return {
            "psnr_db": None if mse == 0.0 else float(10.0 * np.log10(1.0 / mse)),
            "ssim": self.ssim_sum / self.n_frames,
            "mae": self.ab / self.n_values,
            "n_sequences": self.n_sequences,
            "n_frames": self.n_frames,
        }


# -- the dataset command ----------------------------------------------------------------
def _check_glinty_folders(ds: Any) -> None:
    """Every sequence has a glinty folder of >= 2 frames of one size (image headers only)."""
    from PIL import Image

    from wavealt.io import frame_files

    ds.require_condition("glinty")
    for rec in ds.records:
        folder = ds.sequence_dir("glinty", rec.sequence_id)
        if not folder.is_dir():
            msg = f"glinty sequence folder missing: {folder}"
            raise FileNotFoundError(msg)
        files = frame_files(folder)
        if len(files) < 2:
            msg = f"{folder} holds {len(files)} frame(s); temporal deglinting needs at least 2"
            raise ValueError(msg)
        sizes = set()
        for p in files:
            try:
                with Image.open(p) as im:
                    sizes.add(im.size)
            except OSError as exc:
                msg = f"cannot read image {p}: {exc}"
                raise ValueError(msg) from None
        if len(sizes) > 1:
            msg = f"frames in {folder} have different sizes: {sorted(sizes)}"
            raise ValueError(msg)


def _quantised(frames: np.ndarray) -> np.ndarray:
    """What the PNG on disk will hold, back as float32."""
    from wavealt.io import to_uint8

    return to_uint8(frames).astype(np.float32) / 255.0


def quality_table(metrics: dict[str, dict[str, Any]]) -> str:
    """Markdown table of ``deglint_metrics.json`` entries ranked by PSNR (best first)."""
    def key(item: tuple[str, dict[str, Any]]) -> float:
        p = item[1].get("psnr_db")
        return -float("inf") if p is None else -float(p)

    rows = sorted(metrics.items(), key=key)
    lines = ["| rank | condition | method | window | PSNR (dB) | SSIM | MAE | sequences |",
             "|---:|---|---|---:|---:|---:|---:|---:|"]
    for i, (name, m) in enumerate(rows, 1):
        p = m.get("psnr_db")
        ps = "inf" if p is None else f"{p:.2f}"
        win = m.get("window")
        lines.append(f"| {i} | {name} | {m.get('method', '-')} | "
                     f"{'-' if win is None else win} | {ps} | {m['ssim']:.4f} | "
                     f"{m['mae']:.4f} | {m['n_sequences']} |")
    return "\n".join(lines) + "\n"


def deglint_dataset(dataset: Path | str | Any, *, method: str = PAPER_METHOD,
                    window: int = DEFAULT_WINDOW, progress: bool = True,
                    force: bool = False) -> str:
    """Deglint every glinty sequence of a dataset folder and measure against ``clean/``.

    Writes ``DATASET/<condition>/<sequence_id>/frame_###.png`` (same layout as ``clean/``;
    ``residual`` for ``tmf``), atomically per sequence, and records the condition with its
    ``method`` and ``window`` in ``dataset.json``.  Resumes: sequences already written with the
    same method and window are kept; a condition made with other settings is refused unless
    ``force``, which rewrites it.
    When ``clean/`` exists, PSNR / SSIM / MAE of the (8-bit) output and of the untouched
    glinty frames against it are merged into ``DATASET/deglint_metrics.json`` (keyed by
    condition) and ranked in ``DATASET/deglint_table.md``.

    Input is checked before anything is written: ``window`` >= 1 and no longer than the
    shortest sequence, a ``glinty/`` folder with every sequence, at least 2 frames per
    sequence, one frame size per sequence.

    Returns
    -------
    str
        The condition name.
    """
    from tqdm import tqdm

    from wavealt.dataset import Dataset
    from wavealt.io import atomic_write_text, read_frames_folder

    _check_method(method)
    _half_window(window)
    window = int(window)
    ds = dataset if isinstance(dataset, Dataset) else Dataset(dataset)
    _check_glinty_folders(ds)
    cond = condition_name(method)
    settings = {"method": method, "window": window}
    shortest = min(r.scenario.frames for r in ds.records)
    if window > shortest:
        msg = f"window {window} is longer than the sequences ({shortest} frames); use --window <= {shortest}"
        raise ValueError(msg)
    old = ds.info.get("conditions", {}).get(cond, {})
    reuse = all(old.get(k) == v for k, v in settings.items())
    if old and not reuse and not force:
        was = ", ".join(f"{k} {old.get(k)}" for k in settings)
        msg = (f"condition {cond} was made with {was}; --force rewrites it with "
               f"{', '.join(f'{k} {v}' for k, v in settings.items())}")
        raise ValueError(msg)
    ds.register_condition(cond, METHOD_DESCRIPTIONS[method], complete=False, **settings)
    have_clean = "clean" in ds.conditions
    q_method, q_glinty = _QualityAccumulator(), _QualityAccumulator()
    metrics_path = ds.root / "deglint_metrics.json"
    metrics: dict[str, Any] = {}
    if metrics_path.is_file():
        try:
            metrics = json.loads(metrics_path.read_text(encoding="utf-8"))
        except json.JSONDecodeError:
            metrics = {}
    # glinty and clean never change for a dataset (a pure function of its config): a baseline
    # row measured over every sequence is kept rather than measured again
    n_total = sum(r.scenario.frames for r in ds.records)
    old_base = metrics.get("glinty", {})
    keep_base = (old_base.get("n_sequences") == len(ds.records)
                 and old_base.get("n_frames") == n_total)
    for rec in tqdm(ds.records, desc=f"deglint {cond}", unit="seq", disable=not progress):
        sid = rec.sequence_id
        if reuse and ds.has_sequence(cond, sid):
            if not have_clean:
                continue
            glinty = None
            # the condition is flagged incomplete while this runs: read its folder directly
            out = read_frames_folder(ds.sequence_dir(cond, sid))
        else:
            glinty = ds.read_frames("glinty", sid)
            out = _quantised(apply_method(glinty, method, window=window))
            ds.write_frames(cond, sid, out)
        if have_clean:
            clean = ds.read_frames("clean", sid)
            q_method.add(out, clean)
            if not keep_base:
                if glinty is None:
                    glinty = ds.read_frames("glinty", sid)
                q_glinty.add(glinty, clean)
    ds.register_condition(cond, METHOD_DESCRIPTIONS[method], complete=True, **settings)
    if have_clean and ds.records:
        if not keep_base:
            metrics["glinty"] = {"method": "none", "window": None, **q_glinty.result()}
        metrics[cond] = {**settings, **q_method.result()}
        atomic_write_text(metrics_path, json.dumps(metrics, indent=2, sort_keys=True) + "\n")
        atomic_write_text(ds.root / "deglint_table.md", quality_table(metrics))
    return cond
