"""The camera's tilt from its corner tiles' image scales (:mod:`wavealt.altimetry.dispersion.
attitude`): the geometry against a numerical projection onto the sea, the test's level, and
the tiles' placement."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wavealt.altimetry.dispersion.attitude import (
    cochran_q,
    fit_tilt,
    measures_tilt,
    stretch_var_log,
    tile_centres,
    unlevelled_tilt_var_log,
    unmeasured_tilt_var_log,
    without_odd_tile,
)
from wavealt.altimetry.dispersion.constants import ATTITUDE_LEVEL, TILE_SCATTER_LEVEL
from wavealt.altimetry.dispersion.spectra import _corners
from wavealt.camera import tilt_rotation


def _sea_scale(x: float, y: float, focal: float, rot: np.ndarray, height: float) -> float:
    """The altitude a one-scale fit reads around pixel ``(x, y)``: ``focal`` times the
    square root of the area on the sea of one pixel there, by central differences of the
    rays' intersections with the sea ``height`` below (no closed form)."""
    def sea(px: float, py: float) -> np.ndarray:
        d = rot @ np.array([px, py, focal])
        return height * d[:2] / d[2]
    e = 1e-3
    jac = np.stack([(sea(x + e, y) - sea(x - e, y)) / (2 * e),
                    (sea(x, y + e) - sea(x, y - e)) / (2 * e)], axis=1)
    return focal * math.sqrt(abs(np.linalg.det(jac)))


def _sea_stretch(x: float, y: float, focal: float, rot: np.ndarray) -> float:
    """The log of the ratio of the two scales at which the sea around pixel ``(x, y)`` is
    seen (the singular values of the same central differences as :func:`_sea_scale`)."""
    def sea(px: float, py: float) -> np.ndarray:
        d = rot @ np.array([px, py, focal])
        return d[:2] / d[2]
    e = 1e-3
    jac = np.stack([(sea(x + e, y) - sea(x - e, y)) / (2 * e),
                    (sea(x, y + e) - sea(x, y - e)) / (2 * e)], axis=1)
    sv = np.linalg.svd(jac, compute_uv=False)
    return math.log(sv[0] / sv[1])


@pytest.mark.parametrize("roll, pitch", [(0.0, 0.0), (8.0, -3.0), (-12.0, 14.0), (0.0, 25.0)])
@pytest.mark.parametrize("height", [1.5, 9.0])
def test_the_tilt_of_exact_tile_scales_is_the_cameras(roll, pitch, height) -> None:
    focal = 268.5
    rot = tilt_rotation(roll, pitch)
    centres = tile_centres((256, 256), (100, 100))
    fits = [(x, y, math.log(_sea_scale(x, y, focal, rot, height)), 0.03) for x, y in centres]
    tilt = fit_tilt(fits, focal)
    assert tilt is not None
    assert np.allclose(tilt.roll_pitch_deg, (roll, pitch), atol=1e-4)
    assert tilt.chi2_tilt < 1e-12
    assert tilt.significant(ATTITUDE_LEVEL) == (roll != 0.0 or pitch != 0.0)
    assert tilt.tilt_deg == pytest.approx(math.degrees(math.acos(rot[2, 2])), abs=1e-4)
    # three tiles determine it too, with nothing left to check it against
    three = fit_tilt(fits[:3], focal)
    assert np.allclose(three.roll_pitch_deg, (roll, pitch), atol=1e-4)


def test_the_tilt_test_fires_at_its_level_on_a_level_camera() -> None:
    rng = np.random.default_rng(5)
    centres = tile_centres((256, 256), (100, 100))
    fired, n = 0, 3000
    for _ in range(n):
        sd = rng.uniform(0.01, 0.08, 4)
        fits = [(x, y, 1.7 + s * rng.standard_normal(), s) for (x, y), s in zip(centres, sd)]
        tilt = fit_tilt(fits, 268.5)
        fired += tilt is not None and tilt.significant(ATTITUDE_LEVEL)
    assert abs(fired / n - ATTITUDE_LEVEL) < 0.006, fired / n


@pytest.mark.parametrize("roll, pitch", [(6.0, -4.0), (-12.0, 10.0)])
def test_tiles_that_read_a_tilt_fit_it_and_one_wrong_tile_does_not(roll, pitch) -> None:
    """The tilted model's own chi-square (``tiles - 3`` degrees of freedom) tells a tilt
    from one tile's wrong peak: tiles that read a tilt's scales within their noise fit it at
    the test's level as often as the level allows; one tile 30 % off at a sigma of 5 %
    makes a significant "tilt" that does not fit; three tiles, fitted exactly, always fit."""
    focal, height = 268.5, 9.0
    centres = tile_centres((256, 256), (100, 100))
    rot = tilt_rotation(roll, pitch)
    true = [math.log(_sea_scale(x, y, focal, rot, height)) for x, y in centres]
    # a tile reads between the two scales of its oblique view, as the waves' directions fall
    stretch = [_sea_stretch(x, y, focal, rot) / math.sqrt(12.0) for x, y in centres]
    rng = np.random.default_rng(11)
    failed, n = 0, 2000
    for _ in range(n):
        fits = [(x, y, lh + s * rng.standard_normal() + 0.05 * rng.standard_normal(), 0.05)
                for (x, y), lh, s in zip(centres, true, stretch)]
        failed += not fit_tilt(fits, focal).fits(ATTITUDE_LEVEL)
    assert abs(failed / n - ATTITUDE_LEVEL) < 0.006, failed / n
    level = [(x, y, math.log(height), 0.05) for x, y in centres]
    level[2] = (*level[2][:2], math.log(0.7 * height), 0.05)
    wrong = fit_tilt(level, focal)
    assert wrong.significant(ATTITUDE_LEVEL) and not wrong.fits(ATTITUDE_LEVEL)
    assert fit_tilt(level[:3], focal).fits(ATTITUDE_LEVEL)


@pytest.mark.parametrize("roll, pitch", [(0.0, 0.0), (6.0, -4.0), (-12.0, 10.0)])
def test_the_stretch_the_tilted_model_leaves_is_the_oblique_views_own(roll, pitch) -> None:
    """The variance :meth:`TiltFit.fits` adds per tile is ``L^2 / 12``, ``L`` the log ratio
    of the two scales at which the tile sees the sea (here from the exact rays at the
    camera's attitude; the tilt fitted from the tiles' exact scales): nil for a level
    camera, and at 15.6 degrees as large as a few percent of noise."""
    focal = 268.5
    centres = tile_centres((256, 256), (100, 100))
    rot = tilt_rotation(roll, pitch)
    tilt = fit_tilt([(x, y, math.log(_sea_scale(x, y, focal, rot, 9.0)), 0.05)
                     for x, y in centres], focal)
    x, y = (np.array(v) / focal for v in zip(*centres))
    var = stretch_var_log(x, y, tilt.a, tilt.b)
    want = np.array([_sea_stretch(cx, cy, focal, rot) ** 2 / 12.0 for cx, cy in centres])
    assert np.allclose(var, want, rtol=1e-3, atol=1e-10), (var, want)
    if roll == pitch == 0.0:
        assert var.max() < 1e-12
    elif abs(roll) > 10:
        assert 0.02 < math.sqrt(var.max()) < 0.06


def test_tiles_of_a_symmetric_frame_leave_the_altitude_unmoved_by_the_tilt() -> None:
    centres = tile_centres((256, 256), (100, 100))
    tilt = fit_tilt([(x, y, 1.0, 0.05) for x, y in centres], 268.5)
    assert tilt.extra_var_log() == pytest.approx(0.0, abs=1e-12)
    # one tile lost: the mean of the other three moves with the tilt
    assert fit_tilt([(x, y, 1.0, 0.05) for x, y in centres[:3]], 268.5).extra_var_log() > 0
    assert fit_tilt([(x, y, 1.0, 0.05) for x, y in centres[:2]], 268.5) is None


def test_tile_centres_are_those_of_the_corner_tiles() -> None:
    h, w = 90, 120
    xs = np.broadcast_to(np.arange(w) - (w - 1) / 2, (1, h, w))
    ys = np.broadcast_to((np.arange(h) - (h - 1) / 2)[:, None], (1, h, w))
    tx, ty = _corners(xs, 0.4), _corners(ys, 0.4)
    for (cx, cy), a, b in zip(tile_centres((h, w), tx[0].shape[1:]), tx, ty):
        assert cx == pytest.approx(float(a.mean())) and cy == pytest.approx(float(b.mean()))


def test_a_tilt_no_tile_measures_moves_a_one_sided_reading_as_the_geometry_does() -> None:
    """The variance an unmeasured tilt adds, against the exact projection: tilts drawn from
    the prior move the log altitude a tile reads by the predicted amount, and a reading from
    tiles that measure the tilt, or from the frame's middle, not at all."""
    focal, height, prior_deg = 268.5, 4.0, 7.5
    s = math.sin(math.radians(prior_deg))
    centres = tile_centres((256, 256), (96, 96))
    rng = np.random.default_rng(11)
    tilts = rng.normal(0.0, prior_deg, (4000, 2))
    for tiles in ([centres[3]], [centres[2], centres[3]], [centres[0], centres[1]],
                  [centres[1], centres[3]]):
        # equal sigmas: the fit reads at the tiles' centroid, which is what moves
        gx, gy = np.mean(tiles, axis=0)
        var = unmeasured_tilt_var_log([(x, y, 0.0, 0.02) for x, y in tiles], focal, s)
        # two tiles on one side measure the tilt along their line (roll for a pair in one
        # row), not across it: the tilts that move their reading unmeasured are about the
        # other axis alone
        free = tilts.copy()
        if len(tiles) == 2:
            free[:, 0 if tiles[0][1] == tiles[1][1] else 1] = 0.0
        across = gx if tiles[0][0] == tiles[-1][0] else gy
        want = 2.25 * s**2 * (gx**2 + gy**2 if len(tiles) == 1 else across**2) / focal**2
        assert var == pytest.approx(want, rel=1e-9)
        # first order in the tilt: the projection's own spread within a tenth
        moved = [math.log(_sea_scale(gx, gy, focal, tilt_rotation(r, p), height) / height)
                 for r, p in free]
        assert math.sqrt(var) == pytest.approx(float(np.std(moved)), rel=0.1)
    # a diagonal pair (its centroid is the middle), three or four tiles: nothing unmeasured
    for tiles in ([centres[0], centres[3]], centres[:3], centres):
        assert unmeasured_tilt_var_log([(x, y, 0.0, 0.02) for x, y in tiles], focal, s) \
            == pytest.approx(0.0, abs=1e-15)
    # no tile holds the waves: nothing says where the fit reads, taken at a corner tile's
    assert unmeasured_tilt_var_log([], focal, s) == 0.0
    assert unmeasured_tilt_var_log([], focal, s, centres) == pytest.approx(
        unmeasured_tilt_var_log([(*centres[2], 0.0, 0.02)], focal, s))


def test_a_tile_too_imprecise_to_tell_a_tilt_measures_nothing() -> None:
    """Two precise tiles in the bottom row and a third at the top whose sigma (30 %) is
    wider than any tilt within the prior moves it: the tilt across the row stays
    unmeasured, as with the two alone; at 2 % the third tile measures it."""
    focal, s = 223.0, math.sin(math.radians(7.5))
    c = tile_centres((256, 256), (96, 96))
    pair = [(*c[2], 0.0, 0.03), (*c[3], 0.0, 0.02)]
    alone = unmeasured_tilt_var_log(pair, focal, s)
    assert alone > 0.0
    vague = unmeasured_tilt_var_log([*pair, (*c[0], 0.0, 0.30)], focal, s)
    assert vague == pytest.approx(alone, rel=0.05)
    assert unmeasured_tilt_var_log([*pair, (*c[0], 0.0, 0.02)], focal, s) == 0.0


def test_the_tiles_measure_a_tilt_at_the_information_of_their_errors(monkeypatch) -> None:
    """A tile's sigma counts toward the tilt it measures at ``TILE_INFORMATION_SD_SCALE`` of
    itself (its errors are heavy-tailed about a narrower bulk): tiles at sigma s leave the
    variance that tiles at the scaled sigma leave when taken at their own; a third tile at
    15 % beside a precise pair measures the tilt across their row, which at its own sigma
    it would not (the prior knows it better)."""
    import wavealt.altimetry.dispersion.attitude as attitude

    focal, s = 223.0, math.sin(math.radians(7.5))
    c = tile_centres((256, 256), (96, 96))
    tile = (96, 96)
    pair = [(*c[2], 0.0, 0.03), (*c[3], 0.0, 0.02)]
    third = [*pair, (*c[0], 0.04, 0.15)]
    scale = attitude.TILE_INFORMATION_SD_SCALE
    assert 0.0 < scale < 1.0
    scaled = attitude.informative(third)
    assert [t[3] for t in scaled] == pytest.approx([scale * t[3] for t in third])
    assert unmeasured_tilt_var_log(third, focal, s) == 0.0
    unlevelled = unlevelled_tilt_var_log(third, focal, s, tile)
    monkeypatch.setattr(attitude, "TILE_INFORMATION_SD_SCALE", 1.0)
    assert unmeasured_tilt_var_log(scaled, focal, s) == 0.0
    assert unlevelled_tilt_var_log(scaled, focal, s, tile) == pytest.approx(unlevelled,
                                                                            rel=1e-12)
    # at its own sigma the third tile leaves the tilt across the pair's row unmeasured
    assert unmeasured_tilt_var_log(third, focal, s) == pytest.approx(
        unmeasured_tilt_var_log(pair, focal, s), rel=0.1)


def test_the_unmeasured_tilt_is_read_where_the_precise_tiles_lie() -> None:
    """Unequal sigmas move the centroid toward the precise tile: a diagonal pair leaves the
    tilt across it unmeasured once one tile outweighs the other."""
    focal, s = 268.5, 0.1
    (x0, y0), _, _, (x3, y3) = tile_centres((256, 256), (96, 96))
    var = unmeasured_tilt_var_log([(x0, y0, 0.0, 0.01), (x3, y3, 0.0, 0.04)], focal, s)
    # the centroid lies on the diagonal, along which the pair measures the tilt
    assert var == pytest.approx(0.0, abs=1e-15)
    one = unmeasured_tilt_var_log([(x0, y0, 0.0, 0.01)], focal, s)
    assert one == pytest.approx(2.25 * s**2 * (x0**2 + y0**2) / focal**2)


def test_an_unlevelled_fit_reads_a_tilts_scales_within_a_tile_as_the_geometry_does() -> None:
    """The variance a tilt the tiles allow adds to a fit of frames not levelled, read about
    the tiles' weighted centroid within a tile's extent: tiles too vague to tell a tilt leave
    the prior's; precise tiles of a tilted camera give the spread of the exact projection's
    scales over a tile about its centre's; a precise tile outweighing the others moves the
    centroid toward it; fewer than three tiles, None (:func:`unmeasured_tilt_var_log`)."""
    focal, height, s = 206.0, 3.0, math.sin(math.radians(7.5))
    tile = (102, 128)
    centres = tile_centres((256, 320), tile)
    within = (tile[1] ** 2, tile[0] ** 2)
    vague = [(x, y, 0.0, 1e3) for x, y in centres]
    assert unlevelled_tilt_var_log(vague, focal, s, tile) == pytest.approx(
        2.25 * s**2 * sum(within) / (12 * focal**2), rel=1e-4)
    assert unlevelled_tilt_var_log(vague[:2], focal, s, tile) is None
    rot = tilt_rotation(6.0, -4.0)
    tiles = [(x, y, math.log(_sea_scale(x, y, focal, rot, height)), 1e-4) for x, y in centres]
    tilt = fit_tilt(tiles, focal)
    var = unlevelled_tilt_var_log(tiles, focal, s, tile)
    assert var == pytest.approx(2.25 * (tilt.a**2 * within[0] + tilt.b**2 * within[1])
                                / (12 * focal**2), rel=1e-3)
    # the exact projection's scales over a tile about its centre's: within a tenth
    places = np.random.default_rng(5).uniform(-0.5, 0.5, (4000, 2)) * (tile[1], tile[0])
    centre = math.log(_sea_scale(0.0, 0.0, focal, rot, height))
    moved = [math.log(_sea_scale(x, y, focal, rot, height)) - centre for x, y in places]
    assert math.sqrt(var) == pytest.approx(math.sqrt(float(np.mean(np.square(moved)))),
                                           rel=0.1)
    # one tile ten times as precise: the fit reads near it, where the tilt moves it more
    heavy = [tiles[0][:3] + (1e-5,)] + tiles[1:]
    x0, y0 = centres[0]
    near = 2.25 * (tilt.a * x0 + tilt.b * y0) ** 2 / focal**2
    assert unlevelled_tilt_var_log(heavy, focal, s, tile) == pytest.approx(var + near,
                                                                           rel=0.05)


def test_two_tiles_in_a_row_do_not_see_a_pitch_and_four_corners_see_any_tilt() -> None:
    # the levelled view's check (levelling._Level._level): a pitch that one bottom tile made
    # cannot be confirmed by the two top tiles agreeing, however precisely
    prior = math.sin(math.radians(7.5))
    f, d = 222.0, 75.0
    row = [(-d, -d, 0.0, 0.01), (d, -d, 0.0, 0.01)]
    assert not measures_tilt(row, f, prior, (0.0, -0.17))
    assert measures_tilt(row, f, prior, (0.17, 0.0))  # a roll: along the row
    assert measures_tilt(row, f, prior, (0.1, 0.1))  # half along it
    corners = row + [(-d, d, 0.0, 0.05), (d, d, 0.0, 0.05)]
    for direction in ((0.0, 1.0), (1.0, 0.0), (0.6, -0.8)):
        assert measures_tilt(corners, f, prior, direction)
        # a tilt's sense and size do not matter
        assert measures_tilt(corners, f, prior, tuple(-3 * c for c in direction))
    # tiles too imprecise to tell a tilt within the prior measure nothing; one tile nothing
    loose = [(x, y, 0.0, 1.0) for x, y, _, _ in corners]
    assert not measures_tilt(loose, f, prior, (0.0, 1.0))
    assert not measures_tilt(row[:1], f, prior, (1.0, 0.0))
    assert not measures_tilt(corners, f, prior, (0.0, 0.0))


def test_cochran_q_is_the_weighted_squares_about_the_weighted_mean() -> None:
    q, mean, w = cochran_q([(0.0, 0.1), (0.3, 0.1), (0.3, 0.05)])
    assert w == pytest.approx([100.0, 100.0, 400.0])
    assert mean == pytest.approx((0.0 * 100 + 0.3 * 100 + 0.3 * 400) / 600.0)
    assert q == pytest.approx(100 * mean**2 + 100 * (0.3 - mean) ** 2 + 400 * (0.3 - mean) ** 2)
    assert cochran_q([(1.2, 0.02)] * 3)[0] == pytest.approx(0.0, abs=1e-18)


@pytest.mark.parametrize("odd", range(4))
@pytest.mark.parametrize("factor", [0.5, 0.7, 1.4])
def test_a_level_cameras_tile_off_the_shell_is_set_aside(odd, factor) -> None:
    """Three corners that read one scale and a fourth that reads another (a wrong peak: the
    optics' sum products read 0.5-0.8 of the altitude) fit neither a level nor a tilted
    camera: the fourth is set aside and the three are kept, in their order."""
    centres = tile_centres((256, 256), (100, 100))
    rng = np.random.default_rng(odd)
    fits = [(x, y, math.log(6.0 * (factor if i == odd else 1.0)) + 0.01 * rng.standard_normal(),
             0.03) for i, (x, y) in enumerate(centres)]
    kept = without_odd_tile(fits, 268.5, TILE_SCATTER_LEVEL)
    assert kept == fits[:odd] + fits[odd + 1:]


@pytest.mark.parametrize("roll, pitch", [(10.0, 0.0), (-6.0, 9.0), (12.0, 12.0)])
def test_a_tilted_cameras_tiles_are_all_kept(roll, pitch) -> None:
    """A tilt parts the four tiles' scales far beyond their noise, but the tilted model fits
    them, and no three of them read one scale: none is set aside, with one tile off the tilt's
    scale as well (a tilted camera's tiles are judged as they are)."""
    focal, height = 268.5, 7.0
    centres = tile_centres((256, 256), (100, 100))
    rot = tilt_rotation(roll, pitch)
    true = [math.log(_sea_scale(x, y, focal, rot, height)) for x, y in centres]
    rng = np.random.default_rng(3)
    fits = [(x, y, lh + 0.01 * rng.standard_normal(), 0.02) for (x, y), lh in zip(centres, true)]
    assert cochran_q([f[2:] for f in fits])[0] > 50.0  # the tiles differ
    assert without_odd_tile(fits, focal, TILE_SCATTER_LEVEL) == fits
    off = fits[:2] + [(*fits[2][:2], fits[2][2] + math.log(0.7), fits[2][3])] + fits[3:]
    assert without_odd_tile(off, focal, TILE_SCATTER_LEVEL) == off


def test_tiles_that_agree_or_are_too_few_are_kept() -> None:
    centres = tile_centres((256, 256), (100, 100))
    agree = [(x, y, math.log(4.0) + d, 0.03) for (x, y), d in zip(centres, (0.01, -0.02, 0.0,
                                                                            0.02))]
    assert without_odd_tile(agree, 268.5, TILE_SCATTER_LEVEL) == agree
    three = [(x, y, math.log(4.0 * f), 0.02) for (x, y), f in zip(centres, (1.0, 1.0, 0.6))]
    assert without_odd_tile(three, 268.5, TILE_SCATTER_LEVEL) == three
    # an odd tile too imprecise to stand off the others' mean is kept
    vague = agree[:3] + [(*agree[3][:2], math.log(4.0 * 0.8), 0.2)]
    assert without_odd_tile(vague, 268.5, TILE_SCATTER_LEVEL) == vague


def test_a_level_cameras_odd_tile_makes_a_tilt_that_without_it_is_gone() -> None:
    """What the levelling measures (:meth:`~.levelling._Level._level`): with the odd tile,
    four tiles of a level camera show a significant tilt of many degrees; without it, none."""
    centres = tile_centres((256, 256), (100, 100))
    fits = [(x, y, math.log(9.0 * f), s) for (x, y), f, s in
            zip(centres, (1.0, 1.01, 0.7, 0.99), (0.02, 0.02, 0.04, 0.03))]
    false = fit_tilt(fits, 268.5)
    assert false.significant(ATTITUDE_LEVEL) and false.tilt_deg > 5.0
    kept = without_odd_tile(fits, 268.5, TILE_SCATTER_LEVEL)
    assert len(kept) == 3
    assert not fit_tilt(kept, 268.5).significant(ATTITUDE_LEVEL)
