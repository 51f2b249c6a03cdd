"""``benchmarks/bench_dispersion.py``: its options reach the simulator, bad ones are refused
with one line, and its cache tells frames of an older simulator from the current ones."""

from __future__ import annotations

import csv
import gzip
import json
import subprocess
import sys
from pathlib import Path

import pytest
from benchmodule import bench_module

BENCH = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_dispersion.py"


def _run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(BENCH), *args], capture_output=True, text=True,
                          timeout=300)


@pytest.mark.parametrize(("args", "message"), [
    (("--compression", "png"), "invalid choice: 'png'"),
    (("--compression", "h264", "--jpeg-quality", "50"), "--jpeg-quality needs the jpeg encoder"),
    (("--jpeg-quality", "0"), "--jpeg-quality must be in 1-100"),
    (("--h264-crf", "18"), "--h264-crf needs --compression h264; got --compression None"),
    (("--compression", "h264", "--h264-crf", "52"), "--h264-crf must be in 0-51; got 52"),
    (("--compression", "jpeg", "--h264-preset", "medium"),
     "--h264-preset needs --compression h264"),
    (("--compression", "h264", "--h264-preset", "turbo"), "invalid choice: 'turbo'"),
    (("--rows", "realistic-30-blnd"), "--rows: unknown"),
    (("--fps", "2"), "--fps must be within 5-240; got 2"),
    (("--fov-deg", "170"), "--fov-deg must be within 10-150; got 170"),
    (("--rows", "realistic-2-blind"), "--rows: unknown ['realistic-2-blind']"),
    (("--attitude", "tilted"), "argument --attitude: invalid choice: 'tilted'"),
    (("--attitude-sigma-deg", "0"), "--attitude-sigma-deg must be in (0, 15] degrees; got 0"),
    (("--attitude", "level", "--attitude-sigma-deg", "1"),
     "--attitude-sigma-deg goes with --attitude estimate"),
    (("--redraw", "run.csv"), "--redraw needs --figure (the PNG to draw)"),
    (("--aspect", "16x9"), "--aspect must be W:H, two whole numbers within 1:4-4:1; got '16x9'"),
    (("--redraw", "/nonexistent/run.csv", "--figure", "f.png"),
     "--redraw: [Errno 2] No such file or directory: '/nonexistent/run.csv'"),
])
def test_bad_options_are_refused_in_one_line(args, message) -> None:
    res = _run(*args)
    assert res.returncode == 2
    assert message in res.stderr.strip().splitlines()[-1]


def test_the_encoder_option_reaches_the_realistic_frames(tmp_path) -> None:
    """Uncompressed and JPEG frames of one sequence differ, the run records the encoder, and
    every window is reported."""
    runs = {}
    for comp, extra in (("none", ()), ("jpeg", ("--jpeg-quality", "40"))):
        out = tmp_path / f"{comp}.json"
        res = _run("--rows", "realistic-10-exact", "--seeds", "3", "--sequences", "1",
                   "--size", "128", "--no-cache", "--compression", comp, *extra,
                   "--out", str(out))
        assert res.returncode == 0, res.stderr[-2000:]
        runs[comp] = json.loads(out.read_text())
        assert runs[comp]["settings"]["realistic_camera"]["compression"] == comp
        lines = out.with_suffix(".csv").read_text().splitlines()
        assert len(lines) == 3  # header, clean, glinty
        # each window names the path its estimate took and the turn it read
        for rec in csv.DictReader(lines):
            assert rec["signal"].split("/")[0] in ("luma", "chroma"), rec["signal"]
            assert float(rec["yaw_rate_dps"]) == 0.0 or "+yaw" in rec["signal"]
    assert runs["jpeg"]["settings"]["realistic_camera"]["jpeg_quality"] == 40
    est = [[line.split(",")[8] for line in (tmp_path / f"{c}.csv").read_text().splitlines()[1:]]
           for c in ("none", "jpeg")]
    assert est[0] != est[1]


def _bench_module():
    return bench_module("bench_dispersion")


def test_the_frame_rate_reaches_both_presets_and_the_encoder_only_the_realistic() -> None:
    """``--fps`` and ``--fov-deg`` are the camera's, so both renderers take them (and the
    cache tells the clips apart); the encoder's settings are the realistic camera's alone."""
    bench = _bench_module()
    sensor = (("compression", "none"), ("fps", 60.0), ("fov_deg", 90.0))
    paper, realistic = (bench.sim_config(p, 10, 3, 1, 64, sensor) for p in ("paper",
                                                                             "realistic"))
    assert paper.fps == realistic.fps == 60.0
    assert paper.fov_deg == realistic.fov_deg == 90.0
    assert realistic.sensor.compression == "none"
    assert bench.cache_folder(paper) != bench.cache_folder(bench.sim_config("paper", 10, 3,
                                                                            1, 64))


def test_the_attitude_option_reaches_the_altimeter_of_every_task() -> None:
    """``--attitude level`` (a camera told to look straight down) travels with each task to
    the worker's altimeter, and so does ``--attitude-sigma-deg`` (a gimbal's prior of the tilt
    measured); without them the altimeter measures the tilt, as a user's does."""
    bench = _bench_module()
    row = bench.ROW_BY_NAME["realistic-30-blind"]
    for attitude in ("estimate", "level"):
        (task,) = bench.tasks_of([row], [3], 1, 64, False, (), attitude)
        assert task[7:9] == (attitude, None)
        assert bench.estimator(row.dispersion, attitude).attitude == attitude
    assert bench.tasks_of([row], [3], 1, 64, False)[0][7:] == ("estimate", None, None)
    # a gimbal's prior (--attitude-sigma-deg) travels with the tasks too
    (task,) = bench.tasks_of([row], [3], 1, 64, False, (), "estimate", 2.0)
    assert bench.estimator(row.dispersion, *task[7:9]).attitude_sigma_deg == 2.0


def test_the_aspect_crops_the_frames_the_altimeter_reads(monkeypatch) -> None:
    """``--aspect`` travels with the tasks, and each window is read on the middle of its
    frames at that width : height (a video camera's frame), the focal length unchanged."""
    bench = _bench_module()
    row = bench.ROW_BY_NAME["paper-10-exact"]
    (task,) = bench.tasks_of([row], [3], 1, 64, False, (), "estimate", None, (16, 9))
    assert task[-1] == (16, 9)
    seen = []
    timed = bench.timed_estimate

    def spy(row, frames, cfg, *args):
        seen.append((frames.shape, cfg.focal_px))
        return timed(row, frames, cfg, *args)

    monkeypatch.setattr(bench, "timed_estimate", spy)
    recs = bench.run_sequence(task)
    focal = bench.sim_config("paper", 10, 3, 1, 64).focal_px
    assert seen == [((10, 36, 64, 3), focal)] * 2
    assert [r["status"] for r in recs] == ["ok", "ok"]


def test_a_row_of_any_length_is_judged_against_the_contract_alone() -> None:
    """``PRESET-FRAMES-MODE`` names a row the issue's table does not have (a second at 60
    fps: ``realistic-60-blind``); it has no MAE target, so its ``met`` holds the contract's
    keys alone, and the table's rows keep theirs."""
    bench = _bench_module()
    row = bench.row_of("realistic-60-blind")
    assert (row.preset, row.frames, row.mode, row.clean_mae_pct) == ("realistic", 60, "blind",
                                                                     None)
    assert bench.row_of("realistic-30-blind") is bench.ROW_BY_NAME["realistic-30-blind"]
    assert bench.row_of("sea-30-blind") is None and bench.row_of("paper-9999-exact") is None
    good = {"n": 4, "trusted_off_10pct": 0, "coverage_3sigma_all": 1.0, "trusted_share": 1.0,
            "rel_mae_pct": 50.0, "median_abs_rel_pct": 9.0, "latency_ms_median": 1.0}
    m = {c: good for c in bench.CONDITIONS}
    assert bench.met_of(row, m) == {"no_trusted_off_10pct": True, "coverage_3sigma": True,
                                    "trusted_share_aim": True}
    assert not bench.met_of(bench.ROW_BY_NAME["realistic-30-blind"], m)["clean_rel_mae"]


def test_cache_folders_of_an_older_simulator_are_found_and_pruned(tmp_path, capsys) -> None:
    """A folder is stale where its name's digest is not the one its config and the current
    simulator give; the current one, and one without a config, are kept."""
    bench = _bench_module()
    cfg = bench.sim_config("realistic", 10, 5, 3, 64)
    current = tmp_path / bench.cache_folder(cfg).name
    older = tmp_path / (current.name[:-10] + "0123456789")
    unjudged = tmp_path / "paper-seed5-f10-64px-abcdefabcd"
    for folder in (current, older, unjudged):
        folder.mkdir()
        (folder / "0000-clean.npy").write_bytes(b"x" * 1000)
    for folder in (current, older):
        (folder / "config.json").write_text(json.dumps(cfg.to_dict(), indent=2) + "\n")
    assert bench.stale_cache_folders(tmp_path) == [older]
    bench.check_cache(False, tmp_path)  # far under a gigabyte: nothing said, nothing removed
    assert capsys.readouterr().err == "" and older.exists()
    bench.check_cache(True, tmp_path)
    assert "removed 1 stale cache folders" in capsys.readouterr().err
    assert not older.exists() and current.exists() and unjudged.exists()
    assert bench.stale_cache_folders(tmp_path / "absent") == []


def test_a_run_s_windows_are_redrawn_from_its_csv(tmp_path) -> None:
    """``--redraw CSV --figure PNG`` draws a run's windows without running (rows in the
    targets' order); a CSV that is not a run's, or holds a word where a number belongs, is
    refused in one line naming the file, and no figure is written.  A gzipped run reads
    as the plain one."""
    fields = ["row", "seed", "index", "condition", "status", "altitude_m", "est_altitude_m",
              "est_std_m", "trusted"]
    rows = [[name, 7, i, "clean", "ok", 2.0 + i, (2.0 + i) * 1.01, 0.05, i % 2 == 0]
            for name in ("realistic-10-exact", "realistic-30-blind") for i in range(6)]
    run = tmp_path / "run.csv"
    with open(run, "w", newline="") as fh:
        csv.writer(fh).writerows([fields, *rows])
    res = _run("--redraw", str(run), "--figure", str(tmp_path / "f.png"))
    assert res.returncode == 0, res.stderr[-2000:]
    assert (tmp_path / "f.png").stat().st_size > 0
    bench = _bench_module()
    zipped = tmp_path / "run.csv.gz"  # as docs/results keeps the large runs
    zipped.write_bytes(gzip.compress(run.read_bytes()))
    assert bench.read_windows(zipped) == bench.read_windows(run)
    res = _run("--redraw", str(zipped), "--figure", str(tmp_path / "z.png"))
    assert res.returncode == 0 and (tmp_path / "z.png").stat().st_size > 0, res.stderr[-2000:]
    broken = tmp_path / "broken.csv.gz"
    broken.write_bytes(b"not gzip")
    res = _run("--redraw", str(broken), "--figure", str(tmp_path / "g.png"))
    assert res.returncode == 2 and str(broken) in res.stderr.strip().splitlines()[-1]
    other = tmp_path / "other.csv"
    other.write_text("row,altitude_m\nx,1\n")
    word = tmp_path / "word.csv"
    word.write_text(run.read_text().replace("3.0,3.03", "three,3.03", 1))
    for bad, message in ((other, f"{other} is not a bench_dispersion window CSV (no "),
                         (word, f"{word}, line 3: not a number where one belongs")):
        res = _run("--redraw", str(bad), "--figure", str(tmp_path / "g.png"))
        assert res.returncode == 2 and message in res.stderr.strip().splitlines()[-1]
    assert not (tmp_path / "g.png").exists()
