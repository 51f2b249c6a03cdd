"""The ``realistic`` preset end to end: config, validation, determinism, dataset folder."""

from __future__ import annotations

import json

import numpy as np
import pytest

from wavealt.dataset import simulate_dataset
from wavealt.sim.config import PRESETS, SimConfig, preset_config
from wavealt.sim.generate import generate_sequence

COMMON_KEYS = {
    "preset", "renderer", "sequences", "frames", "size", "fov_deg", "fps", "seed", "split_seed",
    "split", "altitude_m", "wind_speed_mps", "wind_dir_deg", "sun_zenith_deg", "sun_azimuth_deg",
    "glint_severity", "camera_speed_mps", "camera_dir_deg", "domain_pad", "refractive_index",
}
PAPER_KEYS = {"water_rgb", "sky_rgb", "display_rgb", "contrast", "lobe_exponent",
              "clean_glint_severity"}


def small(name: str = "realistic", **kw) -> SimConfig:
    kw = {"sequences": 3, "size": 64, "frames": 4, **kw}
    return preset_config(name, **kw)


def test_config_dict_is_common_plus_the_renderers_sections_and_round_trips():
    cfg = small("paper")
    d = cfg.to_dict()
    assert set(d) == COMMON_KEYS | {"paper"} and set(d["paper"]) == PAPER_KEYS
    assert SimConfig.from_dict(cfg.to_dict()) == cfg
    real = small()
    d = real.to_dict()
    assert set(d) == COMMON_KEYS | {"realistic", "sensor"}
    assert d["renderer"] == "realistic" and d["sensor"]["compression"] == "jpeg"
    assert SimConfig.from_dict(json.loads(json.dumps(d))) == real


def test_preset_spans_calm_to_fresh_high_to_low_sun_up_to_15_m():
    p = PRESETS["realistic"]
    assert p["altitude_m"][1] == 15.0
    assert p["wind_speed_mps"][0] <= 2.0 and p["wind_speed_mps"][1] >= 10.0
    assert p["sun_zenith_deg"][0] <= 10.0 and p["sun_zenith_deg"][1] >= 70.0
    assert p["camera_speed_mps"][1] > 0
    assert p["realistic"]["roll_deg"][1] > 0 and p["realistic"]["pitch_deg"][1] > 0


@pytest.mark.parametrize(("overrides", "message"), [
    ({"wind_speed_mps": (-1.0, 5.0)}, "wind_speed_mps must be > 0; got -1"),
    ({"sun_zenith_deg": (10.0, 95.0)}, "sun_zenith_deg must be < 90; got 95"),
    ({"fov_deg": 180.0}, "fov_deg must be < 180; got 180"),
    ({"altitude_m": (1.0, 20.0)}, "altitude_m must be <= 15; got 20"),
    ({"roll_deg": (-30.0, 3.0)}, "roll_deg must be >= -20; got -30"),
    ({"vignetting": (0.0, 1.5)}, "vignetting must be <= 1; got 1.5"),
    ({"inverse_wave_age": (0.5, 1.0)}, "inverse_wave_age must be >= 0.83; got 0.5"),
    ({"spreading_s": (5.0, 1.0)}, r"spreading_s must be a range \(low, high\)"),
    ({"compression": "gif"}, "compression must be one of none, jpeg, h264; got 'gif'"),
    ({"renderer": "raytrace"}, "renderer must be one of paper, realistic; got 'raytrace'"),
    ({"spectrum": "pm"}, "spectrum must be one of elfouhaily, jonswap; got 'pm'"),
    ({"whitecaps": "yes"}, "whitecaps must be true or false"),
    ({"compression": "h264", "size": 65}, "compression 'h264' needs an even size; got size 65"),
])
def test_out_of_range_parameters_get_clear_errors(overrides, message):
    with pytest.raises(ValueError, match=message):
        small(**overrides)


def test_realistic_sequence_contract_and_determinism():
    cfg = small(compression="none")
    s = cfg.sample_scenario(1)
    a = generate_sequence(s, cfg, with_height=True)
    b = generate_sequence(s, cfg, with_height=True)
    for x in (a.clean, a.glinty):
        assert x.shape == (4, 64, 64, 3) and x.dtype == np.float32
        assert x.min() >= 0.0 and x.max() <= 1.0
    assert a.height_m.shape == (4, 64, 64)
    np.testing.assert_array_equal(a.clean, b.clean)
    np.testing.assert_array_equal(a.glinty, b.glinty)
    assert np.all(a.glinty >= a.clean)  # shared exposure and noise; glint only adds
    other = generate_sequence(cfg.sample_scenario(2), cfg)
    assert not np.array_equal(other.clean, a.clean)
    assert a.clean.std() > 0.01  # the sea has texture


def test_glint_appears_where_the_sun_is_mirrored():
    cfg = small(compression="none", sun_zenith_deg=(10.0, 10.0), wind_speed_mps=(5.0, 5.0),
                glint_severity=(1.0, 1.0), whitecaps=False, size=96)
    data = generate_sequence(cfg.sample_scenario(0), cfg)
    extra = (data.glinty - data.clean).mean(axis=(0, 3))
    assert extra.mean() > 0.01
    sun_low = small(compression="none", sun_zenith_deg=(70.0, 70.0), wind_speed_mps=(5.0, 5.0),
                    glint_severity=(1.0, 1.0), whitecaps=False, size=96)
    low = generate_sequence(sun_low.sample_scenario(0), sun_low)
    assert (low.glinty - low.clean).mean() < 0.2 * extra.mean()


def test_realistic_dataset_folder(tmp_path):
    cfg = small(sequences=2)
    out = simulate_dataset(tmp_path / "ds", cfg, progress=False)
    info = json.loads((out / "dataset.json").read_text())
    assert info["config"]["renderer"] == "realistic"
    header = (out / "manifest.csv").read_text().splitlines()[0]
    assert header.startswith("sequence_id,split,altitude_m,wind_speed_mps")
    assert sorted(p.name for p in (out / "glinty").iterdir()) == ["seq_00000", "seq_00001"]
    assert len(list((out / "glinty" / "seq_00000").glob("*.png"))) == 4


def test_figure_presets_writes_a_png(tmp_path):
    from wavealt.plots import figure_presets

    out = figure_presets(tmp_path / "presets.png", size=48)
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_altitude_reaches_the_sea_only_through_the_grid_spacing():
    """The spectrum built for a scenario does not depend on the altitude; the grid spacing
    is the GSD, and the slope budget is the same physical total at every altitude."""
    import dataclasses

    from wavealt.sim.realistic import make_sea, realistic_draws

    cfg = small(size=64)
    base = cfg.sample_scenario(0)
    seas = []
    for alt in (1.5, 6.0, 15.0):
        scen = dataclasses.replace(base, altitude_m=alt)
        sea = make_sea(scen, cfg, realistic_draws(scen, cfg))
        assert sea.dx_m == pytest.approx(alt / scen.focal_px)
        seas.append(sea)
    for attr in ("level", "slope_variance", "k_peak", "spreading_s", "inverse_wave_age"):
        assert len({getattr(s.spectrum, attr) for s in seas}) == 1, attr
    totals = [s.resolved_slope_variance + s.long_slope_variance + s.subpixel_slope_variance
              for s in seas]
    np.testing.assert_allclose(totals, seas[0].spectrum.slope_variance, rtol=1e-9)


def test_a_folder_of_another_renderer_is_refused_naming_the_difference(tmp_path):
    out = simulate_dataset(tmp_path / "ds", small(sequences=1, frames=2, size=32,
                                                  compression="none"), progress=False)
    with pytest.raises(ValueError, match=r"holds a dataset made with a different config \(.*"
                                         r"renderer: 'realistic' -> 'paper'.*"
                                         r"sensor.compression: 'none' -> '-'"):
        simulate_dataset(out, small("paper", sequences=1, frames=2, size=32), progress=False)
