"""A shaking camera's image shift measured on frames alone, without a fit.

The altimeter steadies its corner tiles' mode series before it fits them (:mod:`.jitter`).
A caller that levels frames itself at an attitude measured elsewhere (a flight controller's
``ATTITUDE``) needs the same measurement on the frames as they came, to learn when each
frame was taken on the attitude's clock (:mod:`wavealt.live.latency`): the image shift
that the camera's rotation gave them, frame by frame.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from wavealt._checks import check_frames
from wavealt.altimetry.dispersion.constants import JITTER_MIN_FRAMES, JITTER_MIN_RATIO
from wavealt.altimetry.dispersion.attitude import tile_centres
from wavealt.altimetry.dispersion.jitter import remove_motion, remove_shake
from wavealt.altimetry.dispersion.kernel import _one_blas_thread
from wavealt.altimetry.dispersion.signal import bin_frames, working_bin
from wavealt.altimetry.dispersion.spectra import _corners, _windowed_modes


def image_shake(frames: Any, altimeter: Any = None, min_ratio: float = JITTER_MIN_RATIO,
                rotation: bool = False) -> Any:
    """The image shift of each frame of ``frames`` ``(T, H, W[, 3])`` that the corner tiles
    agree on, ``(T, 2)`` px of the frames given (x, y), less its mean motion over the clip
    (no trend, mean zero): the shake the altimeter first reads before its fit (it then
    reads it again on its tiles moved back, :func:`.jitter.steady_tiles`), with the
    altimeter's signal, tiles and working scale (``altimeter``: a
    :class:`~wavealt.altimetry.dispersion.DispersionAltimeter`, the default one when None).
    None where the tiles share no shift standing ``min_ratio`` times above their own noise
    (in mean square; the altimeter's bar ``JITTER_MIN_RATIO`` by default).  A content that
    moves right and down has positive shifts.

    ``rotation``: the tiles' shifts taken as a shared shift plus a rotation about the
    image centre (a camera whose heading wavers too, :func:`.jitter.remove_motion`), and
    ``(shift, rotation)`` returned, the rotation ``(T,)`` rad less its mean motion; the
    shift is then judged against what the rotation leaves."""
    if altimeter is None:
        from wavealt.altimetry.dispersion.altimeter import DispersionAltimeter

        altimeter = DispersionAltimeter()
    arr = check_frames(frames, min_frames=JITTER_MIN_FRAMES, allow_gray=True)
    if min(arr.shape[1:3]) < 32:
        msg = f"frames must be at least 32x32 px to measure a shake; got {arr.shape[1:3]}"
        raise ValueError(msg)
    b = working_bin(*arr.shape[1:3], altimeter.working_px)
    with _one_blas_thread():
        if b > 1:
            arr = bin_frames(arr, b)
        signal = altimeter._luma(arr)
        parts = _corners(signal, altimeter._tile_fraction())
        kx, ky, _, _, idx = altimeter._plane(*parts[0].shape[1:])
        series = _windowed_modes(parts, idx)
        series -= series.mean(axis=1, keepdims=True)
        if rotation:
            centres = np.array(tile_centres(signal.shape[1:], parts[0].shape[1:]))
            _, shake, turn = remove_motion(series, kx[idx], ky[idx], centres, min_ratio)
            return None if shake is None else (shake * b, turn)
        _, shake = remove_shake(series, kx[idx], ky[idx], min_ratio)
    return None if shake is None else shake * b


__all__ = ["image_shake"]
