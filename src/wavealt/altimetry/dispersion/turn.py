"""A turn the corner tiles show, taken back: the frames turned at the rate measured and fitted
again, and the turn refuted where the frames turned back lose the shell the frames as they
are hold.  And a shake the tiles show, whose own error is carried into the uncertainty of
the fit it steadied."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from wavealt.altimetry.dispersion.constants import YAW_PASSES
from wavealt.altimetry.dispersion.jitter import SHAKE_OFF
from wavealt.altimetry.dispersion.result import DispersionResult
from wavealt.altimetry.dispersion.spectra import ROLLING
from wavealt.camera import MAX_YAW_RATE_DPS


#: How the reason of a fit whose corner tiles show a turn begins (:func:`turn_shown`).
TURN_SHOWN = "the camera turned"


def turn_shown(rate_dps: float) -> str:
    """The reason a fit is not trusted whose corner tiles show the camera turning at
    ``rate_dps`` about its axis (a turn the yaw passes left, or that a levelled view shows)."""
    return f"{TURN_SHOWN} {rate_dps:+.1f} deg/s about its axis over the clip (give its yaw rate)"


class _Turn:
    """The yaw passes of :class:`DispersionAltimeter`, and a steadied fit's shake error
    (uses ``_estimate``, ``_estimate_at``, ``_holds_shell``, ``_rate_uncertain``)."""

    def _turn_back(self, again: dict[str, Any], yaw: float, turned: tuple[float, float],
                   yaw_pass: int, still: Callable[[], DispersionResult]) -> DispersionResult:
        """The fit of the frames ``again`` (``_estimate``'s arguments) turned back at the
        rate ``yaw`` they were fitted at plus the turn their tiles show, ``turned = (rate,
        its standard error)``, deg/s; ``still()`` finishes the fit at ``yaw``.

        The corner tiles show the camera turning about its axis: each sees the water carried
        its own way, which one velocity does not fit.  The frames are turned back at the
        rate measured and fitted from the start, as a levelling pass takes out a tilt.  Where
        the frames turned back hold no shell's peak (significant and prominent:
        :meth:`_holds_shell`) and the frames as they are hold one and explain the waves
        better (a higher significance against random phase steps), the turn is refuted:
        the tiles' phase steps also part where the image moves unevenly over the frame
        without a turn (a shear, one direction's velocity changing across the frame and the
        other's not), and turning a still camera's frames back at the rate the tiles then
        read smears the shell they hold.  The fit at ``yaw`` is then finished and kept.  It
        is not trusted while its tiles show the turn (its finish judges that), so the test
        decides the altitude read, not the trust.
        A turn is refuted too where the frames turned back hold the shell only levelled and
        the frames as they are hold it without a tilt.  A rate off by ``d`` moves each
        corner tile's image by ``d`` times its lever, opposite at opposite corners, which
        the tiles, fitted at one velocity, read as scales that change linearly across the
        frame: a tilt's pattern.  A real turn shows that pattern in the frames as they are
        and loses it turned back; a turn measured where there is none puts it into the
        frames turned back, and the levelling reads it as a tilt (``docs/dispersion.md``,
        forty-fifth session).  Neither turn nor tilt is then needed to explain the frames as
        they are.
        """
        saved = ROLLING.get()  # a pass's rolling-shutter fit sets its own
        res = self._estimate(**again, yaw_rate_dps=yaw + turned[0], yaw_pass=yaw_pass + 1)
        res.signal += "" if "+yaw" in res.signal else "+yaw"
        off = res.yaw_rate_dps + turned[1]  # the rate one standard error further
        if yaw_pass == 0 and res.trusted and abs(off) <= MAX_YAW_RATE_DPS:
            res = self._rate_uncertain(res, self._estimate(**again, yaw_rate_dps=off,
                                                           yaw_pass=YAW_PASSES))
        if self._holds_shell(res) and res.attitude_deg is None:
            return res
        ROLLING.set(saved)
        kept = still()
        if not self._holds_shell(kept):
            return res
        if self._holds_shell(res):
            # levelled: the turn and the tilt it left are one pattern (see above), refuted
            # where the frames as they are pass every test but the turn's, unlevelled
            refuted = kept.attitude_deg is None and (kept.reason or "").startswith(TURN_SHOWN)
        else:
            refuted = kept.significance > res.significance
        if refuted:
            kept.signal += "+turn-refuted"
            return kept
        return res

    def _shake_uncertain(self, res: DispersionResult, frames: np.ndarray, binning: int,
                         readout_s: float, kw: dict[str, Any]) -> DispersionResult:
        """``res``, a fit of ``frames`` (``_estimate_at``'s arguments), as it is, or, where
        it is trusted and its tiles were steadied of a shake, judged again with its shake's
        own error in its uncertainty.

        The shake is read on the corner tiles' modes, each tile's reading off by its noise;
        a reading a little off leaves a shake that can still make a shell, away from the
        altitude and with an uncertainty that does not cover it (``docs/dispersion.md``,
        thirty-seventh session).  The frames are fitted again twice, the first reading
        taken one realisation of its noise off (:func:`.jitter.shake_noise`), either way,
        and the larger change of the altitude joins the uncertainty in quadrature in log
        altitude (as a yaw rate's does, :meth:`_rate_uncertain`)."""
        if not (res.trusted and res.shake_px > 0.0) or SHAKE_OFF.get():
            return res
        moved = []
        for sign in (1.0, -1.0):
            token = SHAKE_OFF.set(sign)
            try:
                moved.append(self._estimate_at(frames, binning, readout_s, **kw))
            finally:
                SHAKE_OFF.reset(token)
        worst = max(moved, key=lambda m: abs(math.log(m.altitude_m / res.altitude_m)))
        return self._rate_uncertain(res, worst)
