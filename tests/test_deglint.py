"""Tests of temporal deglinting (paper §3.3): eq. (5)/(6), streaming, methods, metrics, CLI."""

from __future__ import annotations

import json

import numpy as np
import pytest

from wavealt.cli import main
from wavealt.dataset import Dataset, simulate_dataset
from wavealt.deglint import (
    METHODS,
    apply_method,
    condition_name,
    deglint_dataset,
    glint_mask,
    mae,
    method_names,
    psnr_db,
    sliding_min_stream,
    ssim,
    temporal_minimum,
    tmf_residual,
    window_bounds,
)
from wavealt.io import write_png
from wavealt.sim.config import preset_config

DTYPES = (np.uint8, np.float32)
# a clean-image method on a glint-free smooth sequence may move a pixel by at most this much
GLINT_FREE_MAE = {"tmf-min": 0.02, "median": 0.01, "percentile": 0.015, "glint-mask": 0.002,
                  "achromatic": 0.002}
SSIM_ATOL = 1e-6  # ssim filters in float32


def naive_min(x: np.ndarray, window: int) -> np.ndarray:
    """Eq. (5) written out: min over t' in [t - w//2, t + w//2] clipped to the sequence."""
    h = window // 2
    n = len(x)
    return np.stack([x[max(0, t - h):min(n, t + h + 1)].min(axis=0) for t in range(n)])


def random_frames(rng: np.random.Generator, shape: tuple[int, ...], dtype) -> np.ndarray:
    x = rng.random(shape, dtype=np.float32)
    return (x * 255).astype(np.uint8) if dtype == np.uint8 else x


def smooth_sequence(n: int = 12, size: int = 16) -> np.ndarray:
    """A slowly drifting smooth wave pattern, glint-free, in [0.2, 0.6]."""
    t = np.arange(n, dtype=np.float32)[:, None, None]
    yy, xx = np.mgrid[0:size, 0:size].astype(np.float32)
    lum = 0.4 + 0.2 * np.sin(0.4 * xx + 0.3 * yy + 0.05 * t)
    return np.repeat(lum[..., None], 3, axis=-1).astype(np.float32) * np.array(
        [0.6, 0.9, 1.0], np.float32)


def add_spikes(x: np.ndarray, rng: np.random.Generator, n_spikes: int = 30):
    """Isolated one-frame glint spikes (at most one per pixel) on top of ``x``."""
    y = x.copy()
    n, hgt, wid = x.shape[:3]
    flat = rng.choice(hgt * wid, size=n_spikes, replace=False)
    ts = rng.integers(0, n, size=n_spikes)
    rows, cols = np.unravel_index(flat, (hgt, wid))
    y[ts, rows, cols] = np.minimum(1.0, y[ts, rows, cols] + 0.35)
    return y, (ts, rows, cols)


# -- eq. (5) ---------------------------------------------------------------------------
@pytest.mark.parametrize("dtype", DTYPES)
@pytest.mark.parametrize("window", [1, 2, 3, 4, 5, 10, 11, 25])
@pytest.mark.parametrize("n", [2, 3, 10, 17])
def test_temporal_minimum_matches_the_equation(dtype, window, n):
    x = random_frames(np.random.default_rng(n * 100 + window), (n, 5, 7, 3), dtype)
    out = temporal_minimum(x, window=window)
    assert out.dtype == x.dtype and out.shape == x.shape
    np.testing.assert_array_equal(out, naive_min(x, window))


def test_window_convention_at_the_ends():
    # frame t holds the value t + 1 everywhere: the minimum is the window's first frame + 1
    n = 10
    x = np.broadcast_to((np.arange(n, dtype=np.float32)[:, None, None, None] + 1) / 20,
                        (n, 2, 2, 3))
    out = temporal_minimum(x, window=10)
    first = [window_bounds(t, n, 10)[0] for t in range(n)]
    assert first == [0, 0, 0, 0, 0, 0, 1, 2, 3, 4]
    assert [window_bounds(t, n, 10)[1] for t in range(n)] == [5, 6, 7, 8, 9, 9, 9, 9, 9, 9]
    np.testing.assert_array_equal(out[:, 0, 0, 0], (np.array(first, np.float32) + 1) / 20)
    # on the increasing sequence 1 - x the minimum is the window's last frame
    top = 1 - temporal_minimum(1 - x, window=10)
    last = [window_bounds(t, n, 10)[1] for t in range(n)]
    np.testing.assert_allclose(top[:, 0, 0, 0], (np.array(last, np.float32) + 1) / 20, atol=1e-6)
    # even w and w + 1 share one window (t - w//2 .. t + w//2)
    np.testing.assert_array_equal(out, temporal_minimum(x, window=11))


def test_transient_spikes_vanish_from_the_baseline():
    rng = np.random.default_rng(1)
    clean = np.full((10, 16, 16, 3), 0.3, np.float32)
    clean += np.linspace(0, 0.2, 16, dtype=np.float32)[None, None, :, None]
    glinty, (ts, rows, cols) = add_spikes(clean, rng)
    base = temporal_minimum(glinty, window=10)
    np.testing.assert_array_equal(base, clean)  # background constant in time: exact
    res = tmf_residual(glinty, window=10)
    np.testing.assert_allclose(res, glinty - clean, atol=1e-7)
    assert np.all(res[ts, rows, cols] > 0.3)


@pytest.mark.parametrize("dtype", DTYPES)
def test_constant_sequence_and_window_one_give_zero_residual(dtype):
    const = np.full((6, 4, 5, 3), 0.7 if dtype == np.float32 else 180, dtype)
    assert not tmf_residual(const).any()
    x = random_frames(np.random.default_rng(2), (6, 4, 5, 3), dtype)
    r1 = tmf_residual(x, window=1)
    assert r1.dtype == dtype and r1.shape == x.shape and not r1.any()


@pytest.mark.parametrize("dtype", DTYPES)
def test_residual_is_in_range_and_adds_back(dtype):
    x = random_frames(np.random.default_rng(3), (8, 6, 6, 3), dtype)
    res, base = tmf_residual(x, window=4), temporal_minimum(x, window=4)
    assert res.dtype == dtype
    if dtype == np.uint8:
        np.testing.assert_array_equal(res.astype(int) + base, x)
    else:
        assert res.min() >= 0 and res.max() <= 1
        np.testing.assert_allclose(res + base, x, atol=1e-6)


def test_non_contiguous_and_gray_input():
    x = random_frames(np.random.default_rng(4), (9, 8, 10, 3), np.float32)
    view = x[:, ::2, ::-1]
    np.testing.assert_array_equal(temporal_minimum(view, window=5), naive_min(view, 5))
    gray = x[..., 0]
    np.testing.assert_array_equal(temporal_minimum(gray, window=3), naive_min(gray, 3))


# -- streaming -------------------------------------------------------------------------
@pytest.mark.parametrize("dtype", DTYPES)
@pytest.mark.parametrize("window", [1, 2, 3, 7, 10, 40])
@pytest.mark.parametrize("n", [2, 5, 11, 23])
def test_streaming_equals_batch_bit_for_bit(dtype, window, n):
    x = random_frames(np.random.default_rng(n + 7 * window), (n, 4, 6, 3), dtype)
    stream = list(sliding_min_stream(iter(x), window=window))
    assert len(stream) == n
    fast = list(sliding_min_stream(iter(x), window=window, copy=False))
    np.testing.assert_array_equal(np.stack(fast), np.stack(stream))
    assert all(s.dtype == x.dtype and s.shape == x.shape[1:] for s in stream)
    np.testing.assert_array_equal(np.stack(stream), temporal_minimum(x, window=window))


def test_streaming_copes_with_a_reused_producer_buffer():
    x = random_frames(np.random.default_rng(5), (40, 4, 4, 3), np.float32)  # ring wraps

    def producer():
        buf = np.empty_like(x[0])
        for f in x:
            buf[...] = f
            yield buf
        buf[...] = 0.0  # scribbled after the last frame was handed over

    out = np.stack(list(sliding_min_stream(producer(), window=6)))
    np.testing.assert_array_equal(out, naive_min(x, 6))


def test_streaming_memory_is_bounded_by_the_window():
    # a long stream (200 frames) must not be buffered whole: outputs arrive after h frames
    x = random_frames(np.random.default_rng(6), (4, 4, 3), np.uint8)
    read = []

    def producer():
        for t in range(200):
            read.append(t)
            yield x

    gen = sliding_min_stream(producer(), window=10)
    next(gen)
    assert len(read) <= 2 * 11  # frame 0 comes out within two blocks of 2h + 1 frames
    for _ in range(50):
        next(gen)
    assert len(read) <= 51 + 2 * 11


@pytest.mark.parametrize(("frames", "match"), [
    ([], "no frames"),
    ([np.zeros((4, 4, 3), np.float32)], "at least 2"),
    ([np.zeros((4, 4, 3), np.float32), np.zeros((4, 5, 3), np.float32)], "frame 1 is"),
    ([np.zeros((4, 4, 3), np.float32), np.full((4, 4, 3), np.nan, np.float32)], "finite"),
    ([np.zeros((4, 4, 3), np.float32), np.full((4, 4, 3), 1.5, np.float32)], r"\[0, 1\]"),
    ([np.zeros((4, 4, 3), np.int16)] * 2, "dtype"),
])
def test_streaming_bad_input(frames, match):
    with pytest.raises(ValueError, match=match):
        list(sliding_min_stream(iter(frames), window=3))


# -- methods ---------------------------------------------------------------------------
def test_method_registry_and_names():
    assert {"tmf-min", "median", "percentile", "glint-mask"} <= set(METHODS)
    assert method_names()[0] == "tmf"
    assert condition_name("tmf") == "residual"
    for m in METHODS:
        assert condition_name(m) == m
    with pytest.raises(ValueError, match="method must be one of tmf, tmf-min"):
        apply_method(np.zeros((3, 2, 2, 3), np.float32), "nope")
    with pytest.raises(ValueError, match="method must be one of"):
        condition_name("bogus")


@pytest.mark.parametrize("dtype", DTYPES)
@pytest.mark.parametrize("method", method_names())
def test_every_method_keeps_shape_dtype_and_range(method, dtype):
    x = random_frames(np.random.default_rng(8), (7, 5, 6, 3), dtype)
    out = apply_method(x, method, window=4)
    assert out.shape == x.shape and out.dtype == x.dtype
    if dtype == np.float32:
        assert np.isfinite(out).all() and out.min() >= 0 and out.max() <= 1
    # frames untouched
    np.testing.assert_array_equal(x, random_frames(np.random.default_rng(8), x.shape, dtype))


@pytest.mark.parametrize("method", list(METHODS))
def test_methods_change_a_glint_free_sequence_little(method):
    x = smooth_sequence()
    err = mae(apply_method(x, method, window=10), x)
    assert err <= GLINT_FREE_MAE[method]


@pytest.mark.parametrize("method", list(METHODS))
def test_methods_remove_isolated_spikes(method):
    clean = smooth_sequence()
    glinty, spikes = add_spikes(clean, np.random.default_rng(9), n_spikes=60)
    est = apply_method(glinty, method, window=10)
    assert np.abs(glinty[spikes] - clean[spikes]).min() > 0.3
    assert np.abs(est[spikes] - clean[spikes]).max() < 0.06  # background drift only
    assert psnr_db(est, clean) > psnr_db(glinty, clean)


def test_glint_mask_flags_exactly_the_spikes():
    clean = smooth_sequence()
    glinty, (ts, rows, cols) = add_spikes(clean, np.random.default_rng(10), n_spikes=40)
    mask = glint_mask(glinty, window=10)
    expect = np.zeros(mask.shape, bool)
    expect[ts, rows, cols] = True
    np.testing.assert_array_equal(mask, expect)
    est = apply_method(glinty, "glint-mask", window=10)
    np.testing.assert_array_equal(est[~expect], glinty[~expect])  # unflagged samples untouched


def test_achromatic_removes_persistent_white_glint():
    # glint that stays on the same pixels in every frame defeats every temporal method; as
    # white light added to a scene whose colours lie on one line, it is still removable
    clean = smooth_sequence(n=6, size=24)
    spot = np.zeros((24, 24), np.float32)
    spot[4:12, 6:18] = 0.25
    glinty = np.clip(clean + spot[None, :, :, None], 0, 1)
    est = apply_method(glinty, "achromatic", window=10)
    assert mae(est, clean) < 0.1 * mae(glinty, clean)
    assert mae(apply_method(glinty, "tmf-min", window=10), clean) > 0.5 * mae(glinty, clean)
    with pytest.raises(ValueError, match="achromatic needs RGB"):
        apply_method(glinty[..., 0], "achromatic")


@pytest.mark.parametrize("method", method_names())
def test_methods_bad_input(method):
    good = np.zeros((4, 3, 3, 3), np.float32)
    cases = [
        (good, {"window": 0}, "window must be an integer >= 1"),
        (good, {"window": 2.5}, "window must be an integer"),
        (good, {"window": True}, "window must be an integer"),
        (good[:1], {}, "at least 2 frames"),
        (np.full((3, 3, 3, 3), np.nan, np.float32), {}, "NaN"),
        (np.full((3, 3, 3, 3), 1.2, np.float32), {}, r"must be in \[0, 1\]"),
        (np.full((3, 3, 3, 3), -0.1, np.float32), {}, r"must be in \[0, 1\]"),
        (np.zeros((3, 3, 3, 4), np.float32), {}, "must be"),
        ([np.zeros((3, 3, 3)), np.zeros((3, 4, 3))], {}, "."),
    ]
    for frames, kw, match in cases:
        with pytest.raises(ValueError, match=match):
            apply_method(frames, method, **kw)


# -- metrics ---------------------------------------------------------------------------
def test_psnr_mae_exact_values():
    a = np.full((2, 16, 16, 3), 0.5, np.float32)
    b = a + np.float32(0.1)
    assert psnr_db(b, a) == pytest.approx(20.0, abs=1e-5)  # 10 log10(1 / 0.01)
    assert mae(b, a) == pytest.approx(0.1, abs=1e-6)
    assert psnr_db(a, a) == float("inf")
    with pytest.raises(ValueError, match="one shape"):
        mae(a, a[0])


def test_ssim_invariants():
    rng = np.random.default_rng(11)
    x = smooth_sequence(n=3, size=32)
    assert ssim(x, x) == pytest.approx(1.0, abs=SSIM_ATOL)
    scores = [ssim(np.clip(x + s * rng.standard_normal(x.shape), 0, 1), x)
              for s in (0.01, 0.05, 0.2)]
    assert 1.0 > scores[0] > scores[1] > scores[2] > -1.0
    y = np.clip(x + 0.05 * rng.standard_normal(x.shape), 0, 1)
    assert ssim(x, y) == pytest.approx(ssim(y, x), abs=SSIM_ATOL)
    # a frame stack scores the mean of its frames
    per_frame = np.mean([ssim(x[i], y[i]) for i in range(3)])
    assert ssim(x, y) == pytest.approx(per_frame, abs=SSIM_ATOL)


# -- dataset and command line ----------------------------------------------------------
@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    root = tmp_path_factory.mktemp("deglint") / "ds"
    simulate_dataset(root, preset_config("paper", sequences=4, size=32, frames=6), progress=False)
    return root


def test_deglint_dataset_writes_registers_and_measures(dataset):
    cond = deglint_dataset(dataset, method="tmf", window=4, progress=False)
    assert cond == "residual"
    ds = Dataset(dataset)
    info = ds.info["conditions"]["residual"]
    assert (info["method"], info["window"], info["complete"]) == ("tmf", 4, True)
    rec = ds.records[0].sequence_id
    on_disk = ds.read_frames("residual", rec)
    expect = tmf_residual(ds.read_frames("glinty", rec), window=4)
    assert np.abs(on_disk - expect).max() <= 0.5 / 255 + 1e-6  # only 8-bit rounding
    assert sorted(p.name for p in (dataset / "residual" / rec).iterdir()) == \
        sorted(p.name for p in (dataset / "clean" / rec).iterdir())
    deglint_dataset(dataset, method="tmf-min", window=4, progress=False)
    metrics = json.loads((dataset / "deglint_metrics.json").read_text())
    assert {"glinty", "residual", "tmf-min"} <= set(metrics)  # merged, not replaced
    for m in metrics.values():
        assert m["n_sequences"] == 4 and m["n_frames"] == 24
        assert 0 <= m["mae"] <= 1 and -1 <= m["ssim"] <= 1
    # the baseline row is the untouched glinty frames
    g = [ds.read_frames("glinty", r.sequence_id) for r in ds.records]
    c = [ds.read_frames("clean", r.sequence_id) for r in ds.records]
    assert metrics["glinty"]["mae"] == pytest.approx(mae(np.stack(g), np.stack(c)), rel=1e-9)
    table = (dataset / "deglint_table.md").read_text()
    psnrs = [float(line.split("|")[6]) for line in table.splitlines()[2:]]
    assert psnrs == sorted(psnrs, reverse=True) and len(psnrs) == len(metrics)


def test_deglint_dataset_resumes_and_refuses_other_settings_unless_forced(dataset):
    deglint_dataset(dataset, method="median", window=4, progress=False)
    seq = dataset / "median" / "seq_00000" / "frame_000.png"
    stamp = seq.stat().st_mtime_ns
    deglint_dataset(dataset, method="median", window=4, progress=False)
    assert seq.stat().st_mtime_ns == stamp  # kept
    with pytest.raises(ValueError, match=r"condition median was made with method median, "
                                         r"window 4; --force rewrites it"):
        deglint_dataset(dataset, method="median", window=2, progress=False)
    assert seq.stat().st_mtime_ns == stamp  # refused: nothing replaced
    with pytest.raises(ValueError, match=r"window 50 is longer than the sequences \(\d+ frames\)"):
        deglint_dataset(dataset, method="median", window=50, progress=False, force=True)
    deglint_dataset(dataset, method="median", window=2, progress=False, force=True)
    assert seq.stat().st_mtime_ns != stamp  # other window, forced: rewritten
    ds = Dataset(dataset)
    assert ds.info["conditions"]["median"]["window"] == 2
    rec = ds.records[1].sequence_id
    expect = apply_method(ds.read_frames("glinty", rec), "median", window=2)
    assert np.abs(ds.read_frames("median", rec) - expect).max() <= 0.5 / 255 + 1e-6


def test_deglint_dataset_bad_input_writes_nothing(tmp_path, dataset):
    import shutil

    root = tmp_path / "ds"
    shutil.copytree(dataset, root)
    for c in ("residual", "tmf-min", "median"):
        shutil.rmtree(root / c, ignore_errors=True)
    before = (root / "dataset.json").read_text()
    with pytest.raises(ValueError, match="window must be an integer >= 1"):
        deglint_dataset(root, window=0, progress=False)
    # one sequence with frames of another size
    write_png(root / "glinty" / "seq_00002" / "frame_003.png", np.zeros((20, 32, 3), np.uint8))
    with pytest.raises(ValueError, match="different sizes"):
        deglint_dataset(root, progress=False)
    # one sequence of one frame
    shutil.rmtree(root / "glinty" / "seq_00002")
    (root / "glinty" / "seq_00002").mkdir()
    write_png(root / "glinty" / "seq_00002" / "frame_000.png", np.zeros((32, 32, 3), np.uint8))
    with pytest.raises(ValueError, match="at least 2"):
        deglint_dataset(root, progress=False)
    shutil.rmtree(root / "glinty")
    with pytest.raises(FileNotFoundError, match="no condition 'glinty'"):
        deglint_dataset(root, progress=False)
    assert not (root / "residual").exists()
    assert (root / "dataset.json").read_text() == before


def test_cli_deglint(dataset, tmp_path, capsys):
    main(["deglint", str(dataset), "--method", "percentile", "--window", "3", "--no-figures"])
    out = capsys.readouterr().out
    assert "percentile" in out and "| rank |" in out
    assert Dataset(dataset).info["conditions"]["percentile"]["window"] == 3
    for argv, match in [(["--window", "0"], "window must be an integer >= 1"),
                        (["--method", "bogus"], "method must be one of")]:
        with pytest.raises(SystemExit) as exc:
            main(["deglint", str(dataset), *argv])
        assert exc.value.code == 2
        err = capsys.readouterr().err
        assert err.startswith("wavealt: error:") and match in err and err.count("\n") == 1
    with pytest.raises(SystemExit):
        main(["deglint", str(tmp_path / "missing")])
    assert "no dataset.json" in capsys.readouterr().err


def test_figures(dataset, tmp_path):
    from wavealt.plots import deglint_figures, figure_pixel_trace

    paths = deglint_figures(dataset, tmp_path / "fig", window=4)
    assert [p.name for p in paths] == ["fig4_tmf_decomposition.png", "fig7_pixel_trace.png"]
    assert all(p.stat().st_size > 1000 for p in paths)
    x = smooth_sequence(n=5, size=8)
    with pytest.raises(ValueError, match="pixel must be inside"):
        figure_pixel_trace(x, tmp_path / "p.png", pixel=(8, 0))
