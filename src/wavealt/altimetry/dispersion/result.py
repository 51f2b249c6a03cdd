"""The dispersion altimeter's result: altitude, uncertainty, velocity and trust."""

from __future__ import annotations

import re
from collections import Counter
from collections.abc import Iterable
from dataclasses import asdict, dataclass, field
from typing import Any

#: A measured figure inside a reason: a decimal, or a whole number of per cent (signed).
_FIGURE = re.compile(r"[+-]?\d+\.\d+|[+-]?\d+(?= ?%)")


def reason_class(reason: str | None) -> str | None:
    """The kind of a reason for distrust, its measured figures replaced by ``N`` (counts and
    names kept): ``"3-sigma uncertainty 12 % of the altitude"`` and ``"... 31 % ..."`` are
    one kind, ``"3-sigma uncertainty N % of the altitude"``; None for None."""
    return None if reason is None else _FIGURE.sub("N", reason)


def reason_counts(reasons: Iterable[str | None]) -> dict[str, int]:
    """How many of ``reasons`` are of each kind (:func:`reason_class`), the most frequent
    first (ties by kind); a missing reason counts as ``"no reason given"``."""
    counts = Counter(reason_class(r) or "no reason given" for r in reasons)
    return dict(sorted(counts.items(), key=lambda kv: (-kv[1], kv[0])))


def refuse(result: dict[str, Any], reason: str,
           altitude_range_m: tuple[float, float]) -> dict[str, Any]:
    """``result`` (a :meth:`DispersionResult.to_dict`), in place and returned: NOT TRUSTED
    for ``reason``, its 3-sigma interval spanning ``altitude_range_m`` as the altimeter's
    untrusted results' do, where it was trusted; unchanged where it was not (its own reason
    stands).  For the verdicts a caller adds on what the altimeter could not see (the
    vehicle's motion, a video codec's predictions)."""
    if result.get("trusted"):
        lo, hi = altitude_range_m
        result["trusted"], result["reason"] = False, reason
        result["altitude_std_m"] = max(float(result["altitude_std_m"]), (hi - lo) / 3.0)
    return result


@dataclass
class DispersionResult:
    """The outcome of one dispersion fit.

    Attributes
    ----------
    altitude_m : float
        Estimated camera altitude above the mean sea surface, metres.
    altitude_std_m : float
        One-sigma uncertainty of ``altitude_m``, metres (large when the fit is poor).
    camera_velocity_mps : tuple of float
        ``(vx, vy)``: the camera's velocity relative to the water surface along image +x
        (columns) and +y (rows), m/s; the same convention as the ``velocity_mps`` that
        :meth:`DispersionAltimeter.estimate` takes.  A camera hovering over water that
        drifts at ``c`` has ``-c``.
    quality : float
        In [0, 1]: relative prominence of the wave shell's peak, discounted for a large
        relative uncertainty.
    trusted : bool
        Whether the estimate may be used (an autopilot link sends an untrusted one as a
        dropout, never as a reading).
    reason : str or None
        Why it is not trusted (None when trusted).
    mode : {"blind", "prior", "exact"}
        Velocity unknown; a prior on it (``velocity_sigma_mps > 0``); known exactly.
    frames : int
        Number of frames used.
    n_modes : int
        Number of spatial modes in the final fit.
    signal : str
        The scalar sequence fitted (``"luma"`` or ``"chroma"``) and the tiles it was
        transformed on (``"corners"`` or ``"full"``), e.g. ``"chroma/corners"``; a blind fit
        from which a pattern carried with the water (foam) was removed adds ``"+carried"``;
        one made on frames levelled at a tilt the altimeter measured adds ``"+levelled"``,
        and ``"+faint"`` where faint corner tiles (below the bar a tile's shell must clear)
        helped to measure it; frames turned back at a yaw rate adds ``"+unturned"``, at one
        the tiles measured ``"+yaw"``; a fit of the frames as they are, kept where turning
        them back at the rate the tiles showed lost the shell or needed a tilt that the
        frames as they are do not, ``"+turn-refuted"``.
    attitude_deg : (float, float) or None
        ``(roll, pitch)``, degrees (:func:`wavealt.camera.tilt_rotation`'s convention), at
        which the altimeter levelled the frames before this fit, measured from the scales of
        the frames' corner tiles; None where the frames were fitted as given.
    shake_px : float
        The root mean square, px, of the image shift per frame that a shaking camera gave
        the frames' corner tiles and that was taken out before the fit (:mod:`.jitter`;
        ``signal`` adds ``"+steadied"``); 0 where none was.
    """

    altitude_m: float
    altitude_std_m: float
    camera_velocity_mps: tuple[float, float]
    quality: float
    trusted: bool
    reason: str | None
    mode: str
    frames: int
    n_modes: int
    signal: str = ""
    attitude_deg: tuple[float, float] | None = None
    yaw_rate_dps: float = 0.0
    shake_px: float = 0.0
    #: How far the shell's peak stands above the score of random phase steps, in standard
    #: deviations of it (``MIN_SIGNIFICANCE``); internal to the trust decision.
    significance: float = field(default=0.0, repr=False, compare=False)

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-able dict (floats, ints, a two-item list for the velocity)."""
        d = asdict(self)
        d["camera_velocity_mps"] = [float(v) for v in self.camera_velocity_mps]
        for key in ("altitude_m", "altitude_std_m", "quality"):
            d[key] = float(d[key])
        d["trusted"] = bool(self.trusted)
        if self.attitude_deg is not None:
            d["attitude_deg"] = [float(v) for v in self.attitude_deg]
        del d["significance"]
        return d
