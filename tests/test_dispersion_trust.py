"""The altimeter's trust contract: what it cannot measure it says so, in every mode.

Properties, not benchmark scenes: inputs without dispersion (noise, a frozen clip, a still
frame carried across the image) are never trusted; a trusted estimate lies within 10 % of
the truth and its 3-sigma interval covers the error; a wrong velocity prior is flagged or
corrected, never confidently wrong.
"""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest
from contract import assert_honest
from scipy.ndimage import map_coordinates

from wavealt.altimetry.dispersion import DispersionAltimeter, DispersionResult
from wavealt.altimetry.dispersion.constants import ATTITUDE_PRIOR_SD_DEG, TILE_SCATTER_LEVEL
from wavealt.altimetry.dispersion.search import weighted_spread
from wavealt.altimetry.dispersion.tiles import radial_offset
from wavealt.altimetry.dispersion.trust import tile_scatter
from wavealt.sim.config import preset_config
from wavealt.sim.generate import generate_sequence

FOCAL_PX = 200.0


def _realistic(h: float, drift_mps: float, seed: int, *, frames: int = 30, size: int = 128):
    cfg = preset_config("realistic", size=size, frames=frames, altitude_m=(h, h),
                        wind_speed_mps=(6.0, 6.0), camera_speed_mps=(drift_mps, drift_mps))
    sc = cfg.sample_scenario(seed)
    return generate_sequence(sc, cfg), sc, cfg


def _paper_slopes(h: float, seed: int, *, size: int = 128):
    cfg = preset_config("paper", size=size, altitude_m=(h, h), wind_speed_mps=(7.0, 7.0),
                        camera_speed_mps=(0.3, 0.3))
    sc = cfg.sample_scenario(seed)
    return generate_sequence(sc, cfg), sc, cfg


def _normalise(x: np.ndarray) -> np.ndarray:
    return ((x - x.min()) / (x.max() - x.min())).astype(np.float32)


@pytest.mark.parametrize("mode", ["exact", "blind"])
@pytest.mark.parametrize(("size", "seed"), [(64, 0), (128, 1), (128, 2)])
def test_colour_noise_is_never_trusted(mode: str, size: int, seed: int) -> None:
    frames = np.random.default_rng(seed).random((12, size, size, 3)).astype(np.float32)
    kw = {"velocity_mps": (0.0, 0.0)} if mode == "exact" else {}
    res = DispersionAltimeter().estimate(frames, fps=30.0, focal_px=0.8 * size, **kw)
    assert not res.trusted
    assert res.mode == mode
    # untrusted: the 3-sigma interval spans the altitude range searched
    lo, hi = DispersionAltimeter().altitude_range_m
    assert 3.0 * res.altitude_std_m >= hi - lo - 1e-9


@pytest.mark.parametrize("mode", ["exact", "blind"])
def test_frozen_waves_are_never_trusted(mode: str) -> None:
    data, sc, cfg = _realistic(4.0, 0.0, 3, frames=12)
    frozen = np.repeat(data.clean[:1], 12, axis=0)
    kw = {"velocity_mps": (0.0, 0.0)} if mode == "exact" else {}
    res = DispersionAltimeter().estimate(frozen, fps=cfg.fps, focal_px=cfg.focal_px, **kw)
    assert not res.trusted


@pytest.mark.parametrize("mode", ["exact", "prior", "blind"])
@pytest.mark.parametrize(("shift", "h", "frames"), [((1, 0), 5.0, 30), ((2, 1), 5.0, 30),
                                                    ((1, 0), 10.0, 10), ((2, 1), 5.0, 10),
                                                    ((1, 3), 5.0, 10), ((1, 3), 10.0, 10)])
def test_a_still_frame_carried_across_the_image_is_never_trusted(mode: str, shift, h: float,
                                                                 frames: int) -> None:
    """Advection without dispersion: one sea frame translated by whole pixels per frame.
    Given the velocity that moves it so at ``h``, a shell crossing the pattern's line of
    phase steps made a sharp, prominent peak (10 frames: 7.6 m read for 10 m, 6.1 for 5;
    with a prior of 0.3 m/s, 11.1 for 10)."""
    data, sc, cfg = _realistic(5.0, 0.0, 4, frames=30)
    still = data.clean[0]
    clip = np.stack([np.roll(still, (t * shift[1], t * shift[0]), axis=(0, 1))
                     for t in range(frames)])
    # the camera's velocity that makes the pattern move so at altitude h
    v = (-shift[0] * cfg.fps * h / cfg.focal_px, -shift[1] * cfg.fps * h / cfg.focal_px)
    kw = ({} if mode == "blind" else
          {"velocity_mps": v, "velocity_sigma_mps": 0.3 if mode == "prior" else 0.0})
    res = DispersionAltimeter().estimate(clip, fps=cfg.fps, focal_px=cfg.focal_px, **kw)
    assert res.mode == mode
    assert not res.trusted
    assert isinstance(res.reason, str) and res.reason


@pytest.mark.parametrize(("h", "drift", "seed"), [(2.0, 0.3, 5), (5.0, 0.5, 3), (6.0, 0.8, 6),
                                                (11.0, 0.5, 7)])
def test_blind_through_the_realistic_renderer_is_honest(h: float, drift: float, seed: int) -> None:
    """Blind, 1 s: every estimate keeps the contract, whether or not it is trusted."""
    data, sc, cfg = _realistic(h, drift, seed)
    est = DispersionAltimeter()
    for frames in (data.clean, data.glinty):
        res = est.estimate(frames, fps=cfg.fps, focal_px=cfg.focal_px)
        assert res.mode == "blind"
        assert_honest(res, h)


@pytest.mark.parametrize(("h", "seed"), [(3.0, 8), (8.0, 9)])
def test_exact_through_the_realistic_renderer_recovers_the_altitude(h: float, seed: int) -> None:
    data, sc, cfg = _realistic(h, 0.4, seed, frames=30, size=256)
    res = DispersionAltimeter().estimate(data.clean, fps=cfg.fps, focal_px=cfg.focal_px,
                                         velocity_mps=sc.camera_velocity_mps)
    assert res.mode == "exact"
    assert_honest(res, h)
    assert abs(res.altitude_m - h) / h < 0.03
    # the camera's velocity over the water comes back as it went in
    assert np.allclose(res.camera_velocity_mps, sc.camera_velocity_mps, atol=1e-6)


@pytest.mark.parametrize("offset_mps", [(1.5, 0.0), (0.0, -2.0)])
def test_a_prior_that_excludes_the_truth_is_not_confidently_wrong(offset_mps) -> None:
    """The prior's mean 1.5-2 m/s from the camera's true velocity over the water, sigma
    0.3 m/s (five sigma and more): flagged, or right."""
    h = 4.0
    data, sc, cfg = _realistic(h, 0.5, 10, frames=10)
    v = np.add(sc.camera_velocity_mps, offset_mps)
    res = DispersionAltimeter().estimate(data.clean, fps=cfg.fps, focal_px=cfg.focal_px,
                                         velocity_mps=tuple(v), velocity_sigma_mps=0.3)
    assert res.mode == "prior"
    assert_honest(res, h)


@pytest.mark.parametrize(("h", "seed", "frames"), [(3.0, 11, 10), (5.0, 3, 30)])
def test_a_prior_widens_the_exact_fit_and_never_returns_a_velocity_outside_it(h, seed,
                                                                              frames) -> None:
    """Same clip: where a prior's result is the exact fit at its mean, its uncertainty is no
    smaller than the exact fit's; a result never carries a velocity beyond 3 sigma of the
    prior's mean (where the blind search finds one, neither fit trusted, the exact fit at
    the mean, which the prior supports, is returned)."""
    data, sc, cfg = _realistic(h, 0.5, seed, frames=frames)
    est = DispersionAltimeter()
    kw = {"fps": cfg.fps, "focal_px": cfg.focal_px}
    exact = est.estimate(data.clean, velocity_mps=sc.camera_velocity_mps, **kw)
    for sigma in (0.05, 1.0):
        for offset in ((0.0, 0.0), (2.0, 0.0)):
            mean = tuple(np.add(sc.camera_velocity_mps, offset))
            prior = est.estimate(data.clean, velocity_mps=mean, velocity_sigma_mps=sigma, **kw)
            assert prior.mode == "prior"
            if offset == (0.0, 0.0) and np.isclose(prior.altitude_m, exact.altitude_m):
                assert prior.altitude_std_m >= exact.altitude_std_m
            off = np.hypot(*np.subtract(prior.camera_velocity_mps, mean))
            assert off <= 3.0 * sigma * (1 + 1e-9)
    # a prior 2 m/s off with sigma 0.05 m/s: the blind search's velocity lies far outside
    far = est.estimate(data.clean, velocity_mps=tuple(np.add(sc.camera_velocity_mps, (2, 0))),
                       velocity_sigma_mps=0.05, **kw)
    assert not far.trusted


def test_exact_short_clips_of_a_high_camera_keep_the_contract() -> None:
    """Exact velocity, 10 frames, 10-15 m, any wind and drift: the waves turn by about a
    periodogram bin over the clip, and no estimate is trusted beyond what that resolves."""
    cfg = preset_config("paper", size=128, frames=10, altitude_m=(10.0, 15.0),
                        wind_speed_mps=(2.0, 12.0), camera_speed_mps=(0.0, 1.0))
    est = DispersionAltimeter(dispersion="gravity")
    for seed in range(40):
        sc = cfg.sample_scenario(seed)
        data = generate_sequence(sc, cfg)
        for frames in (data.clean, data.glinty):
            res = est.estimate(frames, fps=cfg.fps, focal_px=cfg.focal_px,
                               velocity_mps=sc.camera_velocity_mps)
            assert_honest(res, sc.altitude_m)


def _uniform_periodogram(kappa: np.ndarray, frames: int) -> dict:
    """A periodogram whose every mode explains every phase step equally (weights all one),
    its modes along +x."""
    return {"q": np.ones((kappa.size, 64), dtype=np.float32), "kx": kappa,
            "ky": np.zeros_like(kappa), "kappa": kappa, "frames": frames}


def test_the_resolution_of_a_clip_follows_the_dispersion_relation() -> None:
    """The log altitude a periodogram bin spans: (2 pi / T) sum|g| / sum g^2 with
    g = d psi / d log h; a still camera over gravity waves has g = omega / (2 fps), so it
    halves when the clip doubles and grows as sqrt(h); a known drift adds kappa . u to g
    and so resolves more."""
    est = DispersionAltimeter(dispersion="gravity")
    kappa = np.linspace(0.3, 2.5, 50)
    fps, focal_px, h = 30.0, 200.0, 9.0
    u0 = np.zeros(2)
    r10 = est._resolution_log(_uniform_periodogram(kappa, 10), np.log(h), u0, fps, focal_px)
    g = 0.5 * est.omega(kappa * focal_px / h) / fps
    assert r10 == pytest.approx(2.0 * np.pi / 10 * g.sum() / (g**2).sum(), rel=1e-9)
    r20 = est._resolution_log(_uniform_periodogram(kappa, 20), np.log(h), u0, fps, focal_px)
    assert r20 == pytest.approx(r10 / 2.0, rel=1e-9)
    r_high = est._resolution_log(_uniform_periodogram(kappa, 10), np.log(4.0 * h), u0, fps,
                                 focal_px)
    assert r_high == pytest.approx(2.0 * r10, rel=1e-9)
    # the camera moving along +x at 0.1 px per frame (its velocity known): every mode's step
    # moves by kappa u more per unit of log altitude
    drift = est._resolution_log(_uniform_periodogram(kappa, 10), np.log(h),
                                np.array([-0.1, 0.0]), fps, focal_px)
    assert drift < r10
    # no mode that moves with the altitude: nothing to resolve it
    flat = est._resolution_log({**_uniform_periodogram(kappa, 10), "kappa": kappa * 0.0,
                                "kx": kappa * 0.0}, np.log(h), u0, fps, focal_px)
    assert flat == np.inf


def test_squared_slope_imagery_is_not_read_low_and_trusted() -> None:
    """Imagery of the squared slope alone carries the shell's harmonic and the sum-frequency
    products between them, off the shell toward half the altitude: exact fits read 0.79-1.0
    h on these scenes, and every one more than 10 % off says it is not to be trusted."""
    est = DispersionAltimeter(dispersion="gravity")
    for h, seed in ((2.0, 0), (5.0, 1), (9.0, 2), (3.0, 3), (12.0, 4), (1.5, 5)):
        data, sc, cfg = _paper_slopes(h, seed, size=256)
        frames = _normalise(data.slope_x**2 + data.slope_y**2)
        res = est.estimate(frames, fps=cfg.fps, focal_px=cfg.focal_px,
                           velocity_mps=sc.camera_velocity_mps)
        assert_honest(res, h)


def test_bad_prior_arguments_are_refused() -> None:
    frames = np.random.default_rng(0).random((10, 32, 32)).astype(np.float32)
    est = DispersionAltimeter()
    with pytest.raises(ValueError, match="velocity_sigma_mps"):
        est.estimate(frames, fps=30.0, focal_px=FOCAL_PX, velocity_mps=(0.0, 0.0),
                     velocity_sigma_mps=-1.0)
    with pytest.raises(ValueError, match="velocity_mps must be two numbers"):
        est.estimate(frames, fps=30.0, focal_px=FOCAL_PX, velocity_mps=(1.0,))
    with pytest.raises(ValueError, match="velocity_mps must be two numbers"):
        est.estimate(frames, fps=30.0, focal_px=FOCAL_PX, velocity_mps=1.0)


def _fit_result(altitude_m: float, sd_rel: float, *, quality: float = 0.9,
                significance: float = 0.0) -> DispersionResult:
    """A finished fit's result as the trust tests see it (no velocity, not yet judged)."""
    return DispersionResult(altitude_m=altitude_m, altitude_std_m=altitude_m * sd_rel,
                            camera_velocity_mps=(0.0, 0.0), quality=quality, trusted=False,
                            reason=None, mode="blind", frames=30, n_modes=100,
                            significance=significance)


def test_of_two_fits_of_a_window_the_one_that_passes_the_trust_tests_is_kept() -> None:
    """The chroma/luminance choice: a higher grade does not outrank a failed trust test."""
    est = DispersionAltimeter()

    def fit(quality: float, significance: float, rel_sd: float = 0.01) -> DispersionResult:
        return _fit_result(5.0, rel_sd, quality=quality, significance=significance)

    trusted = fit(0.5, 100.0)
    assert est._distrust(trusted) is None
    assert est._standing(trusted) > est._standing(fit(0.9, 10.0))  # not significant
    assert est._standing(trusted) > est._standing(fit(0.9, 100.0, rel_sd=0.05))  # too wide
    assert est._standing(fit(0.2, 100.0)) > est._standing(fit(0.9, 10.0))
    assert "3-sigma" in est._distrust(fit(0.9, 100.0, rel_sd=0.05))


@pytest.mark.parametrize("rel3", [0.085, 0.0950, 0.0956, 0.0999])
def test_a_trusted_interval_holds_no_altitude_more_than_ten_percent_from_the_estimate(
        rel3: float) -> None:
    """The contract is relative to the true altitude: a window whose 3-sigma interval in log
    altitude reaches an altitude that the estimate exceeds by more than 10 % is not trusted
    (at 3 sd = 9.99 %, a truth at the interval's low end is 10.5 % below the estimate)."""
    est = DispersionAltimeter()
    res = _fit_result(5.0, rel3 / 3.0, quality=0.8, significance=100.0)
    low = res.altitude_m * np.exp(-3.0 * res.altitude_std_m / res.altitude_m)
    worst = res.altitude_m / low - 1.0  # the error, were the truth at the interval's low end
    reason = est._distrust(res)
    assert (reason is None) == (worst <= 0.10)
    if reason is not None:
        assert reason.startswith("3-sigma uncertainty")


def _slope_image(h: float, seed: int, *, size: int = 128, frames: int = 10):
    """Frames linear in the slope (an ideal camera) of a paper-preset sea seen from ``h``,
    the camera drifting 0.3 m/s; its velocity over the water and focal length."""
    cfg = preset_config("paper", size=size, frames=frames, altitude_m=(h, h),
                        wind_speed_mps=(7.0, 7.0), camera_speed_mps=(0.3, 0.3))
    sc = cfg.sample_scenario(seed)
    data = generate_sequence(sc, cfg)
    return _normalise(data.slope_x + 0.7 * data.slope_y), sc.camera_velocity_mps, cfg.focal_px


def _through_lens(frames: np.ndarray, focal: float, size: int, k1: float) -> np.ndarray:
    """The centre ``size`` px of a pinhole's ``frames`` (focal length ``focal``) seen
    through a lens of OpenCV's radial distortion ``k1`` with the same focal length: each
    pixel samples the pinhole's image where its ray, undistorted by OpenCV, meets it."""
    big, c = frames.shape[1], (size - 1) / 2.0
    cols, rows = np.meshgrid(np.arange(size, dtype=np.float64),
                             np.arange(size, dtype=np.float64))
    k = np.array([[focal, 0.0, c], [0.0, focal, c], [0.0, 0.0, 1.0]])
    ideal = cv2.undistortPoints(np.stack([cols.ravel(), rows.ravel()], 1)[:, None, :], k,
                                np.array([k1, 0.0, 0.0, 0.0, 0.0]))[:, 0, :]
    x, y = (focal * ideal[:, i] + (big - 1) / 2.0 for i in (0, 1))
    assert min(x.min(), y.min()) >= 0.0 and max(x.max(), y.max()) <= big - 1.0
    return np.stack([map_coordinates(f, [y, x], order=3).reshape(size, size)
                     for f in frames])


@pytest.mark.parametrize(("h", "seed", "k1"), [(4.0, 3, -0.4), (2.5, 7, 0.3)])
def test_a_lens_that_distorts_is_named_not_trusted(h: float, seed: int, k1: float) -> None:
    """A lens's radial distortion changes the image scale with the square of the distance
    from the centre: the four corner tiles read one scale and no tilt, and the fit, made of
    them, reads theirs, trusted before the edges were read.  The same sea through a barrel
    (k1 < 0) or a pincushion lens (exaggerated for a 128-px frame) is not trusted, exact or
    blind, and the reason names the lens, the edges reading toward the centre's scale from
    the corners; the pinhole's frames are trusted and honest."""
    cfg = preset_config("paper", size=256, frames=30, altitude_m=(h, h),
                        wind_speed_mps=(7.0, 7.0), camera_speed_mps=(0.3, 0.3))
    sc = cfg.sample_scenario(seed)
    data = generate_sequence(sc, cfg)
    img = data.slope_x + 0.7 * data.slope_y
    kw = {"fps": cfg.fps, "focal_px": cfg.focal_px}
    est = DispersionAltimeter(dispersion="gravity")
    pinhole = _normalise(img[:, 64:192, 64:192])
    for res in (est.estimate(pinhole, velocity_mps=sc.camera_velocity_mps, **kw),
                est.estimate(pinhole, **kw)):
        assert res.trusted, res
        assert_honest(res, h)
    lens = _normalise(_through_lens(img, cfg.focal_px, 128, k1))
    for res in (est.estimate(lens, velocity_mps=sc.camera_velocity_mps, **kw),
                est.estimate(lens, **kw)):
        assert not res.trusted, res
        assert "a lens that distorts: give its calibration" in res.reason
        said = float(res.reason.split("edges read ")[1].split(" %")[0])
        assert said * k1 > 0.0, res.reason  # barrel: the corners read high, the edges less
        assert_honest(res, h)


def test_the_edges_count_against_the_corners_on_the_square_of_the_distance() -> None:
    """:func:`radial_offset`: edges that read the corners' scale within the noise of the
    difference count nothing; edges far off count the part of the difference beyond that
    noise, carried from the edges' mean squared distance to the centre (the corners' reading
    less the centre's, opposite in sign to the edges' less the corners'), the same wherever
    the scale lies; corners that scatter among themselves make their mean less certain, and
    the same edges count less."""
    rc, re = 2.0, 1.0  # mean squared distances: the corners' reading is twice the difference
    corners = [(rc, 1.5, 0.02)] * 4
    s = math.hypot(0.01, 0.015)  # the corners' mean and the edges'
    edges = [(re, 1.5 + 0.5 * s, 0.03)] * 4
    assert radial_offset(corners, edges) == (0.0, pytest.approx(0.5 * s), pytest.approx(s))
    low = [(re, 1.45, 0.03)] * 4
    off, d, sd = radial_offset(corners, low)
    assert (d, sd) == (pytest.approx(-0.05), pytest.approx(s))
    assert off == pytest.approx(2.0 * math.sqrt(0.05**2 - s**2))
    shifted = [(r2, lg + 2.0, sd_) for r2, lg, sd_ in corners]
    assert radial_offset(shifted, [(re, 3.55, 0.03)] * 4)[0] == pytest.approx(-off)
    scattered = [(r2, lg + dl, sd_) for (r2, lg, sd_), dl
                 in zip(corners, (-0.06, 0.06, 0.06, -0.06))]
    assert tile_scatter([(f[1], f[2]) for f in scattered]) > 0.0
    wide = radial_offset(scattered, low)
    assert wide[1] == pytest.approx(-0.05) and wide[2] > s and abs(wide[0]) < abs(off)


def test_a_frame_whose_halves_show_two_scales_is_not_trusted() -> None:
    """The model holds one image scale over the frame (a level camera).  A frame whose left
    half sees the sea from 4 m and its right half from 5.2 m (the two sides of a tilted
    camera, exaggerated) is not trusted as a level camera's, and says why; the 4-m frame
    alone is.  Where the attitude is estimated, the scale's change across the frame is a
    tilt toward its far (right) side, about the image's vertical axis, and the altitude lies
    between the two sides'."""
    near, v, focal = _slope_image(4.0, 3)
    far, _, _ = _slope_image(5.2, 3)
    est = DispersionAltimeter(dispersion="gravity", attitude="level")
    kw = {"fps": 30.0, "focal_px": focal, "velocity_mps": v}
    level = est.estimate(near, **kw)
    assert level.trusted, level
    assert_honest(level, 4.0)
    split = near.copy()
    split[:, :, 64:] = far[:, :, 64:]
    res = est.estimate(split, **kw)
    assert not res.trusted
    assert "corner tiles" in res.reason
    tilted = DispersionAltimeter(dispersion="gravity").estimate(split, **kw)
    roll, pitch = tilted.attitude_deg
    assert roll < -5.0 and abs(pitch) < 2.0, tilted
    assert 4.0 < tilted.altitude_m < 5.2, tilted


@pytest.mark.parametrize("side", ["top", "left"])
def test_waves_on_one_side_of_the_frame_are_not_trusted_unless_the_camera_is_level(
        side: str) -> None:
    """Where only the tiles on one side of the frame hold the waves (the other side flat, as
    under a sky's glare), nothing in the frame measures a tilt toward the other side: with
    the attitude unknown the altitude is not trusted, and the reason says why; the camera
    declared level, and the whole frame with the attitude unknown, are trusted."""
    near, v, focal = _slope_image(4.0, 3, frames=30)
    kw = {"fps": 30.0, "focal_px": focal, "velocity_mps": v}
    whole = DispersionAltimeter(dispersion="gravity").estimate(near, **kw)
    assert whole.trusted, whole
    one_side = near.copy()
    # one half without waves
    one_side[(slice(None), slice(0, 64)) if side == "top" else (Ellipsis, slice(0, 64))] = 0.5
    level = DispersionAltimeter(dispersion="gravity", attitude="level").estimate(one_side,
                                                                                 **kw)
    assert level.trusted, level
    assert_honest(level, 4.0)
    unknown = DispersionAltimeter(dispersion="gravity").estimate(one_side, **kw)
    assert not unknown.trusted
    assert "too few or too imprecise to measure the camera's tilt" in unknown.reason
    assert "give its attitude" in unknown.reason
    assert unknown.altitude_m == level.altitude_m
    assert_honest(unknown, 4.0)


def test_the_tiles_take_the_fits_mode_series_as_they_would_transform_them() -> None:
    """The tile check takes the fit's periodogram's corner series instead of transforming
    the tiles again: the same tile fits, to the bit, as from the tiles themselves."""
    near, v, focal = _slope_image(4.0, 3, frames=30)
    est = DispersionAltimeter(dispersion="gravity")
    for prior in ((*v, 0.0), None):
        res, signal, p = est._fit(near, 30.0, focal, prior)
        assert p is not None and p["corners"] and p["_series"] is not None
        given = est._corner_fits(signal, res, 30.0, focal, p)
        assert len(given[0]) == 4
        assert given == est._corner_fits(signal, res, 30.0, focal)


def test_the_tiles_of_a_blind_fit_are_checked_at_its_velocity() -> None:
    """A trusted blind fit's corner tiles are fitted at the velocity it found: they agree
    on the level frames and not on frames whose halves show two scales."""
    near, _, focal = _slope_image(4.0, 3, frames=30)
    far, _, _ = _slope_image(5.2, 3, frames=30)
    est = DispersionAltimeter(dispersion="gravity")
    res = est.estimate(near, fps=30.0, focal_px=focal)
    assert res.trusted, res
    assert est._tile_verdict(est._corner_fits(est._luma(near), res, 30.0, focal)[0],
                             res) is None
    split = near.copy()
    split[:, :, 64:] = far[:, :, 64:]
    assert "corner tiles" in est._tile_verdict(est._corner_fits(est._luma(split), res, 30.0,
                                                               focal)[0], res)


def test_tile_scatter_is_the_variance_beyond_the_tiles_noise() -> None:
    """Cochran's Q of two estimates 0.2 apart at sd 0.05 is 8, above the chi-square(1)
    quantile at the 10 % level (2.71): the DerSimonian-Laird tau^2 is (8 - 1) / (800 - 400).
    0.1 apart (Q = 2) is within the tiles' noise; one estimate, or agreeing ones, none."""
    assert tile_scatter([(0.0, 0.05), (0.2, 0.05)]) == pytest.approx(np.sqrt(7.0 / 400.0))
    assert tile_scatter([(0.0, 0.05), (0.1, 0.05)]) == 0.0
    assert tile_scatter([(1.3, 0.02)] * 4) == 0.0
    assert tile_scatter([(1.3, 0.02)]) == 0.0
    # the weights are the tiles' own: a precise tile far from an imprecise one scatters less
    # than two precise ones as far apart
    assert 0.0 < tile_scatter([(0.0, 0.02), (0.2, 0.08)]) < tile_scatter([(0.0, 0.02),
                                                                          (0.2, 0.02)])


def test_tile_scatter_fires_at_its_level_on_tiles_that_share_one_scale() -> None:
    """Tiles that share one altitude, each off by its own uncertainty (2 to 4 tiles, sd 1 to
    15 %): tau > 0 in TILE_SCATTER_LEVEL of the windows, not more."""
    rng = np.random.default_rng(5)
    fired = []
    for _ in range(4000):
        k = int(rng.integers(2, 5))
        sd = rng.uniform(0.01, 0.15, k)
        fired.append(tile_scatter(list(zip(1.5 + sd * rng.normal(size=k), sd))) > 0.0)
    assert abs(np.mean(fired) - TILE_SCATTER_LEVEL) < 0.015


def test_cli_takes_frames_levelled_at_an_attitude_given_as_level(tmp_path, run_cli) -> None:
    """An attitude given (``--roll-deg/--pitch-deg``) levels the frames, and the altimeter
    then takes them as level: waves on one side of the frame are trusted with it and not
    without it (the attitude unknown), which the text output says."""
    import json

    from wavealt.io import write_frames_folder

    near, v, focal = _slope_image(4.0, 3, frames=30)
    one_side = near.copy()
    one_side[:, :64] = 0.5
    write_frames_folder(tmp_path / "clip", np.repeat(one_side[..., None], 3, axis=-1))
    base = ["altitude", str(tmp_path / "clip"), "--fps", "30", "--focal-px", str(focal),
            "--dispersion", "gravity", "--velocity-mps", ",".join(str(x) for x in v)]
    code, out, err = run_cli([*base, "--json"])
    assert code == 0, err
    res = json.loads(out)
    assert not res["trusted"] and "to measure the camera's tilt" in res["reason"], res
    code, out, err = run_cli(base)
    assert code == 0, err
    assert "NOT TRUSTED (2 of the 4 corner tiles hold the waves, too few" in out
    code, out, err = run_cli([*base, "--roll-deg", "0", "--pitch-deg", "0", "--json"])
    assert code == 0, err
    res = json.loads(out)
    assert res["trusted"] and abs(res["altitude_m"] / 4.0 - 1) < 0.05, res


def test_a_gimbals_prior_weighs_the_tilt_the_tiles_cannot_measure(tmp_path, run_cli) -> None:
    """Waves on one side of the frame do not measure the camera's tilt; what a tilt within
    the prior (``attitude_sigma_deg``) moves the altitude by joins its uncertainty, in
    step with the prior: a gimbal known to 1 degree is trusted where an attitude not
    known (the default, ``ATTITUDE_PRIOR_SD_DEG``) is not, and the default is that prior.
    The command line takes it as ``--attitude-sigma-deg``, alone (nadir within it) or with an
    attitude given, and names a bad one in one line."""
    import json

    from wavealt.io import write_frames_folder

    near, v, focal = _slope_image(4.0, 3, frames=30)
    one_side = near.copy()
    one_side[:, :, :64] = 0.5
    kw = {"fps": 30.0, "focal_px": focal, "velocity_mps": v}
    default = DispersionAltimeter(dispersion="gravity").estimate(one_side, **kw)
    named = DispersionAltimeter(dispersion="gravity", attitude_sigma_deg=ATTITUDE_PRIOR_SD_DEG
                                ).estimate(one_side, **kw)
    assert named.to_dict() == default.to_dict()
    assert not default.trusted and "measure the camera's tilt" in default.reason, default
    gimbal = DispersionAltimeter(dispersion="gravity", attitude_sigma_deg=1.0).estimate(
        one_side, **kw)
    assert gimbal.trusted and gimbal.altitude_m == default.altitude_m, gimbal
    assert_honest(gimbal, 4.0)
    with pytest.raises(ValueError, match="attitude_sigma_deg.*attitude='estimate'"):
        DispersionAltimeter(attitude="level", attitude_sigma_deg=1.0)
    for bad in (0.0, -1.0, float("nan"), 20.0):
        with pytest.raises(ValueError, match="attitude_sigma_deg"):
            DispersionAltimeter(attitude_sigma_deg=bad)
    write_frames_folder(tmp_path / "clip", np.repeat(one_side[..., None], 3, axis=-1))
    base = ["altitude", str(tmp_path / "clip"), "--fps", "30", "--focal-px", str(focal),
            "--dispersion", "gravity", "--velocity-mps", ",".join(str(x) for x in v), "--json"]
    for extra in ([], ["--roll-deg", "0", "--pitch-deg", "0"]):
        code, out, err = run_cli([*base, *extra, "--attitude-sigma-deg", "1"])
        assert code == 0, err
        res = json.loads(out)
        assert res["trusted"] and abs(res["altitude_m"] / 4.0 - 1) < 0.05, res
    code, out, err = run_cli([*base[:-1], "--attitude-sigma-deg", "1"])
    assert code == 0 and "camera attitude: within 1 deg of nadir a side" in out, err
    code, out, err = run_cli([*base, "--attitude-sigma-deg", "0"])
    assert code != 0 and "--attitude-sigma-deg must be in (0, 15] degrees; got 0" in err


def test_the_command_lines_altimeter_takes_an_attitude_given_exactly_unless_told_its_error(
        ) -> None:
    """Recorded and live, an attitude given levels the frames and is the truth (``level``)
    unless ``--attitude-sigma-deg`` gives its error, which the levelled frames' tilt is then
    measured against; without an attitude the tilt is measured against that prior, or the
    default one."""
    from wavealt.cli.altitude import attitude_prior

    assert attitude_prior(True, None) == {"attitude": "level"}
    assert attitude_prior(False, None) == {"attitude": "estimate"}
    for known in (True, False):
        kw = attitude_prior(known, 1.5)
        assert kw == {"attitude": "estimate", "attitude_sigma_deg": 1.5}
        assert DispersionAltimeter(**kw).attitude_sigma_deg == 1.5
    assert DispersionAltimeter().attitude_sigma_deg == ATTITUDE_PRIOR_SD_DEG


def test_a_fit_that_its_tiles_do_not_read_is_not_trusted() -> None:
    """The fit is made of its corner tiles: two tiles holding the waves at 1.23 m (1-2 %)
    contradict a fit at 1.72 m (2.3 %), whatever the tiles' agreement among themselves; the
    same tiles under a fit at 1.25 m do not."""
    est = DispersionAltimeter()
    tiles = [(-80.0, 80.0, np.log(1.23), 0.013), (80.0, 80.0, np.log(1.234), 0.021)]
    reason = est._tile_verdict(tiles, _fit_result(1.72, 0.023))
    assert reason is not None and "read -28 % from the fit" in reason
    assert est._tile_verdict(tiles, _fit_result(1.25, 0.023)) is None


def test_the_fit_and_its_tiles_disagree_at_most_at_the_agreement_bar_by_chance() -> None:
    """Tiles and a fit that share one altitude, each off by its own uncertainty: the
    fit-against-tiles test (3 sigma, two-sided) fires in well under 1 % of them."""
    est = DispersionAltimeter()
    rng = np.random.default_rng(8)
    fired, n = 0, 3000
    for _ in range(n):
        k = int(rng.integers(1, 5))
        sd = rng.uniform(0.01, 0.05, k)
        tiles = [(0.0, 0.0, 1.5 + s * rng.standard_normal(), s) for s in sd]
        fit_sd = float(rng.uniform(0.01, 0.03))
        res = _fit_result(float(np.exp(1.5 + fit_sd * rng.standard_normal())), fit_sd)
        reason = est._tile_verdict(tiles, res)
        fired += reason is not None and "from the fit" in reason
    assert fired / n < 0.01, fired / n


def test_a_measured_yaw_rates_uncertainty_joins_the_altitudes() -> None:
    """The altitude's change at one standard error more of a measured yaw rate is added to
    its uncertainty in quadrature (log altitude), and the fit judged again."""
    est = DispersionAltimeter()
    steady = est._rate_uncertain(_fit_result(10.0, 0.02, significance=100.0),
                                 _fit_result(10.02, 0.02))
    assert steady.trusted  # 0.2 % more: sigma hypot(2, 0.2) %, 3 sigma under 10 %
    assert steady.altitude_std_m == pytest.approx(10.0 * np.hypot(0.02, np.log(1.002)))
    moved = est._rate_uncertain(_fit_result(10.0, 0.02, significance=100.0),
                                _fit_result(10.5, 0.02))
    assert not moved.trusted and "3-sigma uncertainty" in moved.reason
    low = est._rate_uncertain(_fit_result(10.0, 0.02, significance=100.0),
                              _fit_result(9.5, 0.02))  # either way
    assert not low.trusted


def test_the_groups_spread_weighs_each_group_by_its_peaks_sharpness() -> None:
    """Equal weights about the groups' mean give the standard error of the mean; a group
    whose curve is flat (no weight) moves nothing however far off its peak lies, and the same
    group with weight widens it; the weights' scale does not matter; where one group holds
    nearly all the weight (fewer than two effective groups) the plain standard error stands."""
    rng = np.random.default_rng(5)
    ests = rng.normal(0.0, 0.03, 8)
    plain = float(np.std(ests, ddof=1) / np.sqrt(8))
    assert weighted_spread(ests, np.ones(8), float(ests.mean())) == pytest.approx(plain)
    assert weighted_spread(ests, 7.0 * np.ones(8), float(ests.mean())) == pytest.approx(plain)
    sharp = np.array([1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 0.0])
    centre = float(ests[:7].mean())
    base = weighted_spread(ests, sharp, centre)
    far = ests.copy()
    far[7] = 0.9  # a flat group's peak, far off
    assert weighted_spread(far, sharp, centre) == base
    assert weighted_spread(far, np.ones(8), centre) > 5 * base
    lone = np.array([1.0, 1e-3, 1e-3, 0.0, 0.0, 0.0, 0.0, 0.0])
    assert weighted_spread(far, lone, float(ests[0])) == pytest.approx(
        float(np.std(far, ddof=1) / np.sqrt(8)))
    assert weighted_spread(far, np.zeros(8), 0.0) == pytest.approx(
        float(np.std(far, ddof=1) / np.sqrt(8)))

