"""Physics-based altimeter: fit the wave dispersion relation to a short frame sequence.

A nadir pinhole camera at ``altitude_m`` images a sea wave of physical wavenumber ``k``
(rad/m) at pixel wavenumber ``kappa = k * altitude_m / focal_px`` (rad/px).  Deep-water
waves obey ``omega^2 = g k + (sigma/rho) k^3`` (Lamb 1932, §266; the capillary term matters
only below a few centimetres; over water ``d`` deep it takes the factor ``tanh(k d)``,
:mod:`.waves`), and water moving at ``w`` relative to the camera Doppler shifts every mode,
so the phase of mode ``kappa`` advances per frame by

    psi(kappa) = ( s * omega(|kappa| focal_px / altitude_m) + kappa . u ) / fps,    (1)

with ``s = +1`` for a wave travelling along ``+kappa`` and ``-1`` against it, and
``u = w focal_px / altitude_m`` the water's image velocity in px/s.  In the gravity regime
``omega = a sqrt(|kappa|)`` with ``a^2 = g focal_px / altitude_m`` (Spencer, Shah & Guha,
IEEE TIP 2006, recovered image scale this way).

The estimator tabulates, for every spatial mode of the frame's four corner tiles (where the
image is closest to linear in slope), the share of its temporal energy that one travelling
wave explains as a function of the phase step per frame (a whitened, sharpened periodogram
of the mode's complex amplitudes over the clip), and scores a candidate
``(altitude_m, u)`` by the mean share at the phase steps eq. (1) predicts.  Each tile's
values are first replaced by the normal scores of their ranks (Gaussian anamorphosis,
:func:`.signal.normal_scores`): the sky's radiance along its gradient, Fresnel's reflectance,
the sensor's gamma and clipping record the waves' Gaussian slopes through monotone
non-linear steps, whose harmonics and products lie off the shell, and the ranks undo any
monotone step at once.  Near nadir a camera also records the square of the slope, whose sum and
difference products of wave pairs fill each mode's periodogram off its shell and pull a
short clip's peak (a square is not monotone: no ranks undo it); each mode's
explained energy is taken less the products' expected share, predicted from the frames'
own space-time covariance and skewness (:mod:`.continuum`).  A tile's window admits into
each mode the waves of about a bin and a half around it, and on a sea whose spectrum falls
with the wavenumber the longer ones weigh more: each mode is placed at its waves'
power-weighted centroid, not at its bin's centre (:mod:`.leakage`).  The searches:

* **exact** (the camera's velocity over the water known, e.g. from satellite navigation):
  a scan over log altitude and the most *prominent* peak of it, refined on a fine grid.
  The scan weighted by how far each mode turns over the clip (a mode that stands still
  holds only the optics' slow products) chooses the first peak; the plain scan's own peak
  is refined too, since the weighting leans on the short modes, which the square's sum
  products fill.  A later peak is kept where it shows the shell better: trusted and more
  prominent, or significant where the first is not (away from the ends of the range);
* **blind** (velocity unknown): a per-mode phase-step fit (cross-spectra of consecutive
  frames, Gauss–Newton with Tukey weights on ``(log altitude, u)``) gives a start, and the
  altitude is the most prominent significant peak of the score's *profile* over log
  altitude, the velocity re-fitted at every altitude, from x1.5 of the start down to the
  lowest altitude the frame rate can test (below it nearly every mode's predicted phase
  step wraps, and a free velocity fits noise).  The phase-step fit alone is exact on imagery
  linear in slope but biased on rendered frames, whose non-linear optics (Fresnel, glint)
  add difference-frequency products that move slower than the waves; the profile needs a
  clip long enough to resolve them (about 1 s).  They fill the bottom of the wavenumber
  band, where with the velocity free a slower shell plus more drift fits them, so the
  profile's peak is refined on the modes above it (an ideal camera linear in slope shows
  no such pull).  Foam and floating matter ride with the water without dispersion: a
  line of phase steps ``kappa . u / fps`` (eq. (1) without the wave) that the shell of a
  higher camera approaches, lifting the profile toward the top of the range.  Where most
  modes carry such a pattern it is removed from the periodogram (each mode's
  least-squares component at that step) before the profile, and the result kept where
  the waves' velocity confirms the pattern's.  A floating pattern adds to the waves'
  record, so it is sought and removed in the tiles' values as recorded (the ranks of a
  sum would mix its parts).

With a velocity *prior* (the camera's velocity known to within ``sigma``: a vehicle's
navigation, the water's current unknown) exact fits at velocities spread over the prior
propagate its uncertainty into the altitude's; where the altitude then moves too much with
the velocity to be trusted, the blind search runs, the prior choosing among its profile's
peaks the first significant one whose velocity lies within ``3 sigma`` of it.  A blind fit
that is not trusted gives way to the prior's own fit where its velocity lies beyond that
disk or its uncertainty is the larger, so a result never carries a velocity the prior
excludes.

Every result carries a trust decision (:meth:`DispersionAltimeter._judge`): the shell's
peak must stand out of what random phase steps would give (significance), be prominent in
the altitude scan (quality; blind, its prominence must also exceed five standard
deviations of the profile's noise), have a 3-sigma interval within 10 % of the altitude,
and lie inside the altitude range searched; and the waves must explain the clip's motion
better than a still pattern carried rigidly across the image (phase steps ``-kappa . u``
with no dispersion) does, which with a velocity given otherwise makes a sharp peak where
the shell crosses that line.  The uncertainty is the spread of the peak
over bands of wavenumber (the true shell gives one altitude at every wavenumber; the
optics' products do not; blind, each band weighted by its peak's curvature, as in the summed
profile) plus a systematic term: a floor; blind, at least a part of the
stretch of the ridge that the peak does not beat by one standard error of its per-mode
differences (a paired test: where drift trades against altitude the ridge is flat, and a
small bias moves the peak along it); and, velocity known, the part of a periodogram bin
(``2 pi / T`` a frame) that the clip's phase steps resolve at the estimate.  An untrusted
window's interval spans the whole range.  The blind profile is the
score maximised over the velocity, so a point the continuation leaves below both of its
neighbours is searched again from theirs.
Glint is first clipped (per-pixel spikes far above the sequence's robust spread), or
removed with the colour (chroma) signal.  A rolling shutter whose readout time is given
(``readout_s``) is undone in a second fit: each periodogram column takes the rows' phases
back by the delay at its own phase step, unwrapped at the first fit's Doppler line.

A camera that does not look straight down sees the sea at a scale that changes across the
frame.  The four corner tiles, each fitted alone (:mod:`.tiles`), measure it: over a level
sea a pinhole tilted so that the sea's normal is ``(a, b, c)`` in its axes reads ``H (f /
d_z)^1.5`` at pixel ``(x, y)``, ``d_z = a x + b y + c f`` (:mod:`.attitude`).  Where the
tiles' altitudes fit that model significantly better than one scale, and within their noise and the
oblique view's stretch (:func:`.attitude.stretch_var_log`; one tile's wrong peak fits
neither), the frames are levelled at the tilt
(:class:`wavealt.camera.NadirView`, :mod:`.levelling`) and fitted again, and the result
records the attitude.  A tilt of 10-15 degrees can smear the whole frame's shell below a
prominent peak; the tiles, each seeing a fraction of the smear, are then searched over the
whole range, and where the fit as it stands holds no shell the levelled view is read.
Where fewer than three tiles hold the shell, tiles whose peak stands out less (the near side
of a tilted camera's sea is faint) help to measure the tilt, and judge nothing.
Where the tiles that hold the waves lie on one side of the frame, nothing measures a tilt
toward the other side (nor any tilt where no tile holds them alone), and with the attitude
unknown a prior tilt's part there joins the uncertainty: the prior is the caller's
(``attitude_sigma_deg``, a gimbal's error; by default a tilt anywhere the tiles can measure),
and a levelled view is kept only where its tiles measure the tilt better than the prior.
The fit must also read what those tiles read: it is made of them.  The corners lie at one
distance from the frame's centre, so a lens whose distortion changes the scale with that
distance moves all four alike, and the fit reads their scale.  Tiles at the middle of each
side lie nearer the centre; where their mean reads another scale than the corners' beyond
the noise of the difference, the change, carried on the square of the distance to the
centre (a lens's first radial term), joins the uncertainty (:func:`.tiles.radial_offset`).
A tilt changes the scale linearly across the frame, alike in both means; the centre itself,
seen along the surface normal, shows the optics' products and is not read.

A camera that turns about its axis carries the water past each corner tile its own way.  The
difference of two tiles' phase steps on a mode holds the turn and nothing of the waves
(:mod:`.yaw`); where the tile pairs show a turn, the frames are turned back at it
(:func:`wavealt.camera.unturn_yaw`) and fitted again, and a turn still shown is not
trusted.  The tiles' phase steps also part where the image moves unevenly over the frame
without a turn (a shear): where the frames turned back hold no shell and the frames as they
are hold one, more significant, the turn is refuted and the still fit kept (:mod:`.turn`).
A yaw rate given is taken as the truth.

A camera that rolls and pitches back and forth (no gimbal) moves the whole image by a
shift that changes from frame to frame.  Every mode of a tile moves with it, so each
mode's phase step departs from its steady one by ``-kappa . (s_{t+1} - s_t)``, one
regression per frame over the modes (:mod:`.jitter`); where the four corner tiles agree on
the shift, each tile is moved back by it before it is windowed for the periodogram
(``+steadied``; the shift that remains is read on the moved tiles and added,
:func:`.jitter.steady_tiles`), with a rotation about the image centre where the tiles show
one (a heading that wavers: each tile then moves along its own tangent,
:func:`.jitter.remove_motion`).  The shift read is off by the tiles' own noise: a trusted
steadied fit is made again with it one realisation of that noise off, either way (the tiles'
shifts contrasted + - - + over the corners, which a shared shift and a rotation both cancel:
:func:`.jitter.shake_noise`), and the larger change joins its uncertainty (:mod:`.turn`).
The rotation's mean rate over the clip moves the image as a drift does, which a blind fit
takes into its velocity and a velocity given does not hold: exact and prior fits of
steadied frames are not trusted.  The same measurement on frames as they came
(:func:`image_shake`, :mod:`.shake`) serves a caller that levels each frame at an attitude
measured elsewhere and must know when each frame was taken (:mod:`wavealt.live.latency`).

References: Young, Rosenthal & Ziemer (J. Geophys. Res. 1985), dispersion-shell fits to
image sequences; Senet, Seemann & Ziemer (IEEE TGRS 2001), the shell and its harmonics;
Serafino, Lugni & Soldovieri (IEEE GRSL 2010), normalised scalar products with the shell;
Spencer, Shah & Guha (IEEE TIP 2006), image scale from dispersion.
"""

from typing import Any

# The names of the module this package was (importers, tests and monkeypatches use them).
from wavealt.altimetry.dispersion.altimeter import (  # noqa: F401
    DispersionAltimeter,
    _one_blas_thread,
)
from wavealt.altimetry.dispersion.constants import (  # noqa: F401
    DEGLINTS,
    DISPERSIONS,
    EDGE_FACTOR,
    FULL_CLIP_FRAMES,
    MAX_TRUSTED_3SIGMA,
    MIN_FRAMES,
    MIN_SIGNIFICANCE,
    SD_FLOOR_LOG,
    SIGNALS,
    TILES,
    TRUSTED_QUALITY,
)
from wavealt.altimetry.dispersion.result import DispersionResult, reason_class
from wavealt.altimetry.dispersion.search import (  # noqa: F401
    _most_prominent,
    _parabolic_peak,
    peak_prominences,
)
from wavealt.altimetry.dispersion.signal import (  # noqa: F401
    _clip_outliers,
    _has_texture,
    _robust_level,
    _to_gray,
    deglint,
)
from wavealt.altimetry.dispersion.spectra import (  # noqa: F401
    _corners,
    _fast_len,
    _hann2d,
    _sharpen,
    _windowed_modes,
    _wrap,
)
from wavealt.altimetry.dispersion.shake import image_shake
from wavealt.altimetry.dispersion.warm import warm_up


def estimate_altitude(frames: Any, *, fps: float, focal_px: float,
                      velocity_mps: tuple[float, float] | None = None,
                      velocity_sigma_mps: float = 0.0, readout_s: float = 0.0,
                      yaw_rate_dps: float | None = None, **kw: Any) -> DispersionResult:
    """Convenience: ``DispersionAltimeter(**kw).estimate(frames, fps=, focal_px=,
    velocity_mps=, velocity_sigma_mps=, readout_s=, yaw_rate_dps=)``."""
    return DispersionAltimeter(**kw).estimate(frames, fps=fps, focal_px=focal_px,
                                              velocity_mps=velocity_mps,
                                              velocity_sigma_mps=velocity_sigma_mps,
                                              readout_s=readout_s, yaw_rate_dps=yaw_rate_dps)


__all__ = ["DISPERSIONS", "DispersionAltimeter", "DispersionResult", "deglint", "image_shake",
           "estimate_altitude", "reason_class", "warm_up"]
