"""A steadied fit carries its shake's own error: the corner tiles' scatter about the shift
they share gives one realisation of the reading's noise, and a trusted steadied fit is made
again with its shake that far off, either way, before it is trusted."""

from __future__ import annotations

import math

import numpy as np
import pytest
from contract import assert_honest
from test_dispersion_jitter import _CENTRES, _detrended, _series, _shaken, _sway

from wavealt.altimetry.dispersion import DispersionAltimeter
from wavealt.altimetry.dispersion.jitter import SHAKE_OFF, shake_noise
from wavealt.sim.config import preset_config
from wavealt.sim.generate import generate_sequence


def _tiles(moves: list[np.ndarray], noise: float = 0.0
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mode series of four tiles of one sea (the same modes), tile ``i`` moved by
    ``moves[i]`` ``(T, 2)`` px."""
    tiles, kx, ky = [], None, None
    for m in moves:
        series, kx, ky = _series(m, np.random.default_rng(9), tiles=1, noise=noise)
        tiles.append(series[0])
    return np.stack(tiles), kx, ky


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(x))))


def test_the_noise_realisation_holds_no_shared_shift_and_no_rotation() -> None:
    """Tiles that move only together, by a 2-px sway and a rotation of 0.8 degrees about
    the centre, have no noise to realise: the contrast is a few hundredths of the sway.
    Tiles that each sway their own way give the contrast of their own (less-trend)
    motions, + - - + over the four corners, over four, times sqrt(4 / 3)."""
    sway = _sway(30, 2.0)
    theta = np.radians(0.8) * np.sin(2 * np.pi * 1.1 * np.arange(30) / 30.0 + 1.0)
    together = [sway + theta[:, None] * np.array([-c[1], c[0]])[None, :] for c in _CENTRES]
    series, kx, ky = _tiles(together)
    assert _rms(shake_noise(series, kx, ky)) < 0.05 * _rms(sway)

    rng = np.random.default_rng(2)
    apart = [np.stack([a * np.sin(2 * np.pi * f * np.arange(30) / 30.0 + p)
                       for a, f, p in zip(rng.uniform(0.5, 1.5, 2), rng.uniform(0.7, 1.6, 2),
                                          rng.uniform(0.0, 6.3, 2))], axis=1)
             for _ in range(4)]
    series, kx, ky = _tiles(apart)
    want = sum(s * _detrended(m) for s, m in zip((1, -1, -1, 1), apart)) / 4 * math.sqrt(4 / 3)
    got = shake_noise(series, kx, ky)
    assert _rms(got - want) < 0.2 * _rms(want), (_rms(got - want), _rms(want))
    # another number of tiles: no contrast to take
    assert not np.any(shake_noise(series[:3], kx, ky))


def _clip(altitude: float, seed: int, amp_deg: float) -> tuple[np.ndarray, dict[str, float]]:
    cfg = preset_config("realistic", size=256, frames=30, seed=seed,
                        altitude_m=(altitude, altitude), wind_speed_mps=(8.0, 8.0),
                        camera_speed_mps=(0.4, 0.4))
    sea = generate_sequence(cfg.sample_scenario(0), cfg).clean.mean(axis=-1)
    clip = np.clip(_shaken(sea, cfg.focal_px, amp_deg, 176), 0.0, 1.0)
    return clip, {"fps": cfg.fps, "focal_px": cfg.focal_px}


def _fit(alt: DispersionAltimeter, clip: np.ndarray, kw: dict[str, float], off: float = 0.0):
    """The fit before its shake's error is carried (``_estimate``), its shake ``off``
    realisations of its noise off."""
    token = SHAKE_OFF.set(off)
    try:
        return alt._estimate(clip, velocity_mps=None, **kw)
    finally:
        SHAKE_OFF.reset(token)


@pytest.mark.parametrize(("altitude", "seed"), [(4.0, 5), (9.0, 5)])
def test_a_trusted_steadied_fit_carries_its_shakes_error(altitude: float, seed: int) -> None:
    """A camera shaking by half a degree, steadied and fitted blind (4 m: trusted; 9 m:
    not): the estimate is the fit's, and a trusted fit's uncertainty is the fit's with the
    larger change that its shake taken one noise realisation off (either way) makes, in
    quadrature in log altitude, judged again at the trust bar; an untrusted fit and a still
    camera's fit are not fitted again."""
    clip, kw = _clip(altitude, seed, 0.5)
    alt = DispersionAltimeter(dispersion="gravity-capillary")
    first = _fit(alt, clip, kw)
    assert "+steadied" in first.signal and first.shake_px > 0.0
    res = alt.estimate(clip, **kw)
    assert_honest(res, altitude)
    assert res.altitude_m == first.altitude_m and res.signal == first.signal
    if not first.trusted:  # nothing to carry: the fit as it is
        assert not res.trusted and res.altitude_std_m == first.altitude_std_m
        return
    moved = [_fit(alt, clip, kw, sign) for sign in (1.0, -1.0)]
    change = max(abs(math.log(m.altitude_m / first.altitude_m)) for m in moved)
    assert change > 0.0  # the realisation moves the fit at all
    want = math.hypot(first.altitude_std_m / first.altitude_m, change)
    if res.trusted:
        assert res.altitude_std_m / res.altitude_m == pytest.approx(want, rel=1e-9)
    else:
        assert 3.0 * want > math.log1p(0.10)
        assert res.reason.startswith("3-sigma uncertainty")

    still, kw = _clip(altitude, seed, 0.0)
    level = alt.estimate(still, **kw)
    assert "+steadied" not in level.signal
    again = _fit(alt, still, kw)
    assert (level.altitude_m, level.altitude_std_m) == (again.altitude_m, again.altitude_std_m)


def test_the_noise_realisation_is_taken_on_the_series_the_shake_is_read_on(monkeypatch) -> None:
    """The shake is read on the corner tiles' values as recorded while their normal scores
    are fitted: the first reading taken one realisation off is off by the recorded series'
    own noise (their contrast), which the normal scores' differs from."""
    from wavealt.altimetry.dispersion import spectra

    seen, given = [], []
    real_read, real_steady = spectra.remove_motion_seen, spectra.steady_tiles

    def read(series, recorded, kx, ky, centres):
        out = real_read(series, recorded, kx, ky, centres)
        seen.append((series, recorded, kx, ky, out[1]))
        return out

    def steady(parts, transform, kx, ky, centres, shake, *rest):
        given.append(shake.copy())
        return real_steady(parts, transform, kx, ky, centres, shake, *rest)

    monkeypatch.setattr(spectra, "remove_motion_seen", read)
    monkeypatch.setattr(spectra, "steady_tiles", steady)
    clip, kw = _clip(4.0, 5, 0.5)
    _fit(DispersionAltimeter(dispersion="gravity-capillary"), clip, kw, 1.0)
    assert seen and len(given) == len(seen)
    scores, recorded, kx, ky, shake = seen[0]
    want = shake + shake_noise(recorded, kx, ky)
    np.testing.assert_allclose(given[0], want, rtol=0, atol=1e-9)
    # the normal scores' realisation is another: the test tells the two apart
    assert _rms(shake_noise(scores, kx, ky) - shake_noise(recorded, kx, ky)) > 1e-3
