import json
import os
from pathlib import Path

import numpy as np
import pytest

from wavealt.cli import main
from wavealt.dataset import Dataset, read_manifest, simulate_dataset
from wavealt.io import read_frames_folder
from wavealt.sim.config import SimConfig, derive_seed, preset_config
from wavealt.sim.generate import generate_sequence

SMALL = dict(sequences=5, size=48, frames=4)


def tree_bytes(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    root = tmp_path_factory.mktemp("ref") / "ds"
    simulate_dataset(root, preset_config("paper", **SMALL), progress=False, save_surface=True)
    return root


def test_layout_and_manifest(reference):
    ds = Dataset(reference)
    assert len(ds) == 5
    assert set(ds.conditions) == {"clean", "glinty", "surface"}
    frames = ds.read_frames("clean", "seq_00000")
    assert frames.shape == (4, 48, 48, 3) and frames.dtype == np.float32
    assert sorted(p.name for p in (reference / "glinty" / "seq_00003").iterdir()) == [
        f"frame_{t:03d}.png" for t in range(4)]
    rows = read_manifest(reference / "manifest.csv")
    cfg = preset_config("paper", **SMALL)
    for i, r in enumerate(rows):
        assert r.scenario.seed == derive_seed(42, i)
        assert 1.0 <= r.altitude_m <= 5.0
        assert r.scenario.focal_px == pytest.approx(cfg.focal_px)
    info = json.loads((reference / "dataset.json").read_text())
    assert SimConfig.from_dict(info["config"]) == cfg


def test_surface_ground_truth_matches_images(reference):
    z = np.load(reference / "surface" / "seq_00001.npz")
    assert set(z.files) == {"height_m", "slope_x", "slope_y"}
    for k in z.files:
        assert z[k].shape == (4, 48, 48) and z[k].dtype == np.float32
    cfg = preset_config("paper", **SMALL)
    data = generate_sequence(cfg.sample_scenario(1), cfg, with_height=True)
    assert np.array_equal(z["slope_x"], data.slope_x)
    # slopes are the gradient of the height (central differences on the pixel grid)
    gsd = cfg.sample_scenario(1).altitude_m / cfg.focal_px
    gx = np.gradient(z["height_m"][0], gsd, axis=1)
    corr = np.corrcoef(gx[4:-4, 4:-4].ravel(), z["slope_x"][0][4:-4, 4:-4].ravel())[0, 1]
    assert corr > 0.8
    ds = Dataset(reference)
    stored = ds.read_frames("clean", "seq_00001")
    assert np.abs(stored - data.clean).max() <= 0.5 / 255 + 1e-6


def test_deterministic_and_worker_independent(tmp_path, reference):
    cfg = preset_config("paper", **SMALL)
    simulate_dataset(tmp_path / "w2", cfg, workers=2, progress=False, save_surface=True)
    assert tree_bytes(tmp_path / "w2") == tree_bytes(reference)


def test_subset_regenerates_alone():
    cfg = preset_config("paper", **SMALL)
    bigger = cfg.replace(sequences=9)
    a = generate_sequence(cfg.sample_scenario(3), cfg)
    b = generate_sequence(bigger.sample_scenario(3), bigger)
    assert np.array_equal(a.glinty, b.glinty)


def test_resume_after_interruption(tmp_path, reference):
    cfg = preset_config("paper", **SMALL)
    out = tmp_path / "ds"
    simulate_dataset(out, cfg, progress=False, save_surface=True)
    # simulate a crash: one sequence lost entirely, another half-written (clean only),
    # and a stale temporary folder left behind
    import shutil
    shutil.rmtree(out / "clean" / "seq_00002")
    shutil.rmtree(out / "glinty" / "seq_00002")
    shutil.rmtree(out / "glinty" / "seq_00004")
    (out / "surface" / "seq_00002.npz").unlink()
    (out / "clean" / ".seq_00002.tmp-x").mkdir()
    kept = out / "clean" / "seq_00000" / "frame_000.png"
    mtime = kept.stat().st_mtime_ns
    os.utime(kept, ns=(mtime - 10**9, mtime - 10**9))
    mtime = kept.stat().st_mtime_ns
    simulate_dataset(out, cfg, progress=False, save_surface=True)
    assert kept.stat().st_mtime_ns == mtime  # finished sequences are not redone
    got = {k: v for k, v in tree_bytes(out).items() if ".tmp-" not in k}
    assert got == tree_bytes(reference)


def test_cli_simulate_and_figures(tmp_path, capsys):
    out = tmp_path / "cli"
    main(["simulate", str(out), "--sequences", "2", "--size", "40", "--frames", "3",
          "--seed", "7", "--altitude-m", "2,2"])
    assert (out / "figures" / "fig2_examples.png").is_file()
    assert (out / "figures" / "fig3_generation.png").is_file()
    ds = Dataset(out)
    assert all(r.altitude_m == 2.0 for r in ds.records)


def _expect_error(argv, match, capsys):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("wavealt: error:") and err.count("\n") == 1
    assert match in err
    return err


@pytest.mark.parametrize("extra, match", [
    (["--altitude-m", "0,3"], "altitude_m"),
    (["--altitude-m", "-1"], "altitude_m"),
    (["--altitude-m", "1,16"], "altitude_m"),
    (["--frames", "1"], "frames"),
    (["--size", "16"], "size"),
    (["--preset", "movie"], "unknown preset 'movie'"),
    (["--sequences", "0"], "sequences"),
    (["--workers", "0"], "workers"),
    (["--altitude-m", "a,b"], "--altitude-m"),
    (["--altitude-m", "nan"], "--altitude-m"),
    (["--wind-speed-mps", "1,2,3"], "--wind-speed-mps"),
    (["--frobnicate"], "No such option"),
])
def test_cli_bad_input(tmp_path, capsys, extra, match):
    out = tmp_path / "x"
    _expect_error(["simulate", str(out), "--sequences", "2", "--size", "40", "--frames", "3",
                   "--no-figures"] + extra, match, capsys)
    assert not (out / "clean").exists()


def test_cli_refuses_file_and_foreign_dataset_without_damage(tmp_path, capsys, reference):
    f = tmp_path / "file.txt"
    f.write_text("keep me")
    _expect_error(["simulate", str(f), "--no-figures"], "existing file", capsys)
    assert f.read_text() == "keep me"
    import shutil
    other = tmp_path / "other"
    shutil.copytree(reference, other)
    before = tree_bytes(other)
    _expect_error(["simulate", str(other), "--sequences", "6", "--size", "48", "--frames", "4",
                   "--no-figures"], "different config (sequences: 5 -> 6)", capsys)
    assert tree_bytes(other) == before
    junk = tmp_path / "junk"
    junk.mkdir()
    (junk / "notes.txt").write_text("x")
    _expect_error(["simulate", str(junk), "--no-figures"], "holds no wavealt dataset", capsys)


def test_version(capsys):
    main(["--version"])
    out = capsys.readouterr().out
    assert "wavealt 0.1.0" in out and "numpy" in out and "torch" in out


def test_top_level_help_shows_every_description_whole(capsys):
    main(["--help"])
    out = capsys.readouterr().out
    commands = out.split("Commands:")[1].strip().splitlines()
    assert {c.split()[0] for c in commands} == {"altitude", "deglint", "evaluate", "figures",
                                                 "reproduce", "simulate", "train"}
    assert "..." not in out.split("Commands:")[1]
    assert "Draw the dataset figures (paper Fig. 2 and Fig. 3)." in out


def test_config_rejects_unknown_keys():
    d = preset_config("paper").to_dict()
    d["altitdue_m"] = [1, 2]
    with pytest.raises(ValueError, match="unknown config key.*altitdue_m"):
        SimConfig.from_dict(d)
    d = preset_config("realistic").to_dict()
    d["sensor"]["jpeg_qualty"] = 80
    with pytest.raises(ValueError, match="unknown sensor config key.*jpeg_qualty"):
        SimConfig.from_dict(d)


def test_config_is_nested_per_renderer_and_reads_the_flat_format_1():
    paper = preset_config("paper", **SMALL)
    d = paper.to_dict()
    assert set(d) & {"paper", "realistic", "sensor"} == {"paper"}  # only what it reads
    assert "water_rgb" in d["paper"] and "water_rgb" not in d
    real = preset_config("realistic", **SMALL)
    assert {"realistic", "sensor"} <= set(real.to_dict())
    assert real.sensor.compression == "jpeg" and real.realistic.whitecaps is True
    # dataset.json of format 1 held one flat config
    flat = {k: v for k, v in d.items() if k != "paper"} | d["paper"]
    assert SimConfig.from_dict(flat) == paper
    assert SimConfig.from_dict(json.loads(json.dumps(real.to_dict()))) == real
    # a sub-config's field can be set alone or as a nested change
    assert (preset_config("realistic", compression="none")
            == preset_config("realistic", sensor={"compression": "none"}))


def test_read_frames_errors(tmp_path):
    with pytest.raises(FileNotFoundError, match="frame folder not found"):
        read_frames_folder(tmp_path / "nope")
    (tmp_path / "bad").mkdir()
    (tmp_path / "bad" / "frame_000.png").write_bytes(b"not a png")
    with pytest.raises(ValueError, match="cannot read image"):
        read_frames_folder(tmp_path / "bad")


def test_non_finite_render_is_refused_and_earlier_sequences_kept(tmp_path, monkeypatch):
    import wavealt.sim.paper as sim

    real = sim.render_pair
    calls = {"n": 0}

    def nan_on_third(*args, **kw):
        clean, glinty = real(*args, **kw)
        calls["n"] += 1
        if calls["n"] == 3:
            clean = clean.copy()
            clean[1, 5, 7, 0] = np.nan
        return clean, glinty

    monkeypatch.setattr(sim, "render_pair", nan_on_third)
    cfg = preset_config("paper", **SMALL)
    with pytest.raises(ValueError, match=r"made 1 non-finite clean frame\(s\) for altitude"):
        simulate_dataset(tmp_path / "ds", cfg, progress=False)
    done = sorted(p.name for p in (tmp_path / "ds" / "clean").iterdir() if p.is_dir())
    assert done == ["seq_00000", "seq_00001"]
    assert not (tmp_path / "ds" / "glinty" / "seq_00002").exists()
