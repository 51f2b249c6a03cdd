"""The altimeter: parameters, the physics, and the path through the stages to a result."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from wavealt._checks import check_choice, check_finite_number, check_frames, check_integer
from wavealt.altimetry.dispersion.constants import (
    ATTITUDES,
    BLIND_MAP_KAPPA,
    BLOCK_CODED_MIN_EXCESS,
    BLOCK_PERIOD_PX,
    CARRIED_CHECKED_MATCH_PX,
    CARRIED_CHECKED_MIN_RATIO,
    CARRIED_MATCH_BINS,
    CARRIED_MIN_RATIO,
    CORNER_TILES,
    DEGLINTS,
    DISPERSIONS,
    MIN_FIT_MODES,
    MIN_FRAMES,
    PRIOR_SIGMAS,
    SIGNALS,
    TILES,
    TRUSTED_QUALITY,
    WORKING_PX,
    YAW_PASSES,
)
from wavealt.altimetry.dispersion.kernel import _one_blas_thread, use_compiled  # noqa: F401
from wavealt.altimetry.dispersion.levelling import _Level, attitude_prior_deg
from wavealt.altimetry.dispersion.profile import _Profile
from wavealt.altimetry.dispersion.result import DispersionResult
from wavealt.altimetry.dispersion.search import _Search
from wavealt.altimetry.dispersion.signal import _has_texture, _Signal, bin_frames, block_excess
from wavealt.altimetry.dispersion.signal import working_bin
from wavealt.altimetry.dispersion.spectra import ROLLING, _Spectra, set_rolling
from wavealt.altimetry.dispersion.start import _Start
from wavealt.altimetry.dispersion.tiles import _Tiles
from wavealt.altimetry.dispersion.trust import _Trust
from wavealt.altimetry.dispersion.turn import _Turn, turn_shown
from wavealt.altimetry.dispersion.waves import omega, omega_and_dlog_k
from wavealt.camera import MAX_YAW_RATE_DPS, unturn_yaw


class DispersionAltimeter(_Signal, _Spectra, _Start, _Search, _Profile, _Trust, _Tiles,
                          _Level, _Turn):
    """Altitude, its uncertainty and the water's velocity from frames, by wave dispersion.

    Parameters
    ----------
    dispersion : {"gravity-capillary", "gravity"}
        Dispersion relation of the water: ``"gravity-capillary"`` (``omega^2 = g k +
        (sigma/rho) k^3``), real water; ``"gravity"`` (``omega = sqrt(g k)``), the ``paper``
        simulator preset's.
    water_depth_m : float, optional
        Depth of the water, metres (None, the default: deep water).  Waves longer than about
        twice the depth feel the bottom and slow down (:mod:`.waves`): over water shallower
        than about a tenth of the altitude, fitted as deep water, the camera reads high.
    deglint : {"clip", "median", "none"}
        Glint suppression before the analysis (:func:`deglint`).
    clip_sigma : float
        Threshold of the glint clip of the luminance and of the outlier clip of the chroma
        signal (foam, saturated glint), in robust standard deviations.
    max_modes : int
        Most spatial modes entering the fit (phase-step start: the most coherent-energy
        ones; periodogram: a fixed, even subsample of the plane).
    min_kappa_bins : float
        Lowest radial wavenumber used, in FFT bins (lower ones carry the window's leakage
        and the illumination's slow gradients).
    max_kappa_frac : float
        Highest radial wavenumber used, as a fraction of the Nyquist wavenumber pi rad/px.
    max_shift_px : float
        Largest water image speed searched, pixels per frame.
    altitude_range_m : tuple of float
        Altitudes the fit may return, metres (the tool is made for 1-15 m; a wider range lets
        slow, nearly static image content pose as a very high camera).
    tiles : {"quadrants", "full"}
        Cross-spectra of the blind start on the four image quadrants (summed), or on the
        whole frame.
    signal : {"auto", "luma", "chroma"}
        Scalar sequence analysed (:meth:`_signal`): the luminance, glint-clipped, or the
        chroma, from which white content (glint, saturation, foam) drops out.  ``"auto"``
        (the default) fits the chroma of colour frames whose colour explains less than
        ``glint_r2`` of the luminance's variance (white glint dominates the luminance), and
        the luminance too where that fit fails a trust test, keeping the fit that passes
        more of the tests; or the luminance alone where the colour explains more, or where
        the chroma shows a block coder's lattice (:func:`~.signal.block_excess`,
        ``BLOCK_CODED_MIN_EXCESS``: JPEG and MPEG quantise the chroma coarsely on 8-px
        blocks, and the lattice mixes the short waves into false shells in it).
    glint_r2 : float
        ``"auto"`` fits the chroma first when the squared correlation of luminance and
        chroma over the frame's pixels is below this (white glint adds to the luminance and
        not to the chroma).
    n_psi : int, optional
        Phase steps tabulated by the periodogram; default: enough to resolve its peak
        (``2 pi / T`` wide) with about six steps, at least 64.
    n_scan : int
        Points of the aided altitude scan over ``altitude_range_m``.
    n_groups : int
        Mode groups whose spread gives the uncertainty.
    sharpness : float
        Exponent applied to every mode's explained share (:meth:`_periodogram`) on clips
        of up to ``SHARPNESS_REFERENCE_FRAMES`` frames; lower on longer clips
        (:func:`.spectra.sharpness_at`).
    corner_tiles : float
        Side of the four corner tiles the periodogram is taken over, as a fraction of the
        frame's (0.5: the quadrants; :meth:`_periodogram`); 0, or tiles under 32 px, for
        the whole frame.  An aided fit on the tiles that flags itself is tried on the whole
        frame too (:meth:`_fit_signal`).
    attitude : {"estimate", "level"}
        ``"estimate"`` (the default): where the corner tiles' scales show that the camera
        is tilted (:mod:`.attitude`, ``ATTITUDE_LEVEL``), the frames are levelled at the
        tilt measured and fitted again (:meth:`_level`; the result's ``attitude_deg``), and
        where the tiles that hold the waves cannot measure the tilt (all on one side of the
        frame, or none) a tilt of about ``ATTITUDE_PRIOR_SD_DEG`` per axis joins the
        uncertainty (:meth:`_unmeasured_tilt`); ``"level"``: the frames are fitted as those
        of a camera looking straight down (frames already levelled at an attitude known,
        :class:`wavealt.camera.NadirView`, may still be tilted by the attitude's error).
    attitude_sigma_deg : float, optional
        With ``"estimate"``: the prior of the tilt the tiles measure, one sigma per axis,
        degrees, from the frames' nadir (a gimbal's; an attitude's error the frames were
        levelled at); None: ``ATTITUDE_PRIOR_SD_DEG``, an attitude not known (:meth:`_level`).
    working_px : int
        The working scale (``WORKING_PX``; the band's limits in rad/px were set at it): frames
        of twice its side, or of a much longer focal length, are binned first
        (:func:`.signal.working_bin`; ``signal`` then says ``+binned2``); 0 never bins.
    """

    def __init__(self, *, dispersion: str = "gravity-capillary",
                 water_depth_m: float | None = None, deglint: str = "clip", clip_sigma: float = 3.0,
                 max_modes: int = 4000, min_kappa_bins: float = 2.5, max_kappa_frac: float = 0.85,
                 max_shift_px: float = 16.0, altitude_range_m: tuple[float, float] = (0.5, 20.0),
                 tiles: str = "full", signal: str = "auto", glint_r2: float = 0.3,
                 n_psi: int | None = None, n_scan: int = 80, n_groups: int = 8,
                 sharpness: float = 5.0, corner_tiles: float = CORNER_TILES,
                 attitude: str = "estimate", working_px: int = WORKING_PX,
                 attitude_sigma_deg: float | None = None) -> None:
        self.signal = check_choice("signal", signal, SIGNALS)
        self.attitude = check_choice("attitude", attitude, ATTITUDES)
        self.attitude_sigma_deg = attitude_prior_deg(attitude, attitude_sigma_deg)
        self.corner_tiles = check_finite_number("corner_tiles", corner_tiles, low=0.0, high=0.5)
        self.glint_r2 = check_finite_number("glint_r2", glint_r2, low=0.0, high=1.0)
        for name, v, least in (("working_px", working_px, 0), ("n_psi", n_psi, 16),
                               ("n_scan", n_scan, 8), ("n_groups", n_groups, 3)):
            if v is not None or name != "n_psi":
                check_integer(name, v, low=least)
        self.n_psi = None if n_psi is None else int(n_psi)
        self.working_px, self.n_scan, self.n_groups = int(working_px), int(n_scan), int(n_groups)
        self.sharpness = check_finite_number("sharpness", sharpness, low=1.0)
        self.tiles = check_choice("tiles", tiles, TILES)
        self.dispersion = check_choice("dispersion", dispersion, DISPERSIONS)
        self.deglint = check_choice("deglint", deglint, DEGLINTS)
        self.water_depth_m = None if water_depth_m is None else check_finite_number(
            "water_depth_m", water_depth_m, low=0.0, low_open=True)
        self.clip_sigma = check_finite_number("clip_sigma", clip_sigma, low=0.0, low_open=True)
        self.max_modes = check_integer("max_modes", max_modes, low=8)
        self.min_kappa_bins = check_finite_number("min_kappa_bins", min_kappa_bins, low=1.0)
        self.max_kappa_frac = check_finite_number("max_kappa_frac", max_kappa_frac, low=0.0,
                                                  high=1.0, low_open=True)
        self.max_shift_px = check_finite_number("max_shift_px", max_shift_px, low=0.0)
        lo, hi = altitude_range_m
        check_finite_number("altitude_range_m[0]", lo, low=0.0, low_open=True)
        check_finite_number("altitude_range_m[1]", hi, low=lo, low_open=True)
        self.altitude_range_m = (float(lo), float(hi))

    # -- physics ---------------------------------------------------------------------------
    def omega(self, k: np.ndarray) -> np.ndarray:
        """Angular frequency (rad/s) of physical wavenumber ``k`` (rad/m), in water
        ``water_depth_m`` deep (None: deep water; :mod:`.waves`)."""
        return omega(k, self.dispersion, self.water_depth_m)

    def _omega_and_dlog(self, kappa: np.ndarray, focal_px: float,
                        altitude_m: float) -> tuple[np.ndarray, np.ndarray]:
        """``omega`` and ``d omega / d log(altitude)`` at pixel wavenumbers ``kappa``."""
        w, dlog_k = omega_and_dlog_k(kappa * focal_px / altitude_m, self.dispersion,
                                     self.water_depth_m)
        return w, -dlog_k  # k = kappa f / h: d log k / d log h = -1

    # -- public ------------------------------------------------------------------------
    def estimate(self, frames: Any, *, fps: float, focal_px: float,
                 velocity_mps: tuple[float, float] | None = None,
                 velocity_sigma_mps: float = 0.0, readout_s: float = 0.0,
                 yaw_rate_dps: float | None = None) -> DispersionResult:
        """Estimate altitude, its uncertainty and the camera's velocity over the water.

        Three modes (``DispersionResult.mode``): **blind** (no ``velocity_mps``: altitude and
        velocity searched jointly); **prior** (``velocity_sigma_mps > 0``: the velocity over
        the water within about ``3 velocity_sigma_mps`` of ``velocity_mps``, e.g. satellite
        navigation with the current unknown); **exact** (``velocity_sigma_mps = 0``).
        Fits not trusted are made again: binned half as much (``+finer``, kept if trusted) or,
        where the focal length is long, binned toward the working one (``+coarser``).

        Parameters
        ----------
        frames : (T, H, W, 3) or (T, H, W) array
            Frame sequence, float in [0, 1] or uint8, ``T >= 3``, evenly spaced in time.
        fps : float
            Frame rate, frames per second.
        focal_px : float
            Focal length in pixels (``(W / 2) / tan(fov_x / 2)``).
        velocity_mps : (float, float), optional
            The camera's velocity (over the water as far as known), m/s, along image +x
            (columns) and +y (rows).
        velocity_sigma_mps : float
            How far, m/s (one sigma, per axis), the camera's velocity over the water may lie
            from ``velocity_mps``; 0 for exact.  Ignored without ``velocity_mps``.
        readout_s : float
            A rolling shutter's readout time, s: the frame's rows are read top to bottom,
            ``readout_s / rows`` apart (0: a global shutter).  At most one frame interval.
            A row read later sees the sea carried further; given, the fit is made again
            with each row's delay undone at the first fit's velocity.
        yaw_rate_dps : float, optional
            The camera's yaw rate, degrees per second, positive turning the top of the
            image (the vehicle's nose) right, taken as the truth: the frames are turned back
            to the middle frame's orientation first (:func:`wavealt.camera.unturn_yaw`), so
            the result's velocity is in the middle frame's axes.  At most 180; 0 declares a
            camera that does not turn.  Not given, the corner tiles measure the turn
            (:func:`.yaw.tile_yaw`) and the frames are turned back at it; the result's
            ``yaw_rate_dps`` says at what rate the frames were.

        Returns
        -------
        DispersionResult
        """
        frames = np.asarray(frames)  # once: a list is not converted again for each try
        focal_px = check_finite_number("focal_px", focal_px, low=0.0, low_open=True)
        shape = frames.shape[1:3] if frames.ndim >= 3 else (1, 1)
        b, b_focal = (working_bin(*shape, self.working_px, f) for f in (None, focal_px))
        kw = {"fps": fps, "focal_px": focal_px, "velocity_mps": velocity_mps,
              "velocity_sigma_mps": velocity_sigma_mps, "yaw_rate_dps": yaw_rate_dps}
        res = self._estimate_at(frames, b, readout_s, **kw)
        if b_focal > b and not res.trusted:
            # a focal length long at this scale moves the image too many px a frame for the
            # band: binned toward the working focal length, that fit is the result
            coarser = self._estimate_at(frames, b_focal, readout_s, **kw)
            coarser.signal += "+coarser"
            return coarser
        if b > 1 and not res.trusted:
            # not measured at the working scale: frames binned half as much resolve waves
            # half as long (high up, where the working scale's shortest turn slowly)
            finer = self._estimate_at(frames, b // 2, readout_s, **kw)
            if finer.trusted:
                finer.signal += "+finer"
                return finer
        return res

    def _estimate_at(self, frames: np.ndarray, binning: int, readout_s: float,
                     **kw: Any) -> DispersionResult:
        """:meth:`_estimate` of ``frames`` binned ``binning`` px a side, read in ``readout_s``."""
        rows = frames.shape[1] // binning if frames.ndim >= 3 else 1
        token = set_rolling(readout_s, kw["fps"], rows)
        try:
            with _one_blas_thread():
                res = self._estimate(frames, binning=binning, **kw)
                return self._shake_uncertain(res, frames, binning, readout_s, kw)
        finally:
            ROLLING.reset(token)

    def _estimate(self, frames: Any, *, fps: float, focal_px: float,
                  velocity_mps: tuple[float, float] | None,
                  velocity_sigma_mps: float = 0.0, yaw_rate_dps: float | None = None,
                  binning: int = 1, yaw_pass: int = 0) -> DispersionResult:
        arr = check_frames(frames, min_frames=MIN_FRAMES, allow_gray=True)
        fps = check_finite_number("fps", fps, low=0.0, low_open=True)
        focal_px = check_finite_number("focal_px", focal_px, low=0.0, low_open=True)
        velocity_sigma_mps = check_finite_number("velocity_sigma_mps", velocity_sigma_mps, low=0.0)
        if velocity_mps is not None:
            if np.ndim(velocity_mps) != 1 or len(velocity_mps) != 2:
                msg = f"velocity_mps must be two numbers (vx, vy); got {velocity_mps!r}"
                raise ValueError(msg)
            velocity_mps = tuple(check_finite_number("velocity_mps", v) for v in velocity_mps)
        h, w = arr.shape[1:3]
        if min(h, w) < 16:
            msg = f"frames must be at least 16x16 px; got {h}x{w}"
            raise ValueError(msg)
        # flat input: on a subsample where that shows texture (nearly always), else every pixel
        if not _has_texture(arr[:, ::7, ::7]) and not _has_texture(arr):
            msg = "frames hold no texture (flat, black or saturated); no waves to measure"
            raise ValueError(msg)
        # a yaw rate given is taken as the truth; one measured (a later pass) is checked again
        measure = yaw_rate_dps is None or yaw_pass > 0
        yaw = 0.0 if yaw_rate_dps is None else yaw_rate_dps
        if yaw != 0.0:  # a yawing camera: every frame turned as the middle one
            arr = unturn_yaw(arr, yaw, fps)  # (which checks the rate)
        camera_focal_px = focal_px  # the frames' own, which a pass turned back is given
        if binning > 1:  # to the working scale (``working_px``)
            arr, focal_px = bin_frames(arr, binning), focal_px / binning
        lattice = BLOCK_PERIOD_PX // binning  # a block coder's, in the binned frames
        prior = None if velocity_mps is None else (*velocity_mps, velocity_sigma_mps)
        res, signal, p = self._fit(arr, fps, focal_px, prior, lattice)
        turned = self._measured_turn(p, signal, fps, True) if measure and p else None
        turn = None if turned is None else turned[0]

        def finish() -> DispersionResult:
            return self._finish(res, signal, p, arr, fps, focal_px, prior, lattice,
                                measure=measure, turn=turn, yaw=yaw, binning=binning)
        if turn is not None and yaw_pass < YAW_PASSES and abs(yaw + turn) <= MAX_YAW_RATE_DPS:
            again = {"frames": frames, "fps": fps, "focal_px": camera_focal_px, "binning": binning,
                     "velocity_mps": velocity_mps, "velocity_sigma_mps": velocity_sigma_mps}
            return self._turn_back(again, yaw, turned, yaw_pass, finish)
        return finish()

    def _finish(self, res: DispersionResult, signal: np.ndarray, p: dict[str, Any] | None,
                arr: np.ndarray, fps: float, focal_px: float, prior: Any, lattice: int, *,
                measure: bool, turn: float | None, yaw: float, binning: int) -> DispersionResult:
        """The fit ``res`` of ``signal`` (periodogram ``p``) of frames ``arr`` (turned back at
        ``yaw``, binned ``binning``; ``turn``: the turn its tiles show) finished and judged."""
        rolling = ROLLING.get()
        if rolling is not None and res.n_modes > 0:
            # A rolling shutter: fitted again, each row's delay undone (_rolled_share_table)
            scale = focal_px / (res.altitude_m * fps)  # m/s -> px/frame
            ROLLING.set((rolling[0], tuple(v * scale for v in res.camera_velocity_mps)))
            res, signal, p = self._fit(arr, fps, focal_px, prior, lattice)
        # the tiles: to measure a tilt (over the whole range where the fit holds no shell's
        # peak: a tilt may have smeared it, _level), and to judge a fit that passes the rest
        level = self.attitude == "level"
        fit_focal, fit_signal = focal_px, signal  # of the view fitted (a levelled view's own)
        wanted = self._distrust(res) is None if level else self._holds_shell(res, prominent=False)
        fits, weak = (self._corner_fits(signal, res, fps, focal_px, p,
                                        not self._holds_shell(res)) if wanted else ([], []))
        if not level:
            res, fits, p, fit_focal, fit_signal = self._level(arr, fps, focal_px, prior, res,
                                                              fits, p, lattice, signal, weak)
            if res.attitude_deg is None:
                res.reason = (self._unmeasured_tilt(fits, res, focal_px, arr.shape[1:3])
                              or res.reason)
        res.mode = "blind" if prior is None else "prior" if prior[2] > 0 else "exact"
        if self._distrust(res) is None:
            res.reason = (self._tile_verdict(fits, res)
                          or self._radial_verdict(fits, res, fit_signal, fps, fit_focal, p))
        if self._distrust(res) is None and "+carried" not in res.signal:
            res.reason = self._rigid_verdict(p and p.get("_fitted", p), res, fps, fit_focal)
        if (measure and self._distrust(res) is None
                and (turn is not None or fit_signal is not signal)):
            # a turn the passes left (or that a levelled view shows): not modelled
            turn = self._measured_turn(p, fit_signal, fps)
            if turn is not None:
                res.reason = turn_shown(turn)
        shake = p.get("shake") if p is not None else None
        res.shake_px = (0.0 if shake is None  # in the frames' own px, not the binned ones
                        else binning * float(np.sqrt(np.mean(shake**2))))
        if prior is not None and shake is not None:
            # The frames were steadied (:mod:`.jitter`): the camera rolled or pitched over the
            # clip, and the rotation's mean rate, which no steadying sees, moves the image
            # as a velocity over the water would, which a velocity given does not hold (the
            # first thing to mend, whatever else the fit shows).
            res.reason = (f"the camera shook by {res.shake_px:.1f} px "
                          f"over the clip, and its turn moves the image as a velocity would "
                          f"(give its attitude, or fit blind)")
        res.signal += "+unturned" if yaw != 0.0 else ""
        res.signal += f"+binned{binning}" if binning > 1 else ""
        res.yaw_rate_dps = yaw
        return self._judge(res)

    def _fit(self, arr: np.ndarray, fps: float, focal_px: float,
             prior: tuple[float, float, float] | None, lattice: int = BLOCK_PERIOD_PX
             ) -> tuple[DispersionResult, np.ndarray, dict[str, Any] | None]:
        """The fit of the signal(s) of checked frames ``arr`` (:meth:`estimate`), the scalar
        sequence it was made of and that sequence's periodogram (:meth:`_fit_signal`);
        ``prior``: the camera's velocity ``(vx, vy)`` and its sigma (0: exact), None for
        blind; ``lattice``: a block coder's period in ``arr``, px (binned frames: shorter;
        under 2, whole blocks averaged, none)."""
        if self.signal == "auto" and arr.ndim == 4:
            weights, r2 = self._colour(arr)
            if r2 < self.glint_r2:
                # The colour explains little of the luminance: white content (glint) that the
                # luminance's clip leaves in.  The chroma is free of it; a chroma fit that
                # passes every trust test stands.  Else the luminance's fit is tried and the
                # one that passes more of the tests (then the better graded) kept.  A chroma
                # that a block coder's lattice marks (BLOCK_CODED_MIN_EXCESS) is not fitted:
                # the coder quantises it coarsely on its 8-px blocks, which mix the short
                # waves into false shells far below the truth, which can be trusted
                # (docs/dispersion.md, sixteenth session), and the luminance is fitted alone.
                chroma = self._chroma(arr, weights)
                if lattice < 2 or block_excess(chroma, lattice) <= BLOCK_CODED_MIN_EXCESS:
                    res, p = self._fit_signal(chroma, "chroma", fps, focal_px, prior)
                    if self._distrust(res) is None:
                        return res, chroma, p
                    luma = self._luma(arr)
                    alt, p_luma = self._fit_signal(luma, "luma", fps, focal_px, prior)
                    if self._standing(alt) >= self._standing(res):
                        return alt, luma, p_luma
                    return res, chroma, p
        signal, kind = self._signal(arr)
        res, p = self._fit_signal(signal, kind, fps, focal_px, prior)
        return res, signal, p

    def _fit_signal(self, signal: np.ndarray, kind: str, fps: float, focal_px: float,
                    prior: tuple[float, float, float] | None
                    ) -> tuple[DispersionResult, dict[str, Any] | None]:
        """Fit to one scalar ``(T, H, W)`` sequence of ``kind`` (``"luma"``/``"chroma"``), the
        path recorded in the result's ``signal``, and its periodogram (:meth:`_fit_periodogram`;
        None where none can be fitted), whose tiles' series the tile check takes."""
        p = self._fit_periodogram(signal)
        res = self._fit_path(signal, p, fps, focal_px, prior)
        res.signal = f"{kind}/{res.signal or 'corners'}"
        if p is not None and p.get("shake") is not None:
            res.signal += "+steadied"
        return res, p

    def _fit_path(self, signal: np.ndarray, p: dict[str, Any] | None, fps: float,
                  focal_px: float, prior: tuple[float, float, float] | None
                  ) -> DispersionResult:
        """Exact, prior or blind fit to one scalar sequence (:meth:`estimate`) from its
        periodogram ``p``; a result from the whole frame rather than the corner tiles says
        ``signal="full"``."""
        t = signal.shape[0]
        if p is None:
            return self._failed(t)
        if prior is not None and prior[2] == 0:
            res = self._aided(p, t, fps, focal_px, prior[:2])
            if self._shell_seen(res) < (True, TRUSTED_QUALITY) and p["corners"]:
                # A fast drift carries the water across a corner tile within the clip (3 m/s
                # at 3 m: 7.5 px per frame); the whole frame keeps it in view longer
                # (docs/dispersion.md).
                whole = self._periodogram(signal, corners=False)
                alt = self._aided(whole, t, fps, focal_px, prior[:2])
                if self._shell_seen(alt) > self._shell_seen(res):
                    res = alt
                    res.signal = "full"
                    p["_fitted"] = whole  # the periodogram the result is made of
            return res
        use_compiled()  # the prior's and the blind searches score many candidates
        if prior is not None:
            spread = self._prior(p, t, fps, focal_px, prior)
            if self._distrust(spread) is None:
                return spread
        m = self._modes(signal)
        start = (self._phase_step_fit(m, fps, focal_px) if m["kappa"].size >= MIN_FIT_MODES
                 else {})
        if not start:
            return self._failed(t) if prior is None else spread
        if prior is None:
            return self._blind(p, signal, start, fps, focal_px)
        # A prior whose spread moves the altitude (a wide prior, a short clip): the blind
        # search, the prior choosing among the profile's peaks, and a fit whose velocity lies
        # outside the prior not trusted (a current moves the shell the prior's mean assumes).
        vx, vy, sigma = prior
        radius = PRIOR_SIGMAS * sigma
        res = self._blind(p, signal, start, fps, focal_px, (vx, vy, radius))
        off = math.hypot(res.camera_velocity_mps[0] - vx, res.camera_velocity_mps[1] - vy)
        if off > radius:
            res.reason = (f"velocity {off:.2f} m/s from the prior's mean, beyond "
                          f"{PRIOR_SIGMAS:g} sigma")
        if self._distrust(res) is None:
            return res
        # Neither fit trusted: the one that says more (a blind fit outside the prior's disk
        # contradicts the user; else the smaller uncertainty: a narrow prior's is small).
        if off > radius or (spread.altitude_std_m / spread.altitude_m
                            < res.altitude_std_m / res.altitude_m):
            return spread
        return res

    def _blind(self, p: dict[str, Any], signal: np.ndarray, start: dict[str, Any], fps: float,
               focal_px: float, disk: tuple[float, float, float] | None = None
               ) -> DispersionResult:
        """The blind fit (:meth:`_fit_blind`, ``disk``: a prior's) of periodogram ``p`` of
        ``signal``, from the phase-step ``start``, with the water's carried pattern removed
        where there is one.

        Foam, and whatever else floats, rides with the water without dispersion: in the periodogram
        it is a line of phase steps ``-kappa . u`` at the water's own velocity ``u``, which the
        shell of a slower sea (a higher camera) approaches: the profile rises toward the top of the
        range with no peak at the truth.  Where the clip carries a pattern in most of its modes
        (:meth:`_carried_velocity`, ``CARRIED_MIN_RATIO``), it is removed (:meth:`_periodogram`)
        and the profile fitted again; the waves must then confirm that the pattern rode with the
        water, the fit's velocity within ``CARRIED_MATCH_BINS`` of a low mode's periodogram bin of
        the pattern's, else the fit with the pattern left in stands.  Where that match is fine
        enough to tell the water's velocity from a line that crosses the shell
        (``CARRIED_CHECKED_MATCH_PX``: clips of about a second), it alone decides, and a weaker
        pattern (``CARRIED_CHECKED_MIN_RATIO``) is tried too.  A pattern the scored periodogram
        shows is sought again, and removed, in the tiles' values as recorded (``scores=False``): it
        adds to the waves' record, and the ranks of a sum mix its parts.
        """
        t = int(p["frames"])
        u_c, ratio = self._carried_velocity(p, fps, focal_px)
        match = CARRIED_MATCH_BINS * (2.0 * math.pi / t) / BLIND_MAP_KAPPA
        checked = match <= CARRIED_CHECKED_MATCH_PX
        bar = CARRIED_CHECKED_MIN_RATIO if checked else CARRIED_MIN_RATIO
        raw = p
        if ratio >= bar and p["scores"]:  # sought again, and removed, in the values recorded
            raw = self._periodogram(signal, scores=False)
            u_c, ratio = self._carried_velocity(raw, fps, focal_px)
        if ratio >= bar:
            pc = self._periodogram(signal, raw["corners"], u_c, raw, scores=False)
            fit = self._fit_blind(pc, fps, focal_px, start["logh"], -start["u"], disk)
            if math.hypot(*(fit["u"] - u_c)) <= match and (fit["interior"] or not checked):
                res = self._result(pc, fit, t, fps, focal_px)
                res.signal = f"{'corners' if p['corners'] else 'full'}+carried"
                return res
        fit = self._fit_blind(p, fps, focal_px, start["logh"], -start["u"], disk)
        return self._result(p, fit, t, fps, focal_px)

