"""Spectra: the frame cross-spectra modes of the blind start and the whitened periodogram
(per mode, the share of its temporal energy one travelling wave explains)."""

from __future__ import annotations

import contextvars
import functools
import math
from typing import Any, NamedTuple

import numpy as np
import scipy.fft

from wavealt._checks import check_finite_number
from wavealt.altimetry.dispersion.constants import (
    CORNER_TILES,
    JITTER_MIN_FRAMES,
    JITTER_PIXEL_PASSES,
    MIN_FIT_MODES,
    SHARPNESS_FRAMES_POWER,
    SHARPNESS_REFERENCE_FRAMES,
    STATIC_NORM_FRACTION,
)
from wavealt.altimetry.dispersion.attitude import tile_centres
from wavealt.altimetry.dispersion.continuum import continuum_lags, explained_of_lags
from wavealt.altimetry.dispersion.jitter import SHAKE_OFF, remove_motion, remove_motion_seen
from wavealt.altimetry.dispersion.jitter import shake_noise, steady_tiles
from wavealt.altimetry.dispersion.leakage import centroid_shifts, mode_shifts, plane_powers
from wavealt.altimetry.dispersion.modeseries import (
    explained_energy,
    modes_within,
    remove_carried,
    share_basis,
)
from wavealt.altimetry.dispersion.signal import normal_scores

#: For the estimate in progress: None (a global shutter), or a rolling shutter's row delay
#: (frames) and the image velocity (px/frame, the table's convention) of the first fit, whose
#: Doppler line unwraps each mode's phase step (None before that fit: no rows undone).
ROLLING: contextvars.ContextVar[tuple[float, Any] | None] = contextvars.ContextVar(
    "rolling", default=None)


def set_rolling(readout_s: float, fps: float, rows: int) -> contextvars.Token:
    """Set :data:`ROLLING` for an estimate of frames of ``rows`` rows read ``readout_s``
    seconds from first to last row (0: a global shutter, None), no velocity yet; its token
    for the caller's reset.  ``readout_s`` must be finite, >= 0 and at most a frame
    interval."""
    fps = check_finite_number("fps", fps, low=0.0, low_open=True)
    readout_s = check_finite_number("readout_s", readout_s, low=0.0)
    if readout_s > 1.0 / fps:
        msg = (f"readout_s {readout_s:g} s is longer than a frame interval at {fps:g} fps "
               f"({1.0 / fps:g} s)")
        raise ValueError(msg)
    return ROLLING.set((readout_s * fps / rows, None) if readout_s else None)


class _Table(NamedTuple):
    """:meth:`_Spectra._share_table`'s explained-share table and what it kept."""

    q: np.ndarray  # sharpened explained shares (modes, n_psi)
    kx: np.ndarray  # the table's modes (the plane's bins), rad/px
    ky: np.ndarray
    kappa: np.ndarray
    series: np.ndarray | None  # the parts' mean-free mode series (parts, T, modes), complex64
    modes: np.ndarray | None  # the plane's indices of the series' modes
    shake: np.ndarray | None  # the image shift removed (T, 2) px (:mod:`.jitter`)
    continuum: np.ndarray | None  # the optics' square's lags of the series' modes
    shift: np.ndarray | None  # (2, modes) to the series' modes' centroids (:mod:`.leakage`)
    table_shift: np.ndarray  # the same, of the table's modes
    powers: np.ndarray | None  # each part's power over the plane, where transformed


def _wrap(phase: np.ndarray) -> np.ndarray:
    """Wrap angles to ``[-pi, pi)``."""
    out = np.add(phase, np.pi)
    np.remainder(out, 2.0 * np.pi, out=out)
    out -= np.pi
    return out


@functools.lru_cache(maxsize=8)
def _hann2d(h: int, w: int) -> np.ndarray:
    """Separable Hann window ``(h, w)`` float32, zero-free (spectral leakage of a clip);
    cached, read-only."""
    win = (np.hanning(h + 2)[1:-1, None] * np.hanning(w + 2)[None, 1:-1]).astype(np.float32)
    win.flags.writeable = False
    return win


def _windowed_modes(parts: list[np.ndarray], idx: np.ndarray,
                    whole: bool = False) -> Any:
    """Hann-windowed 2-D spectra of equal-sized ``(T, h, w)`` float32 ``parts`` (views
    welcome) at the flat rfft2 indices ``idx``: ``(len(parts), T, len(idx))`` complex64;
    with ``whole``, also the whole planes ``(len(parts), T, h, w // 2 + 1)``.

    The FFTs are SciPy's (single precision). On the corner tiles they are as fast as
    PyTorch's MKL transform (four 30-frame 96^2 tiles: 1.8 ms on one core either way), and
    not importing torch saves about a second of start-up.
    """
    t, h, w = parts[0].shape
    win = _hann2d(h, w)
    x = np.empty((len(parts), t, h, w), dtype=np.float32)
    for i, part in enumerate(parts):
        np.multiply(part, win, out=x[i])
    planes = scipy.fft.rfft2(x, overwrite_x=True)
    modes = planes.reshape(len(parts), t, -1)[:, :, idx]
    return (modes, planes) if whole else modes


def _mean_free_modes(parts: list[np.ndarray], idx: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_windowed_modes` of ``parts`` (``whole``), each mode's temporal mean removed."""
    g, planes = _windowed_modes(parts, idx, whole=True)
    g -= g.mean(axis=1, keepdims=True)
    return g, planes


def _fast_len(n: int) -> int:
    """The largest ``2^a 3^b <= n`` (``n >= 1``): a size the FFT transforms fast (a 10-frame
    stack of four 102^2 tiles took 4.6 ms, of 96^2 tiles 0.7 ms)."""
    best, p3 = 1, 1
    while p3 <= n:
        best = max(best, p3 << (n // p3).bit_length() - 1)
        p3 *= 3
    return best


def _corner_shape(h0: int, w0: int, frac: float = 0.5) -> tuple[int, int]:
    """The ``(h, w)`` of :func:`_corners`'s tiles of ``(h0, w0)`` frames."""
    return _fast_len(int(frac * h0)), _fast_len(int(frac * w0))


def _corners(arr: np.ndarray, frac: float = 0.5) -> list[np.ndarray]:
    """The four corner tiles of ``(T, H, W)`` frames (views), each side the largest fast FFT
    size within ``frac`` of the frame's (:func:`_fast_len`; ``frac = 0.5`` on a
    power-of-two frame: the quadrants)."""
    _, h0, w0 = arr.shape
    h, w = _corner_shape(h0, w0, frac)
    return [arr[:, :h, :w], arr[:, :h, w0 - w:], arr[:, h0 - h:, :w], arr[:, h0 - h:, w0 - w:]]


def _sharpen(q: np.ndarray, exponent: float) -> np.ndarray:
    """``q ** exponent``, by repeated multiplication when the exponent is a small integer."""
    e = float(exponent)
    if e != int(e) or not 1 <= e <= 16:
        return q ** np.float32(e)
    out = q.copy()
    for _ in range(int(e) - 1):
        out *= q
    return out


def sharpness_at(sharpness: float, frames: int) -> float:
    """The exponent :meth:`_Spectra._share_table` raises a ``frames``-frame clip's shares to:
    ``sharpness`` up to ``SHARPNESS_REFERENCE_FRAMES`` frames, and
    ``sharpness (T_ref / T) ** SHARPNESS_FRAMES_POWER`` beyond, but not below 1 (no
    flattening: a share is never raised to less than itself; ``docs/dispersion.md``,
    thirty-fifth session)."""
    if frames <= SHARPNESS_REFERENCE_FRAMES:
        return float(sharpness)
    law = float(sharpness) * (SHARPNESS_REFERENCE_FRAMES / frames) ** SHARPNESS_FRAMES_POWER
    return max(law, 1.0)


class _Spectra:
    """Spectra of :class:`DispersionAltimeter`: the blind start's cross-spectra modes and the
    whitened periodogram (uses ``tiles``, ``max_modes``, ``min_kappa_bins``,
    ``max_kappa_frac``, ``n_psi``, ``corner_tiles``, ``sharpness``)."""

    def _tile_fraction(self) -> float:
        """Side of the corner tiles that the tile checks (tilt, turn, shake, lens) cut, as a
        fraction of the frame's: ``corner_tiles``, or ``CORNER_TILES`` where the fit takes
        the whole frame (``corner_tiles=0``)."""
        return self.corner_tiles or CORNER_TILES

    def _modes(self, gray: np.ndarray) -> dict[str, np.ndarray]:
        """Per-mode phase step, weight and wavenumber from the frame cross-spectra."""
        t, h0, w0 = gray.shape
        if self.tiles == "quadrants":
            # Near nadir the Fresnel reflectance is quadratic in slope (harmonics) and its
            # linear part is the slope times the view tilt, which changes sign across the
            # image centre; an odd modulation smears each mode over its neighbours (biasing
            # toward the stronger, slower low wavenumbers).  Quadrant tiles see one sign.
            parts = [normal_scores(part) for part in _corners(gray)]
            h, w = parts[0].shape[1:]
        else:
            h, w = h0, w0
            parts = [gray]
        win = _hann2d(h, w)
        cross = np.zeros((h, w // 2 + 1), dtype=np.complex128)
        amp = np.zeros((h, w // 2 + 1))
        for part in parts:
            x = part - part.mean(axis=(1, 2), keepdims=True)
            x *= win
            f = scipy.fft.rfft2(x, axes=(1, 2), workers=1, overwrite_x=True)
            cross += np.sum(f[1:] * np.conj(f[:-1]), axis=0)
            mag = np.abs(f)  # each frame's once
            amp += np.sum(mag[1:] * mag[:-1], axis=0)
        kx, ky, kappa, band, _ = self._plane(h, w)
        bin_kappa = 2.0 * np.pi / max(h, w)
        mag = np.abs(cross)
        coh = np.where(amp > 0, mag / np.maximum(amp, 1e-30), 0.0)
        idx = band
        # keep every low mode (the velocity search starts there) and, above, the modes of
        # most coherent energy after whitening the steep ~kappa^-2 image spectrum
        low = kappa.ravel()[idx] <= max(0.25, 6.0 * bin_kappa)
        score = (coh.ravel()[idx] ** 2 * mag.ravel()[idx] * kappa.ravel()[idx] ** 2)
        score[low] = np.inf
        if idx.size > self.max_modes:
            idx = idx[np.argpartition(-score, self.max_modes)[:self.max_modes]]
        c = np.clip(coh.ravel()[idx], 0.0, 0.999)
        pairs = t - 1
        # phase variance of a coherence-c cross-spectrum over n pairs: (1-c^2)/(2 n c^2)
        var = (1.0 - c**2) / (2.0 * pairs * np.maximum(c, 1e-3) ** 2)
        return {
            "psi": -np.angle(cross.ravel()[idx]),
            "kx": kx.ravel()[idx].astype(np.float64),
            "ky": ky.ravel()[idx].astype(np.float64),
            "kappa": kappa.ravel()[idx].astype(np.float64),
            "weight": 1.0 / (var + 1e-4),
            "energy": mag.ravel()[idx].astype(np.float64),
            "total_energy": np.array(float(mag.ravel()[band].sum())),
            "bin_kappa": np.array(bin_kappa),
            "shape": (h, w),
        }

    # -- whitened periodogram ----------------------------------------------------------------
    def _fit_periodogram(self, signal: np.ndarray, **kw: Any) -> dict[str, Any] | None:
        """:meth:`_periodogram` (``kw``) of a scalar sequence a fit can be tried on; None
        where none can: no pixel changes over the clip (on a subsample), or fewer than
        ``MIN_FIT_MODES`` modes."""
        if float(np.mean(np.var(signal[:, ::4, ::4], axis=0))) <= 1e-12:
            return None
        p = self._periodogram(signal, **kw)
        return p if p["kappa"].size >= MIN_FIT_MODES else None

    def _periodogram(self, signal: np.ndarray, corners: bool = True,
                     carried: np.ndarray | None = None,
                     like: dict[str, Any] | None = None,
                     max_modes: int | None = None, continuum: bool = True,
                     scores: bool = True) -> dict[str, Any]:
        """Per spatial mode, the share of its temporal energy one travelling wave explains,
        tabulated over the phase step per frame.

        For mode ``kappa`` with complex amplitudes ``X_t`` (temporal mean removed), the least-
        squares fit of ``a exp(-i psi t) + b`` explains ``|sum_t X_t exp(i psi t)|^2 / D(psi)``
        of ``E = sum_t |X_t|^2``, with ``D(psi) = T - |sum_t exp(i psi t)|^2 / T``.  The table
        ``Q[mode, j] = explained / E`` at ``psi_j = 2 pi j / n_psi`` is independent of the
        mode's power: every mode votes with equal weight (whitening), so the strong but
        poorly resolved long waves do not drown the short ones, whose phase steps are large
        against the 2 pi / T resolution of a short clip.

        The table is taken over the four corner tiles of the frame (``corner_tiles``;
        explained and total energy summed over them).  Near nadir the Fresnel reflectance is
        quadratic in the angle between the surface normal and the line of sight, so where
        the line of sight is vertical (the image centre) the image records the slope
        squared: sum and difference products of wave pairs, off the dispersion shell.
        Toward the edges the term linear in slope (slope times view tilt) dominates, and a
        tile within one corner sees that tilt with one sign (across the centre it changes
        sign, an odd modulation that smears every mode over its neighbours; measured in
        ``docs/dispersion.md``, "The corner tiles").

        ``carried``: the image velocity (px/frame, the table's convention) of a pattern that
        the water carries without dispersion (foam); its content is removed first
        (:meth:`_share_table`) and ``p["carried"]`` records it.  ``like``: a periodogram of
        the same ``signal`` on the same tiles, whose mode series (``p["_series"]``, of the
        plane's modes ``p["_series_modes"]``) are taken instead of transforming the tiles
        again, where they hold every mode this one needs.  ``max_modes``: at most this many
        modes (default ``self.max_modes``).  ``p["shake"]``: the image shift per frame
        that a shaking camera gave the corner tiles and that was removed (:mod:`.jitter`),
        None where none was.  ``scores``: each corner tile's values are taken as the normal
        scores of their ranks (:func:`.signal.normal_scores`; the camera's monotone
        non-linear steps undone); False, as recorded (``p["scores"]`` says which).
        """
        t, h, w = signal.shape
        n_psi = self.n_psi or max(64, 1 << math.ceil(math.log2(6.4 * t)))
        basis, denom = share_basis(t, n_psi)
        corners = corners and _fast_len(int(self.corner_tiles * min(h, w))) >= 32
        recorded = _corners(signal, self.corner_tiles) if corners else [signal]
        parts = [normal_scores(part) for part in recorded] if corners and scores else recorded
        series = None
        if (like is not None and like["corners"] == corners and like["frames"] == t
                and like.get("scores", scores) == scores):
            series = tuple(like.get(k) for k in ("_series", "_series_modes", "_continuum",
                                                 "_shift", "_power"))
        limit = self.max_modes if max_modes is None else max_modes
        centres = (np.array(tile_centres(signal.shape[1:], parts[0].shape[1:])) if corners
                   else None)
        tab = self._share_table(parts, basis, denom, limit, carried, series,
                                like and like.get("shake"), centres, continuum,
                                recorded if parts is not recorded else None)
        # each mode at its waves' centroid (:mod:`.leakage`); the velocity map keeps the bins
        cx, cy = tab.kx + tab.table_shift[0], tab.ky + tab.table_shift[1]
        return {"q": tab.q, "kx": cx, "ky": cy, "kappa": np.hypot(cx, cy), "frames": t,
                "corners": corners, "scores": scores and corners, "carried": carried,
                "_bins": (tab.kx, tab.ky, tab.kappa), "tile": parts[0].shape[1:],
                "_series": tab.series, "_series_modes": tab.modes, "shake": tab.shake,
                "_continuum": tab.continuum, "_shift": tab.shift, "_powers": tab.powers}

    def _share_table(self, parts: list[np.ndarray], basis: np.ndarray, denom: np.ndarray,
                     limit: int, carried: np.ndarray | None = None,
                     series: tuple[Any, ...] | None = None,
                     shaken: np.ndarray | None = None,
                     centres: np.ndarray | None = None,
                     continuum: bool = True,
                     recorded: list[np.ndarray] | None = None) -> _Table:
        """Sharpened explained-share table (:meth:`_periodogram`) of at most ``limit`` modes
        of equal-sized ``parts`` ``(T, h, w)``, explained and total energy summed over the
        parts, with what it kept (:class:`_Table`; the series, their modes, lags and shifts
        None where ``carried`` changed them).  With ``carried`` (px/frame), each mode's
        least-squares component at the carried pattern's phase step ``-kappa . carried`` is
        removed first (:func:`.modeseries.remove_carried`).  ``series``: ``(series, modes[,
        continuum, shifts, the parts' summed power])`` of the same parts, already taken,
        used where they hold every mode (a copy is changed).  ``continuum``: the optics'
        square's share (:mod:`.continuum`) is taken out.  Frames read by a rolling shutter
        (:data:`ROLLING`, once a first fit gave a velocity) take :meth:`_rolled_share_table`.
        The corner tiles' series (``centres``: theirs from the frame's centre, px; None for
        other parts) of a clip of at least ``JITTER_MIN_FRAMES`` frames are steadied first:
        the image shift they share, a shaking camera's, is found in their modes
        (:func:`.jitter.remove_motion`) and the tiles are moved back by it
        (:func:`.jitter.steady_tiles`; ``shake``: None for none; for ``series`` given,
        ``shaken``, theirs); read on ``recorded`` where given (the parts' values as
        recorded, where ``parts`` are their normal scores: :func:`.jitter.remove_motion_seen`)."""
        t, h, w = parts[0].shape
        kx, ky, kappa, _, idx = self._plane(h, w, limit)
        rolling = ROLLING.get()
        if rolling is not None and rolling[1] is not None:
            return self._rolled_share_table(parts, basis, denom, idx, rolling, carried,
                                            continuum)
        given, pos = modes_within(series[:2] if series else None, (len(parts), t), idx)
        planes = None  # the parts' whole windowed planes, where transformed here
        shake = shaken if given is not None else None  # given series: steadied as they were
        # the square's continuum (:mod:`.continuum`) and the modes' centroids (:mod:`.leakage`)
        # of the series' modes, and the parts' power over the plane, where given
        cont, shift = ((None, None) if given is None else
                       (v if v is None or pos is None else v[:, pos] for v in series[2:4]))
        power = series[4] if given is not None else None
        powers = None  # each part's power, where transformed here
        if given is not None:
            # a mode's series and mean are its own: taken from the same transform they are
            # the same bits (copied where the carried pattern's removal changes them)
            if pos is not None:
                g = given[:, :, pos]
            else:
                g = given.copy(order="K") if carried is not None else given
        else:
            # (parts, T, modes); the temporal mean of every pixel, removed where it is cheap:
            # per selected mode
            g, planes = _mean_free_modes(parts, idx)
            if centres is not None and t >= JITTER_MIN_FRAMES:
                # a shaking camera: the image shift the corner tiles share, with a rotation
                # about the centre where they show one, removed (:mod:`.jitter`)
                # the series the shake is read on (the recorded values where ``recorded`` is
                # given, not the normal scores fitted): its noise is what SHAKE_OFF adds
                read = g
                if recorded is None:
                    g, shake, turn = remove_motion(g, kx[idx], ky[idx], centres)
                else:
                    read = _mean_free_modes(recorded, idx)[0]
                    g, shake, turn = remove_motion_seen(g, read, kx[idx], ky[idx], centres)
                if shake is not None:  # the tiles themselves moved back and taken again
                    if SHAKE_OFF.get():  # the first reading one noise realisation off
                        shake = shake + SHAKE_OFF.get() * shake_noise(read, kx[idx], ky[idx])
                    parts, g, planes, shake, _ = steady_tiles(
                        parts, lambda moved: _mean_free_modes(moved, idx), kx[idx], ky[idx],
                        centres, shake, turn, JITTER_PIXEL_PASSES)
        modes = idx  # the series' modes (the table drops those without energy below)
        if carried is not None:
            remove_carried(g, -(kx[idx] * carried[0] + ky[idx] * carried[1]))
        explained, energy = explained_energy(g, basis)
        if continuum:
            if cont is None:
                cont = continuum_lags(parts, idx, _hann2d(h, w), planes)
            # each mode's explained energy less the square's expected share of it
            explained -= explained_of_lags(cont.sum(axis=0), basis.shape[0] // 2)
            np.maximum(explained, np.float32(0.0), out=explained)
        if shift is None:
            if power is None:
                power, powers = plane_powers(parts, _hann2d(h, w), planes)
            shift = centroid_shifts(np.maximum(power, 0.0), w, idx)
        keep = energy > 1e-20 * max(float(energy.max(initial=0.0)), 1e-30)
        table_shift = shift
        if not keep.all():
            idx, explained, energy = idx[keep], explained[keep], energy[keep]
            table_shift = shift[:, keep]
        # explained share |z|^2 / D(psi) / E
        share = explained
        share *= (1.0 / denom).astype(np.float32)[None, :]
        share *= (1.0 / energy).astype(np.float32)[:, None]
        # psi ~ 0: a static pattern, not a wave
        share[:, denom < STATIC_NORM_FRACTION * t] = 0.0
        # Sharpen: a mode counts in proportion to (explained share)^sharpness, so modes that
        # one travelling wave explains almost wholly dominate, and modes that mix the wave
        # with the rendering's non-linear products (harmonics, sum and difference
        # frequencies, glint) count little (docs/dispersion.md, twenty-eighth session).
        kept = carried is None
        return _Table(_sharpen(share, sharpness_at(self.sharpness, t)), kx[idx], ky[idx],
                      kappa[idx], g if kept else None, modes if kept else None, shake,
                      cont if kept else None, shift if kept else None, table_shift,
                      powers if kept else None)

    def _rolled_share_table(self, parts: list[np.ndarray], basis: np.ndarray,
                            denom: np.ndarray, idx: np.ndarray,
                            rolling: tuple[float, tuple[float, float]],
                            carried: np.ndarray | None,
                            continuum: bool = True) -> _Table:
        """:meth:`_share_table` of frames read by a rolling shutter, each row ``c`` frames
        after the one above it, with every row's delay undone (``rolling = (c, u)``: ``u``
        the image velocity, px/frame, of a first fit); the mode series are not kept (None).

        Row ``y`` of frame ``n`` shows the sea at ``n + c y``, so a wave of wavevector ``k``
        and phase step ``Psi`` a frame appears at ``(k_x, k_y - Psi c)``.  Column ``psi_j``
        of mode ``k`` takes the tiles' spectrum at ``k`` with ``e^{+i Psi c y'}`` applied to
        each row (``y'`` from the tile's centre: a delay common to the tile leaves ``|z|``
        as it is), to second order in ``Psi c y'``: ``z_j = B X + i c Psi B Y - (c Psi)^2 / 2
        B W``, ``X, Y, W`` the spectra of the tiles times ``1, y', y'^2``.  ``Psi`` is
        ``psi_j`` unwrapped at the first fit's Doppler line ``-k.u``: a mode carried across
        the frame faster than half a period a frame turns by more than ``pi``, and its own
        step, not the principal one, sets its rows' phases.  Each column's share is of its
        own series' energy (``X + i c Psi Y - (c Psi)^2 / 2 W``), so none exceeds 1.  A
        carried pattern is removed from ``X`` alone.
        """
        t, h, w = parts[0].shape
        row_delay, (ux, uy) = rolling
        plane_kx, plane_ky, plane_kappa = self._plane(h, w)[:3]
        y = np.arange(h, dtype=np.float32) - np.float32((h - 1) / 2)
        series = []
        for weight in (None, y, y * y):
            weighted = parts if weight is None else [part * weight[:, None] for part in parts]
            g = _windowed_modes(weighted, idx).astype(np.complex128)
            g -= g.mean(axis=1, keepdims=True)
            series.append(g)
        if carried is not None:
            remove_carried(series[0], -(plane_kx[idx] * carried[0]
                                         + plane_ky[idx] * carried[1]))
        n_psi = denom.size
        psi = 2.0 * np.pi * np.arange(n_psi) / n_psi
        line = -(plane_kx[idx] * ux + plane_ky[idx] * uy)  # the Doppler line, rad/frame
        turns = np.round((line[None, :] - psi[:, None]) / (2.0 * np.pi))
        c_psi = (psi[:, None] + 2.0 * np.pi * turns) * row_delay  # (n_psi, modes)
        basis_c = basis[:n_psi].astype(np.float64) + 1j * basis[n_psi:].astype(np.float64)
        explained = np.zeros((n_psi, idx.size))
        for x, xy, xyy in zip(*series):
            z, zy, zyy = (basis_c @ np.concatenate([g.real, g.imag]) for g in (x, xy, xyy))
            z += 1j * c_psi * zy - 0.5 * c_psi**2 * zyy
            explained += z.real**2 + z.imag**2
        if continuum:  # less the square's expected share, as in :meth:`_share_table`
            cont = continuum_lags(parts, idx, _hann2d(h, w)).sum(axis=0)
            explained -= explained_of_lags(cont, n_psi).T
            np.maximum(explained, 0.0, out=explained)
        a, b, e = series[0], 1j * series[1], -0.5 * series[2]

        def dot(u: np.ndarray, v: np.ndarray) -> np.ndarray:
            return np.einsum("ptm,ptm->m", u.conj(), v).real

        s1 = c_psi
        energy = (dot(a, a) + s1**2 * dot(b, b) + s1**4 * dot(e, e) + 2 * s1 * dot(a, b)
                  + 2 * s1**2 * dot(a, e) + 2 * s1**3 * dot(b, e))
        total = dot(a, a)
        keep = total > 1e-20 * max(float(total.max(initial=0.0)), 1e-30)
        shift = mode_shifts(parts, idx, _hann2d(h, w))[:, keep]  # (:mod:`.leakage`)
        idx = idx[keep]
        share = (explained.T[keep] / denom[None, :] / energy.T[keep]).astype(np.float32)
        share[:, denom < STATIC_NORM_FRACTION * t] = 0.0
        return _Table(_sharpen(share, sharpness_at(self.sharpness, t)), plane_kx[idx],
                      plane_ky[idx], plane_kappa[idx], None, None, None, None, None, shift,
                      None)

    def _plane(self, h: int, w: int, limit: int | None = None) -> tuple[np.ndarray, ...]:
        """Flat ``kx, ky, kappa`` (rad/px) of an ``(h, w)`` rfft2 plane, the indices of the
        band ``[min_kappa_bins, max_kappa_frac pi]`` (one of each ``+-ky`` pair on the
        ``kx = 0`` column) and the periodogram's fixed, even subsample of it, at most
        ``limit`` (default ``max_modes``; the strongest would be the low wavenumbers only).
        Cached per size and limit."""
        limit = self.max_modes if limit is None else int(limit)
        key = (h, w, limit)
        cache = self.__dict__.setdefault("_plane_cache", {})
        if key not in cache:
            ky = 2.0 * np.pi * np.fft.fftfreq(h)[:, None]
            kx = 2.0 * np.pi * np.fft.rfftfreq(w)[None, :]
            ky, kx = (a.ravel() for a in np.broadcast_arrays(ky, kx))
            kappa = np.hypot(kx, ky)
            bin_kappa = 2.0 * np.pi / max(h, w)
            band = np.flatnonzero((kappa >= self.min_kappa_bins * bin_kappa)
                                  & (kappa <= self.max_kappa_frac * np.pi)
                                  & ~((kx == 0) & (ky < 0)))
            even = band
            if band.size > limit:
                sel = np.random.default_rng(0).choice(band.size, limit, replace=False)
                even = band[np.sort(sel)]
            cache[key] = (kx, ky, kappa, band, even)
        return cache[key]
