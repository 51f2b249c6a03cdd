"""A camera that shakes in roll and pitch: its corner tiles measure the image shift they
share, frame by frame, and the altimeter removes it before it fits the waves."""

from __future__ import annotations

import math

import numpy as np
import pytest
from contract import assert_honest

from wavealt.altimetry.dispersion import DispersionAltimeter
from wavealt.altimetry.dispersion import spectra as spectra_module
from wavealt.altimetry.dispersion.constants import JITTER_MIN_RATIO
from wavealt.altimetry.dispersion.jitter import common_shake, remove_shake, tile_shake
from wavealt.altimetry.dispersion.spectra import _corners, _windowed_modes
from wavealt.sim.config import preset_config
from wavealt.sim.generate import generate_sequence


def _detrended(shift: np.ndarray) -> np.ndarray:
    t = np.arange(shift.shape[0], dtype=float)
    out = shift.astype(float).copy()
    for c in range(out.shape[1]):
        out[:, c] -= np.polyval(np.polyfit(t, out[:, c], 1), t)
    return out


def _series(shake: np.ndarray, rng: np.random.Generator, *, tiles: int = 4,
            noise: float = 0.1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mode series of ``tiles`` tiles of a sea drifting at ``(0.6, -0.4)`` px a frame, each
    mode's waves stepping by a dispersion term of their own, every frame moved by
    ``shake[t]`` px (the same in every tile), with independent noise per tile."""
    n = 900
    kappa = rng.uniform(0.1, 1.5, n)
    angle = rng.uniform(0.0, 2.0 * np.pi, n)
    kx, ky = kappa * np.cos(angle), kappa * np.sin(angle)
    t = np.arange(shake.shape[0])[:, None]
    step = -(kx * 0.6 - ky * 0.4) + 0.5 * np.sqrt(kappa)
    out = []
    for _ in range(tiles):
        phase = step * t - (kx * shake[:, :1] + ky * shake[:, 1:]) + rng.uniform(0, 6.3, n)
        g = np.exp(1j * phase)
        g += noise * (rng.standard_normal(g.shape) + 1j * rng.standard_normal(g.shape))
        out.append(g - g.mean(axis=0))
    return np.stack(out).astype(np.complex64), kx, ky


def _sway(frames: int, amp_px: float) -> np.ndarray:
    t = np.arange(frames) / 30.0
    return amp_px * np.stack([np.sin(2 * np.pi * 1.3 * t + 0.4),
                              np.sin(2 * np.pi * 0.9 * t + 2.0)], axis=1)


def test_the_tiles_read_the_shake_less_its_trend() -> None:
    shake = _sway(30, 2.0) + np.array([0.05, -0.02]) * np.arange(30)[:, None]  # a steady turn too
    series, kx, ky = _series(shake, np.random.default_rng(3))
    want = _detrended(shake)
    got = tile_shake(series[0], kx, ky)
    assert np.abs(got.mean(axis=0)).max() < 1e-9  # no mean
    # one tile, one pass: most of it (a mode's steady step is read on the shaken series)
    assert np.sqrt(((got - want) ** 2).mean()) < 0.25 * np.sqrt((want**2).mean())
    steadied, removed = remove_shake(series, kx, ky)  # four tiles' mean, twice
    assert removed is not None
    assert np.sqrt(((removed - want) ** 2).mean()) < 0.06 * np.sqrt((want**2).mean())
    # what is left steps steadily: the shake read again is nothing the tiles agree on
    assert common_shake(steadied, kx, ky)[1] < JITTER_MIN_RATIO


_CENTRES = np.array([[-50.0, -50.0], [50.0, -50.0], [-50.0, 50.0], [50.0, 50.0]])


def _turning_tiles(rng: np.random.Generator
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Mode series of tiles at ``_CENTRES`` whose content shifts by a 2-px sway and turns
    about the centre by 0.8 degrees back and forth, with noise of their own: the series,
    the modes' ``kx``, ``ky``, the shift ``(T, 2)`` and the rotation ``(T,)`` rad."""
    shake = _sway(30, 2.0)
    t = np.arange(30) / 30.0
    theta = np.radians(0.8) * np.sin(2 * np.pi * 1.1 * t + 1.0)
    tiles, kx, ky = [], None, None
    for c in _CENTRES:  # each tile moves by the shift and the rotation at its centre
        moved = shake + theta[:, None] * np.array([-c[1], c[0]])[None, :]
        series, kx, ky = _series(moved, np.random.default_rng(9), tiles=1)
        series = series + 0.05 * (rng.standard_normal(series.shape)
                                  + 1j * rng.standard_normal(series.shape))
        tiles.append(series[0])
    return np.stack(tiles).astype(np.complex64), kx, ky, shake, theta


def test_a_wavering_heading_is_taken_out_with_the_shake_and_only_when_it_is_there() -> None:
    """Tiles at the corners of a frame whose content also turns about the centre by a
    fraction of a degree back and forth: the shift and the rotation are both read
    and removed (the tiles then agree on nothing more; the shift to 10 %, the rotation to
    15 %); without a rotation the removal is
    remove_shake's, to the bit, and no rotation is reported."""
    from wavealt.altimetry.dispersion.jitter import remove_motion

    series, kx, ky, shake, theta = _turning_tiles(np.random.default_rng(4))
    steadied, shift, turn = remove_motion(series, kx, ky, _CENTRES)
    want = _detrended(shake)
    want_turn = _detrended(np.stack([theta, theta], -1))[:, 0]
    assert shift is not None and turn is not None
    assert np.sqrt(((shift - want) ** 2).mean()) < 0.1 * np.sqrt((want**2).mean())
    assert np.sqrt(((turn - want_turn) ** 2).mean()) < 0.15 * np.sqrt((want_turn**2).mean())
    assert common_shake(steadied, kx, ky)[1] < JITTER_MIN_RATIO
    # the shift alone: no rotation reported, and remove_shake's removal exactly
    still, kx, ky = _series(shake, np.random.default_rng(5))
    out, shift, turn = remove_motion(still, kx, ky, _CENTRES)
    assert turn is None and shift is not None
    same, same_shift = remove_shake(still, kx, ky)
    assert np.array_equal(out, same) and np.array_equal(shift, same_shift)


def test_a_motion_read_on_one_record_of_the_tiles_is_removed_whole_from_another() -> None:
    """:func:`remove_motion_seen` reads the shift and the rotation on one record of the
    tiles and removes them, whole, from another: from the record it read, the same motion
    as :func:`remove_motion` reports, and the tiles then share no shift (about
    :func:`remove_motion`'s series: it removes the mean between its passes); from the same
    tiles at three times the amplitude, the same steadied series three times over.  Where
    the record read shows no shake, the series come back as given and no motion is
    reported."""
    from wavealt.altimetry.dispersion.jitter import remove_motion, remove_motion_seen

    series, kx, ky, _, _ = _turning_tiles(np.random.default_rng(4))
    want, want_shift, want_turn = remove_motion(series, kx, ky, _CENTRES)
    got, shift, turn = remove_motion_seen(series, series, kx, ky, _CENTRES)
    assert np.array_equal(shift, want_shift) and np.array_equal(turn, want_turn)
    assert common_shake(got, kx, ky)[1] < JITTER_MIN_RATIO
    assert np.sqrt(np.mean(np.abs(got - want) ** 2)) < 0.05 * np.sqrt(np.mean(np.abs(want) ** 2))
    louder, _, _ = remove_motion_seen(3.0 * series, series, kx, ky, _CENTRES)
    assert np.allclose(louder, 3.0 * got, atol=1e-4 * float(np.abs(louder).max()))
    still, kx, ky = _series(np.zeros((30, 2)), np.random.default_rng(5))
    other = 2.0 * still
    out, shift, turn = remove_motion_seen(other, still, kx, ky, _CENTRES)
    assert out is other and shift is None and turn is None


def test_a_still_camera_is_not_steadied() -> None:
    for seed in range(5):
        series, kx, ky = _series(np.zeros((30, 2)), np.random.default_rng(seed))
        shake, ratio = common_shake(series, kx, ky)
        assert ratio < JITTER_MIN_RATIO and np.abs(shake).max() < 0.05
        out, removed = remove_shake(series, kx, ky)
        assert removed is None and out is series


def test_tiles_of_noise_are_not_steadied() -> None:
    rng = np.random.default_rng(11)
    kx, ky = rng.uniform(-1.0, 1.0, (2, 600))
    for _ in range(20):
        noise = rng.standard_normal((4, 30, 600)) + 1j * rng.standard_normal((4, 30, 600))
        assert remove_shake(noise.astype(np.complex64), kx, ky)[1] is None


def test_frames_moved_by_whole_pixels_read_that_shift_with_its_sign() -> None:
    """The shift read from the corner tiles' transforms (the periodogram's own modes) is
    the frames' own, x along columns and y along rows."""
    rng = np.random.default_rng(2)
    base = rng.standard_normal((160, 160)).astype(np.float32)
    shake = np.array([[0, 0], [2, 1], [3, -1], [1, -2], [-1, -1], [-2, 1], [-1, 2], [1, 1],
                      [2, -1], [0, -2], [-2, 0], [-1, 1], [1, 2], [2, 0], [0, -1], [-1, -2]])
    frames = np.stack([np.roll(base, (int(sy) - t, int(sx) + t), axis=(0, 1))
                       for t, (sx, sy) in enumerate(shake)])
    alt = DispersionAltimeter()
    tiles = _corners(frames, 0.4)
    kx, ky, _, _, idx = alt._plane(*tiles[0].shape[1:], 2000)
    g = _windowed_modes(tiles, idx)
    g -= g.mean(axis=1, keepdims=True)
    _, removed = remove_shake(g, kx[idx], ky[idx])
    assert removed is not None
    assert np.abs(removed - _detrended(shake)).max() < 0.25


def _shaken(frames: np.ndarray, focal_px: float, amp_deg: float, side: int) -> np.ndarray:
    """The central ``side`` px of a camera rolling and pitching by ``amp_deg`` (about 1 and
    1.5 Hz) over a level camera's ``frames``."""
    import cv2

    from wavealt.camera import tilt_rotation

    t, h, w = frames.shape
    k = np.array([[focal_px, 0, (w - 1) / 2], [0, focal_px, (h - 1) / 2], [0, 0, 1.0]])
    k_out = np.array([[focal_px, 0, (side - 1) / 2], [0, focal_px, (side - 1) / 2], [0, 0, 1.0]])
    out = []
    for i in range(t):
        s = i / 30.0
        rot = tilt_rotation(amp_deg * np.sin(2 * np.pi * 1.0 * s + 0.5),
                            amp_deg * np.sin(2 * np.pi * 1.5 * s + 2.0))
        out.append(cv2.warpPerspective(frames[i].astype(np.float32),
                                       k @ rot @ np.linalg.inv(k_out), (side, side),
                                       flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
                                       borderMode=cv2.BORDER_REFLECT))
    return np.stack(out)


def test_a_shaking_camera_is_steadied_and_read_blind(monkeypatch: pytest.MonkeyPatch) -> None:
    """Seas seen through half a degree of roll and pitch (two scenes at each of two
    altitudes): steadied, the blind 1-s fit reads them nearer a level camera's reading than
    the fit left shaking does, by a factor of two over the scenes; the shake taken out is
    the sway the rotation made; every estimate keeps the trust contract."""
    steadied, shaken = [], []
    for altitude in (4.0, 9.0):
        for seed in (4, 5):
            cfg = preset_config("realistic", size=256, frames=30, seed=seed,
                                altitude_m=(altitude, altitude), wind_speed_mps=(8.0, 8.0),
                                camera_speed_mps=(0.4, 0.4))
            sea = generate_sequence(cfg.sample_scenario(0), cfg).clean.mean(axis=-1)
            kw = {"fps": cfg.fps, "focal_px": cfg.focal_px}
            alt = DispersionAltimeter(dispersion="gravity-capillary")
            level = alt.estimate(np.clip(_shaken(sea, cfg.focal_px, 0.0, 176), 0.0, 1.0), **kw)
            assert "+steadied" not in level.signal
            assert_honest(level, altitude)
            clip = np.clip(_shaken(sea, cfg.focal_px, 0.5, 176), 0.0, 1.0)
            res = alt.estimate(clip, **kw)
            assert "+steadied" in res.signal
            assert_honest(res, altitude)
            # the sway the rotation made, less its trend (no steadying sees a steady turn)
            s = np.arange(30)[:, None] / 30.0
            angle = 0.5 * np.sin(2 * np.pi * np.array([1.0, 1.5]) * s + np.array([0.5, 2.0]))
            sway = math.sqrt(np.mean(_detrended(cfg.focal_px * np.tan(np.radians(angle)))**2))
            assert res.shake_px == pytest.approx(sway, rel=0.2), (res.shake_px, sway)
            with monkeypatch.context() as m:
                m.setattr(spectra_module, "JITTER_MIN_FRAMES", 10**6)  # not steadied
                shaking = alt.estimate(clip, **kw)
            assert "+steadied" not in shaking.signal
            assert_honest(shaking, altitude)
            steadied.append(abs(math.log(res.altitude_m / level.altitude_m)))
            shaken.append(abs(math.log(shaking.altitude_m / level.altitude_m)))
    assert sum(steadied) < 0.5 * sum(shaken), (steadied, shaken)


def test_the_shake_taken_out_is_in_the_frames_own_pixels() -> None:
    """Fitted at a working scale of half the frames (binned by 2), the shake taken out is
    reported in the frames' own pixels, as :func:`image_shake` reports it: about the sway
    the unbinned fit reports (a degree: 2.1 px rms), not half of it.  The binned fit is the
    working scale's own (``_estimate_at``), trusted or not: ``estimate`` would give way to
    the finer scale where it is not."""
    cfg = preset_config("realistic", size=256, frames=30, seed=4, altitude_m=(4.0, 4.0),
                        wind_speed_mps=(8.0, 8.0), camera_speed_mps=(0.4, 0.4))
    sea = generate_sequence(cfg.sample_scenario(0), cfg).clean.mean(axis=-1)
    clip = np.clip(_shaken(sea, cfg.focal_px, 1.0, 176), 0.0, 1.0)
    kw = {"fps": cfg.fps, "focal_px": cfg.focal_px}
    full = DispersionAltimeter(dispersion="gravity-capillary").estimate(clip, **kw)
    binned = DispersionAltimeter(dispersion="gravity-capillary", working_px=88)._estimate_at(
        clip, 2, 0.0, velocity_mps=None, velocity_sigma_mps=0.0, yaw_rate_dps=None, **kw)
    assert "+steadied" in full.signal and "+steadied+binned2" in binned.signal, binned.signal
    assert binned.shake_px == pytest.approx(full.shake_px, rel=0.25), (full, binned)


def test_a_level_camera_is_not_steadied() -> None:
    cfg = preset_config("realistic", size=256, frames=30, seed=5, altitude_m=(6.0, 6.0),
                        wind_speed_mps=(8.0, 8.0), camera_speed_mps=(0.4, 0.4))
    sea = generate_sequence(cfg.sample_scenario(0), cfg).clean.mean(axis=-1)
    res = DispersionAltimeter(dispersion="gravity-capillary").estimate(
        sea[:, 40:216, 40:216], fps=cfg.fps, focal_px=cfg.focal_px)
    assert "+steadied" not in res.signal


def test_a_velocity_given_is_not_trusted_through_a_shake() -> None:
    """Steadying takes out the shake's back and forth, not the rotation's mean rate, which
    moves the image as a velocity over the water would: an exact fit of steadied frames is
    not trusted, and says why."""
    cfg = preset_config("realistic", size=256, frames=30, seed=4, altitude_m=(4.0, 4.0),
                        wind_speed_mps=(8.0, 8.0), camera_speed_mps=(0.4, 0.4))
    sc = cfg.sample_scenario(0)
    sea = generate_sequence(sc, cfg).clean.mean(axis=-1)
    clip = np.clip(_shaken(sea, cfg.focal_px, 0.5, 176), 0.0, 1.0)
    res = DispersionAltimeter(dispersion="gravity-capillary").estimate(
        clip, fps=cfg.fps, focal_px=cfg.focal_px,
        velocity_mps=tuple(float(v) for v in sc.camera_velocity_mps))
    assert "+steadied" in res.signal and not res.trusted
    assert "shook" in res.reason
    assert_honest(res, 4.0)


def test_tiles_without_waves_are_not_steadied() -> None:
    """Two tiles flat (a sky's glare), two shaken: no mode of a flat tile has a phase, and
    nothing undefined reaches the shake (the estimate stays finite or is not taken)."""
    series, kx, ky = _series(_sway(30, 2.0), np.random.default_rng(4))
    series[:2] = 0.0
    out, removed = remove_shake(series, kx, ky)
    assert np.all(np.isfinite(out))
    assert removed is None or np.all(np.isfinite(removed))


def test_the_command_line_reports_the_shake_it_took_out(tmp_path, run_cli) -> None:
    """A frame folder of a camera shaking by half a degree, fitted blind: the JSON's
    ``shake_px`` is the shake taken out (about the focal length times the angle), the text
    says so, and ``altitude.csv`` holds it; a level camera's is 0 and the text is silent."""
    import csv
    import json

    from wavealt.io import write_frames_folder

    cfg = preset_config("realistic", size=256, frames=30, seed=4, altitude_m=(4.0, 4.0),
                        wind_speed_mps=(8.0, 8.0), camera_speed_mps=(0.4, 0.4))
    sea = generate_sequence(cfg.sample_scenario(0), cfg).clean.mean(axis=-1)
    for amp, name in ((0.5, "shaken"), (0.0, "level")):
        grey = np.clip(_shaken(sea, cfg.focal_px, amp, 176), 0.0, 1.0)
        write_frames_folder(tmp_path / name, np.repeat(grey[..., None], 3, axis=-1))
        args = ["altitude", str(tmp_path / name), "--fps", str(cfg.fps), "--focal-px",
                str(cfg.focal_px)]
        code, out, err = run_cli([*args, "--json"])
        assert code == 0, err
        summary = json.loads(out)
        code, text, err = run_cli([*args, "--out", str(tmp_path / f"out-{name}")])
        assert code == 0, err
        with open(tmp_path / f"out-{name}" / "altitude.csv", newline="") as fh:
            rows = list(csv.DictReader(fh))
        assert float(rows[0]["shake_px"]) == pytest.approx(summary["shake_px"], rel=1e-5)
        if amp:
            # half a degree at 222 px of focal length: about 1.9 px of sway, 1.3 px rms
            assert 0.5 < summary["shake_px"] < 3.0, summary
            assert "camera shaking" in text
        else:
            assert summary["shake_px"] == 0.0 and "camera shaking" not in text


def test_a_tile_moved_back_is_the_tile_before_it_moved() -> None:
    """:func:`move_back` undoes each tile's own sub-pixel motion, x along columns and y
    along rows (a periodic tile, which a circular shift moves exactly)."""
    from wavealt.altimetry.dispersion.jitter import move_back

    rng = np.random.default_rng(8)
    h, w, t = 48, 64, 5
    yy, xx = np.mgrid[0:h, 0:w].astype(float)
    cycles = rng.integers(1, 6, (6, 2))
    amp, phase = rng.uniform(0.5, 1.0, 6), rng.uniform(0.0, 2 * np.pi, 6)

    def tile(dx: float, dy: float) -> np.ndarray:  # the pattern moved by (dx, dy) px
        return sum(a * np.cos(2 * np.pi * (cx * (xx - dx) / w + cy * (yy - dy) / h) + p)
                   for (cx, cy), a, p in zip(cycles, amp, phase))

    motion = rng.uniform(-2.5, 2.5, (2, t, 2))
    parts = [np.stack([tile(*m) for m in mv]).astype(np.float32) for mv in motion]
    back = move_back(parts, motion)
    still = tile(0.0, 0.0)
    for b in back:
        assert b.dtype == np.float32 and b.shape == (t, h, w)
        np.testing.assert_allclose(b, np.broadcast_to(still, b.shape), atol=2e-4)


def _moved_sea(sea: np.ndarray, sway: np.ndarray, side: int) -> np.ndarray:
    """The central ``side`` px of frames ``sea`` ``(T, H, W)`` moved by ``sway[t]`` px (x, y)
    each, a sub-pixel shift through the whole frame's transform."""
    h, w = sea.shape[1:]
    ky = 2 * np.pi * np.fft.fftfreq(h)[:, None]
    kx = 2 * np.pi * np.fft.rfftfreq(w)[None, :]
    out = np.stack([np.fft.irfft2(np.fft.rfft2(f) * np.exp(-1j * (kx * sx + ky * sy)), s=(h, w))
                    for f, (sx, sy) in zip(sea.astype(np.float64), sway)])
    a, b = (h - side) // 2, (w - side) // 2
    return np.clip(out[:, a:a + side, b:b + side], 0.0, 1.0).astype(np.float32)


def test_the_tiles_moved_back_read_the_shake_nearer_than_their_modes_phases(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """Seas moved by a known sway of 2.5 px: the shake the periodogram takes out, its tiles
    moved back and read again (``JITTER_PIXEL_PASSES``), is nearer the sway than the one
    their windowed modes' phases alone give (one pass), by a quarter over the scenes."""
    sway = _sway(30, 2.5)
    want = _detrended(sway)
    alt = DispersionAltimeter(dispersion="gravity-capillary", attitude="level")
    passes = spectra_module.JITTER_PIXEL_PASSES
    off = {1: [], passes: []}
    for altitude in (6.0, 10.0):
        for seed in (4, 5, 6):
            cfg = preset_config("realistic", size=256, frames=30, seed=seed,
                                altitude_m=(altitude, altitude), wind_speed_mps=(8.0, 8.0),
                                camera_speed_mps=(0.4, 0.4))
            sea = generate_sequence(cfg.sample_scenario(0), cfg).clean.mean(axis=-1)
            clip = _moved_sea(sea, sway, 176)
            for n, errs in off.items():
                with monkeypatch.context() as m:
                    m.setattr(spectra_module, "JITTER_PIXEL_PASSES", n)
                    shake = alt._fit_periodogram(clip)["shake"]
                assert shake is not None
                errs.append(math.sqrt(np.mean((shake - want) ** 2)))
    assert passes > 1
    assert sum(off[passes]) < 0.75 * sum(off[1]), off


def test_modes_that_all_point_one_way_read_no_step_across_them() -> None:
    """Tiles whose readable modes all point within a milliradian of one direction hold no
    step across it: a near-singular solve there read 1300 px from phase noise (and on a
    live clip overflowed its robust weights).  No step is read beyond half the longest
    mode's wavelength, where the phases no longer hold it; the frame's step is then not
    measured."""
    rng = np.random.default_rng(0)
    t, n = 15, 12
    angle, kappa = np.linspace(0.0, 1e-3, n), np.linspace(0.8, 1.0, n)
    kx, ky = kappa * np.cos(angle), kappa * np.sin(angle)
    frames = np.arange(t)[:, None]
    tiles = []
    for _ in range(4):
        phase = (np.linspace(1.0, 2.0, n) * frames + rng.uniform(0.0, 2 * np.pi, n)
                 + rng.normal(0.0, 0.5, (t, n)))
        z = np.exp(1j * phase)
        tiles.append(z - z.mean(axis=0))
    shift = np.stack([tile_shake(z.astype(np.complex64), kx, ky) for z in tiles])
    assert np.all(np.isfinite(shift))
    steps = np.diff(shift, axis=1)
    assert np.abs(steps).max() <= 2.0 * math.pi / kappa.min()
