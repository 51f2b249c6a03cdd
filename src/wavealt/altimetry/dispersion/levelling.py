"""Levelling: a tilted camera's frames turned to the view of a level one at the tilt that
their corner tiles measure, and fitted again (:mod:`.attitude` holds the model)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from wavealt._checks import check_finite_number
from wavealt.altimetry.dispersion.attitude import (
    fit_tilt,
    measures_tilt,
    roll_pitch,
    without_odd_tile,
)
from wavealt.altimetry.dispersion.constants import (
    ATTITUDE_LEVEL,
    ATTITUDE_PASSES,
    ATTITUDE_PRIOR_SD_DEG,
    BLOCK_PERIOD_PX,
    MAX_ATTITUDE_SIGMA_DEG,
    TILE_SCATTER_LEVEL,
    WEAK_TILE_SD_LOG,
)
from wavealt.altimetry.dispersion.result import DispersionResult
from wavealt.altimetry.dispersion.tiles import Tile
from wavealt.altimetry.dispersion.trust import tile_scatter


#: Why a levelled fit is not trusted where the levelled view's tiles do not confirm the tilt
#: and the fit of the frames as given held no shell's peak either.
UNCONFIRMED_TILT = ("the frames were levelled at the tilt their corner tiles showed, and the "
                    "levelled view's tiles do not confirm it (give the camera's attitude)")


def attitude_prior_deg(attitude: str, sigma_deg: float | None) -> float:
    """The prior of a camera's tilt, per axis, degrees, that an altimeter of ``attitude``
    given ``attitude_sigma_deg`` takes: ``ATTITUDE_PRIOR_SD_DEG`` where none is given; a
    ``ValueError`` naming the parameter for one not in ``(0, MAX_ATTITUDE_SIGMA_DEG]`` or
    given with ``attitude="level"`` (which takes the frames as level, with no tilt)."""
    if sigma_deg is None:
        return ATTITUDE_PRIOR_SD_DEG
    if attitude != "estimate":
        msg = (f"attitude_sigma_deg is the prior of a tilt the altimeter measures: give it "
               f"with attitude='estimate', not {attitude!r}")
        raise ValueError(msg)
    return check_attitude_sigma("attitude_sigma_deg", sigma_deg)


def check_attitude_sigma(name: str, value: Any) -> float:
    """``value`` as the prior of a camera's tilt, degrees per axis, in ``(0,
    MAX_ATTITUDE_SIGMA_DEG]`` (the tilts the tiles can measure); a one-line ``ValueError``
    naming ``name`` (the parameter or the flag it came in) otherwise.  The library, the
    command line and the benchmarks take it through this one check."""
    x = check_finite_number(name, value)
    if not 0.0 < x <= MAX_ATTITUDE_SIGMA_DEG:
        msg = f"{name} must be in (0, {MAX_ATTITUDE_SIGMA_DEG:g}] degrees; got {x:g}"
        raise ValueError(msg)
    return x


class _Level:
    """The levelling pass of :class:`DispersionAltimeter` (uses ``_fit``, ``_holds_shell``,
    ``_corner_fits`` and ``attitude_sigma_deg``)."""

    @property
    def _attitude_prior_sd(self) -> float:
        """The prior of the tilt (``attitude_sigma_deg``) as the standard deviation of each
        of the sea normal's parts ``(a, b)`` (the sine of a tilt along each axis)."""
        return math.sin(math.radians(self.attitude_sigma_deg))

    def _level(self, arr: np.ndarray, fps: float, focal_px: float,
               prior: tuple[float, float, float] | None, res: DispersionResult,
               fits: list[Tile], p: dict[str, Any] | None,
               lattice: int = BLOCK_PERIOD_PX, signal: np.ndarray | None = None,
               weak: list[Tile] | tuple[()] = ()
               ) -> tuple[DispersionResult, list[Tile], dict[str, Any] | None, float,
                          np.ndarray | None]:
        """The fit of frames ``arr`` levelled at the tilt their corner tiles show, its tiles,
        periodogram, focal length and the scalar sequence fitted; ``res``, ``fits``, ``p``,
        ``focal_px`` and ``signal`` where they show none.

        A tilted camera sees the sea at a scale that changes across the frame
        (:mod:`.attitude`), which the fit, made for one scale, reads as an average of them
        (high) and as a smeared shell.  Where the tiles' altitudes fit the tilted model
        significantly better than the level one (``ATTITUDE_LEVEL``), the frames are turned
        to the view of a level camera at the tilt measured (:class:`wavealt.camera.NadirView`
        of a pinhole centred on the frame) and fitted again, and the levelled view's own
        tiles measure what tilt is left, up to ``ATTITUDE_PASSES`` times.  A tilt beyond
        ``camera.MAX_TILT_DEG`` ends the passes, and so does a levelled fit without wave
        signal.  A levelled fit with wave signal but no prominent peak is read (not trusted)
        even where the fit before it held one: the tilt the tiles show biases that fit
        toward the far side's scale, and the levelled view, resampled, flattens the peak
        (``docs/dispersion.md``, forty-second session).
        A tilt can smear the shell away (10-15 degrees change the scale by 20-30 % across
        the frame): a fit with wave signal but no prominent peak has its tiles searched
        over the whole range (each sees a fraction of the smear, :meth:`_corner_fits`), and
        the view they call level is read (not trusted without a prominent peak of its
        own).  Where fewer than three tiles hold the shell, the weak tiles (``weak``: those of
        the frames as given, :meth:`_corner_fits`) join them to measure the tilt: the near
        side of a tilted camera's sea is faint.  A tile that no attitude explains measures no
        tilt (:func:`.attitude.without_odd_tile`).  The tilt's uncertainty joins the levelled
        fit's: the focal length of the level view is ``f cos(tilt)``, and where the tiles
        are not placed and weighted symmetrically their mean moves with the tilt
        (:meth:`.attitude.TiltFit.extra_var_log`).
        The tilted model is kept only where the levelled view's tiles then read one scale
        (the scatter of those that hold the shell within their noise at ``ATTITUDE_LEVEL``,
        :func:`~.trust.tile_scatter`) and are placed to see the tilt made (at least two,
        measuring it along its direction better than the prior ``attitude_sigma_deg``,
        :func:`.attitude.measures_tilt`): a tilt that one tile's wrong peak made does not
        level the frames, and those are judged as given (``docs/dispersion.md``) where
        their fit held a shell's peak; where it held none, the levelled fit is kept, not
        trusted (``UNCONFIRMED_TILT``).
        """
        from wavealt.camera import MAX_TILT_DEG, NadirView, pinhole, tilt_rotation

        h, w = arr.shape[1:3]
        given = res, fits, p, focal_px, signal
        focal, rot, made, faint, made_from = focal_px, np.eye(3), None, False, None
        for _ in range(ATTITUDE_PASSES):
            seen = _measuring(fits, weak)
            # a tile that no attitude explains measures no tilt (its peak is not the shell)
            kept = without_odd_tile(seen, focal, TILE_SCATTER_LEVEL)
            step = fit_tilt(kept, focal)
            if (step is None or not step.significant(ATTITUDE_LEVEL)
                    or not step.fits(ATTITUDE_LEVEL) or step.tilt_deg > MAX_TILT_DEG):
                break
            turned = tilt_rotation(*step.roll_pitch_deg) @ rot
            roll, pitch = roll_pitch(turned)
            if max(abs(roll), abs(pitch)) > MAX_TILT_DEG:
                break
            view = NadirView(pinhole(w, h, focal_px), w, h, roll_deg=roll, pitch_deg=pitch)
            new, s_new, p_new = self._fit(view(arr), fps, view.focal_px, prior, lattice)
            if not self._holds_shell(new, prominent=False):  # no wave signal
                break
            made_from = _doubted(kept, fits), focal  # the step's tiles, for its uncertainty
            rot, res, focal, made, p, signal = turned, new, view.focal_px, step, p_new, s_new
            faint = faint or len(seen) > len(fits)
            res.signal += "+levelled" + ("+faint" if faint else "")
            res.attitude_deg = (roll, pitch)
            fits, weak = self._corner_fits(signal, res, fps, focal, p, not self._holds_shell(res))
        if made is None:
            return res, fits, p, focal, signal
        seen = _measuring(fits, weak)
        if (tile_scatter([f[2:] for f in fits], ATTITUDE_LEVEL) > 0.0
                or not measures_tilt(seen, focal, self._attitude_prior_sd,
                                      tuple(rot[2, :2]))):
            # the levelled view's tiles do not read one scale either, or cannot see the tilt
            # made (two in a row, a tilt across it): the tilt measured was not shown to be
            # the frames' (one tile's peak off the shell, its sigma too small) and the frames
            # are judged as given, unless their fit held no shell's peak either: then the
            # view the tiles call level is read, and not trusted
            if self._holds_shell(given[0]):
                return given
            if self._holds_shell(res):
                res.reason = res.reason or UNCONFIRMED_TILT
            return res, fits, p, focal, signal
        # the tilt's uncertainty, a weak tile's peak taken as possibly off the shell: the
        # levelled view's tiles, else those of the last step made
        last = fit_tilt(_doubted(seen, fits), focal) or fit_tilt(*made_from) or made
        theta = math.acos(min(float(rot[2, 2]), 1.0))
        var = last.extra_var_log() + math.tan(theta) ** 2 * last.tilt_var_rad()
        res.altitude_std_m = res.altitude_m * math.sqrt(
            (res.altitude_std_m / res.altitude_m) ** 2 + var)
        return res, fits, p, focal, signal


def _doubted(seen: list[Tile], fits: list[Tile]) -> list[Tile]:
    """The tiles ``seen`` with the weak ones' (those not in ``fits``) sigma widened by
    ``WEAK_TILE_SD_LOG``: a weak tile's peak may lie off the shell anywhere within the
    reach of a tilt, where its own sigma says nothing of how far."""
    return [t if t in fits else (*t[:3], math.hypot(t[3], WEAK_TILE_SD_LOG)) for t in seen]


def _measuring(fits: list[Tile], weak: list[Tile] | tuple[()]) -> list[Tile]:
    """The tiles that measure a tilt: those that hold the shell (``fits``), and the weak
    ones (``weak``, :meth:`~.tiles._Tiles._corner_fits`) too where fewer than three do."""
    return fits if len(fits) >= 3 else [*fits, *weak]
