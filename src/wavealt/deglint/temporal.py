"""Temporal deglinting of paper §3.3: the sliding temporal minimum (eq. (5)) and its
residual (eq. (6)), in memory and streamed.

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
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterable, Iterator
from typing import Any

import numpy as np

from wavealt._checks import check_frames, check_integer

DEFAULT_WINDOW = 10


# -- validation -------------------------------------------------------------------------
def _half_window(window: Any) -> int:
    """``h = w // 2`` of eq. (5) after checking ``window`` is an integer >= 1."""
    return check_integer("window", window, low=1) // 2


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
