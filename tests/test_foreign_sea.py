"""The independent sea generator of ``benchmarks/bench_foreign_sea.py`` (the altimeter's
out-of-distribution check): its physics self-checks pass, and a one-clip run reports every
window of its rows."""

from __future__ import annotations

import gzip
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from benchmodule import bench_module

BENCH = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_foreign_sea.py"


def _run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(BENCH), *args], capture_output=True, text=True,
                          timeout=300)


def test_the_generators_physics_checks_pass() -> None:
    """One wave's phase step, no advection when the current equals the drift, the slope
    variance of the spectrum, the altimeter's velocity convention, the tilted camera's
    rays (level: the nadir crop itself; tilted: the axis meets the sea H tan(tilt) away),
    the CIE clear sky's luminance against the standard's formula, the camera effects
    (phases taken whole or stepped, a rolling shutter's row against a direct render,
    automatic exposure's gains), the cumulus deck's cover, a distorting lens's pixel
    rays against OpenCV's own projection, and the Lagrangian sea's one wave against
    Gerstner's curve, at 30 and 60 frames/s."""
    for fps in ("30", "60"):  # at another frame rate too (--fps)
        res = _run("--self-check", "--fps", fps)
        assert res.returncode == 0, res.stdout + res.stderr[-2000:]
        lines = res.stdout.splitlines()
        assert sum(line.startswith("PASS") for line in lines) == 10
        assert not any(line.startswith("FAIL") for line in lines)
    bad = _run("--self-check", "--fps", "2")
    assert bad.returncode == 2 and "--fps must be within 5-240; got 2" in bad.stderr


def test_a_one_clip_run_reports_every_window(tmp_path) -> None:
    """Every window in the JSON, its figure drawn (``--figure``), and drawn again from the
    JSON alone, gzipped or not (``--redraw``); a redraw without a figure, or of a file that
    is not a run's, is refused in one line."""
    out = tmp_path / "run.json"
    res = _run("--clips", "1", "--seed", "5", "--rows", "exact10,prior10", "--out", str(out),
               "--figure", str(tmp_path / "run.png"))
    assert res.returncode == 0, res.stderr[-2000:]
    assert (tmp_path / "run.png").stat().st_size > 0
    packed = tmp_path / "run.json.gz"  # as docs/results keeps runs
    packed.write_bytes(gzip.compress(out.read_bytes()))
    for name, run in (("again.png", out), ("packed.png", packed)):
        again = _run("--redraw", str(run), "--figure", str(tmp_path / name))
        assert again.returncode == 0 and (tmp_path / name).stat().st_size > 0, again.stderr
    (tmp_path / "other.json").write_text('{"clips": 1}')
    for args, message in ((("--redraw", str(out)), "--redraw needs --figure"),
                          (("--redraw", str(tmp_path / "other.json"), "--figure", "x.png"),
                           f"--redraw: {tmp_path / 'other.json'}: not a bench_foreign_sea.py "
                           "run with records (KeyError)")):
        bad = _run(*args)
        assert bad.returncode == 2 and message in bad.stderr.strip().splitlines()[-1]
    summary = json.loads(res.stdout)
    saved = json.loads(out.read_text())
    assert saved["metrics"] == summary["metrics"]
    assert [(r["row"], r["start"]) for r in saved["records"]] == [
        ("exact10", 0), ("exact10", 10), ("exact10", 20),
        ("prior10", 0), ("prior10", 10), ("prior10", 20)]
    assert summary["metrics"]["exact10"]["all"]["windows"] == 3
    for row in ("exact10", "prior10"):
        stats = summary["metrics"][row]["all"]
        untrusted = sum(not r["trusted"] for r in saved["records"] if r["row"] == row)
        assert sum(stats["untrusted_reasons"].values()) == untrusted
    bad = _run("--clips", "1", "--rows", "blind99")
    assert bad.returncode == 2 and "unknown rows: blind99" in bad.stderr


def test_a_tilted_run_records_each_clips_tilt_and_refuses_a_bad_one(tmp_path) -> None:
    out = tmp_path / "tilted.json"
    res = _run("--clips", "2", "--seed", "5", "--rows", "exact10", "--max-tilt-deg", "15",
               "--out", str(out))
    assert res.returncode == 0, res.stderr[-2000:]
    saved = json.loads(out.read_text())
    assert saved["max_tilt_deg"] == 15.0
    tilts = {r["seed"]: r["tilt_deg"] for r in saved["records"]}
    assert sorted(tilts) == [5, 6] and all(0.0 < t <= 15.0 for t in tilts.values())
    bad = _run("--clips", "1", "--max-tilt-deg", "45")
    assert bad.returncode == 2 and "--max-tilt-deg must be within 0-30; got 45" in bad.stderr


def test_a_cie_or_cloudy_sky_run_changes_the_radiance_and_nothing_else(tmp_path) -> None:
    """``--sky cie`` and ``--sky clouds`` draw the same scenes (the sky draws nothing from
    the scene's stream) and render other frames; an unknown sky is refused."""
    runs = {}
    for sky in ("gradient", "cie", "clouds"):
        out = tmp_path / f"{sky}.json"
        res = _run("--clips", "1", "--seed", "5", "--rows", "exact10", "--sky", sky,
                   "--save-clips", str(tmp_path / sky), "--out", str(out))
        assert res.returncode == 0, res.stderr[-2000:]
        assert json.loads(out.read_text())["sky"] == sky
        runs[sky] = json.loads((tmp_path / sky / "clip5.json").read_text())
    keep = {k: v for k, v in runs["gradient"].items() if k not in ("sky", "texture_dn",
                                                                     "noise_dn")}
    for sky in ("cie", "clouds"):
        assert keep == {k: runs[sky][k] for k in keep}
        assert runs[sky]["sky"] == sky and runs[sky]["texture_dn"] != runs["gradient"][
            "texture_dn"]
    bad = _run("--clips", "1", "--sky", "overcast")
    assert bad.returncode == 2 and "invalid choice: 'overcast'" in bad.stderr


def test_a_one_way_sea_has_no_counter_sea_a_narrow_spread_and_the_same_scene(tmp_path) -> None:
    """``--one-way`` draws the scene as without it but for the sea: no counter-running sea,
    and a spread exponent in ``ONE_WAY_SPREAD`` from a stream of its own."""
    runs = {}
    for name, extra in (("both", ()), ("one", ("--one-way",))):
        out = tmp_path / f"{name}.json"
        res = _run("--clips", "1", "--seed", "5", "--rows", "exact10", *extra,
                   "--save-clips", str(tmp_path / name), "--out", str(out))
        assert res.returncode == 0, res.stderr[-2000:]
        assert json.loads(out.read_text())["one_way"] == (name == "one")
        runs[name] = json.loads((tmp_path / name / "clip5.json").read_text())
    sea = ("counter_share", "spread_s", "texture_dn", "noise_dn")
    assert {k: v for k, v in runs["both"].items() if k not in sea} == {
        k: v for k, v in runs["one"].items() if k not in sea}
    assert runs["both"]["counter_share"] > 0 and runs["one"]["counter_share"] == 0.0
    assert 15.0 <= runs["one"]["spread_s"] <= 40.0 and runs["both"]["spread_s"] <= 10.0


def test_supersampled_pixels_average_the_radiance_and_keep_the_frames_scale(tmp_path) -> None:
    """``--supersample 2`` renders the sea at twice the size and averages each pixel's four
    samples: the frames and the focal length the altimeter is told are the frame's (256 px),
    the scene is the same, the frames differ; a bad factor is refused."""
    clips = {}
    for n in ("1", "2"):
        out = tmp_path / f"{n}.json"
        res = _run("--clips", "1", "--seed", "5", "--rows", "exact10", "--supersample", n,
                   "--save-clips", str(tmp_path / n), "--out", str(out))
        assert res.returncode == 0, res.stderr[-2000:]
        assert json.loads(out.read_text())["supersample"] == int(n)
        truth = json.loads((tmp_path / n / "clip5.json").read_text())
        clips[n] = (np.load(tmp_path / n / "clip5.npy"), truth)
    (one, t1), (two, t2) = clips["1"], clips["2"]
    assert one.shape == two.shape == (30, 256, 256)
    assert t1["focal_px"] == t2["focal_px"] and t1["altitude_m"] == t2["altitude_m"]
    assert not np.array_equal(one, two)
    bad = _run("--clips", "1", "--supersample", "5")
    assert bad.returncode == 2 and "--supersample must be within 1-4" in bad.stderr


def test_a_lens_that_distorts_changes_the_frames_and_not_the_scene(tmp_path) -> None:
    """``--lens-k1``: the scene is drawn as without it, seen through the lens (the frames
    differ, the altimeter is told the same focal length, the centre's); with
    ``--tell-calibration`` the windows are read from the frames turned to a pinhole's view;
    a lens beyond the range, or a calibration told without a lens, is refused.  The clip's
    glitter clips some pixels: the record's saturated share is the camera's frames', not
    the view's."""
    truths = {}
    for name, extra in (("pinhole", ()), ("lens", ("--lens-k1", "-0.1")),
                        ("told", ("--lens-k1", "-0.1", "--tell-calibration"))):
        out = tmp_path / f"{name}.json"
        res = _run("--clips", "1", "--seed", "1", "--rows", "exact10", *extra,
                   "--save-clips", str(tmp_path / name), "--out", str(out))
        assert res.returncode == 0, res.stderr[-2000:]
        run = json.loads(out.read_text())
        assert run["lens_k1"] == (0.0 if name == "pinhole" else -0.1)
        assert run["tell_calibration"] == (name == "told")
        assert all(r["lens_k1"] == run["lens_k1"] for r in run["records"])
        truths[name] = (json.loads((tmp_path / name / "clip1.json").read_text()),
                        np.load(tmp_path / name / "clip1.npy"), run["records"])
    sensed = ("lens_k1", "texture_dn", "noise_dn")
    (pin, pin_frames, _), (lens, lens_frames, untold), (told, told_frames, read) = (
        truths["pinhole"], truths["lens"], truths["told"])
    assert told == lens  # the same clip, told its calibration
    assert {k: v for k, v in pin.items() if k not in sensed} == {
        k: v for k, v in lens.items() if k not in sensed}
    assert lens["focal_px"] == pin["focal_px"] and lens["lens_k1"] == -0.1
    assert not np.array_equal(pin_frames, lens_frames)
    np.testing.assert_array_equal(lens_frames, told_frames)  # the camera's frames, saved
    # the saturated share is the camera's, told or not (not the view's, whose resampling
    # blurs the clipped pixels)
    for frames, records in ((lens_frames, untold), (told_frames, read)):
        assert {r["saturated_share"] for r in records} == {float(np.mean(frames == 255))}
    assert [r["est"] for r in read] != [r["est"] for r in untold]
    for args, message in ((("--lens-k1", "-0.2"), "--lens-k1 must be within +-0.12"),
                          (("--tell-calibration",), "--tell-calibration needs --lens-k1")):
        bad = _run("--clips", "1", *args)
        assert bad.returncode == 2 and message in bad.stderr, bad.stderr


def test_a_lagrangian_sea_moves_the_surface_and_not_the_scene(tmp_path) -> None:
    """``--choppy``: the scene is drawn as without it (its truth the same but for the
    choppiness and what the sensor sees), its frames differ; the surface a pixel sees is
    the linear sea's carried on the orbits: two waves, a long one carrying a short one,
    show the short wave's crests moved by the long one's displacement at each pixel (the
    fixed-point trace back to the particle); a choppiness beyond the range is refused in
    one line."""
    truths = {}
    for name, extra in (("linear", ()), ("choppy", ("--choppy", "1"))):
        out = tmp_path / f"{name}.json"
        res = _run("--clips", "1", "--seed", "3", "--rows", "exact10", *extra,
                   "--save-clips", str(tmp_path / name), "--out", str(out))
        assert res.returncode == 0, res.stderr[-2000:]
        run = json.loads(out.read_text())
        assert run["choppy"] == (1.0 if name == "choppy" else 0.0)
        assert all(r["choppy"] == run["choppy"] for r in run["records"])
        truths[name] = (json.loads((tmp_path / name / "clip3.json").read_text()),
                        np.load(tmp_path / name / "clip3.npy"))
    sensed = ("choppy", "texture_dn", "noise_dn")
    (lin, lin_frames), (chop, chop_frames) = truths["linear"], truths["choppy"]
    assert {k: v for k, v in lin.items() if k not in sensed} == {
        k: v for k, v in chop.items() if k not in sensed}
    assert not np.array_equal(lin_frames, chop_frames)
    # a short wave (grid bin 40 along x) on a long one (bin 4): the surface at a pixel x is
    # the particle's x0 with x0 + D(x0) = x, D = -sum A sin(k x0) over both waves, and its
    # slope -sum A k sin(k x0) / (1 - sum A k cos(k x0)) (Gerstner's curve of two waves);
    # the short wave's crests ride the long one's orbits, which moves them by more than the
    # tolerance many times over
    fs = bench_module("bench_foreign_sea")
    from dataclasses import replace

    sc = replace(fs.draw_scene(7), choppy=1.0)
    kx = fs.wavenumbers(sc)[0][0]
    amp = np.zeros((fs.GRID, fs.GRID), complex)
    waves = ((4, 0.15 / kx[4]), (40, 0.01 / kx[40]))  # (bin, amplitude): slopes 0.15, 0.01
    for b, a in waves:
        amp[0, b] = a
    got = fs.slope_frames(sc, amp.copy(), 1)[0][0][fs.SIZE // 2]
    x = ((fs.GRID - fs.SIZE) // 2 + np.arange(fs.SIZE)) * sc.gsd
    x0 = x.copy()
    for _ in range(60):
        x0 = x + sum(a * np.sin(kx[b] * x0) for b, a in waves)
    want = -sum(a * kx[b] * np.sin(kx[b] * x0) for b, a in waves) / (
        1 - sum(a * kx[b] * np.cos(kx[b] * x0) for b, a in waves))
    assert np.max(np.abs(got - want)) < 0.1 * 0.01
    linear = fs.slope_frames(replace(sc, choppy=0.0), amp.copy(), 1)[0][0][fs.SIZE // 2]
    assert np.max(np.abs(linear - want)) > 10 * np.max(np.abs(got - want))
    bad = _run("--clips", "1", "--choppy", "2")
    assert bad.returncode == 2 and "--choppy must be within 0-1.5; got 2" in bad.stderr


def test_camera_effects_change_the_frames_and_not_the_scene(tmp_path) -> None:
    """``--camera`` draws each effect from a stream of its own: the scene is the one drawn
    without it, the frames differ, the record holds the effect's figures; an unknown effect
    is refused by name."""
    truths = {}
    for camera in ("", "rolling,blur,autoexposure"):
        name = camera.split(",")[0] or "none"
        out = tmp_path / f"{name}.json"
        res = _run("--clips", "1", "--seed", "5", "--rows", "exact10", "--camera", camera,
                   "--save-clips", str(tmp_path / name), "--out", str(out))
        assert res.returncode == 0, res.stderr[-2000:]
        saved = json.loads(out.read_text())
        assert saved["camera"] == [c for c in camera.split(",") if c]
        truths[name] = json.loads((tmp_path / name / "clip5.json").read_text())
        record = saved["records"][0]
        assert {k: record[k] for k in ("readout_s", "shutter_s", "ae_rate", "ae_jitter")} == {
            k: truths[name][k] for k in ("readout_s", "shutter_s", "ae_rate", "ae_jitter")}
    plain, effects = truths["none"], truths["rolling"]
    assert plain["readout_s"] == plain["shutter_s"] == plain["ae_rate"] == 0.0
    assert 0.010 <= effects["readout_s"] <= 0.030 and 0.002 <= effects["shutter_s"] <= 0.016
    assert 0.2 <= effects["ae_rate"] <= 0.6 and effects["ae_jitter"] > 0.0
    drawn = set(plain) - {"readout_s", "shutter_s", "ae_rate", "ae_jitter", "texture_dn",
                          "noise_dn"}
    assert {k: plain[k] for k in drawn} == {k: effects[k] for k in drawn}
    frames = [np.load(tmp_path / name / "clip5.npy") for name in ("none", "rolling")]
    assert frames[0].shape == frames[1].shape and not np.array_equal(*frames)
    bad = _run("--clips", "1", "--camera", "rolling,fisheye")
    assert bad.returncode == 2
    assert "unknown camera effects: fisheye (known: rolling, blur, autoexposure)" in bad.stderr


def test_a_larger_camera_sees_the_same_scene_and_is_binned(tmp_path) -> None:
    """``--size 512`` renders the same scene at twice the pixels (the same field of view);
    the altimeter bins them to its working scale unless ``--working-px 0``."""
    runs = {}
    for name, extra in (("binned", ()), ("native", ("--working-px", "0"))):
        out = tmp_path / f"{name}.json"
        res = _run("--clips", "1", "--seed", "5", "--rows", "exact10", "--size", "512",
                   *extra, "--out", str(out), "--save-clips", str(tmp_path / name))
        assert res.returncode == 0, res.stderr[-2000:]
        runs[name] = json.loads(out.read_text())
    clip = np.load(tmp_path / "binned" / "clip5.npy")
    assert clip.shape[1:3] == (512, 512)
    small = tmp_path / "small.json"
    assert _run("--clips", "1", "--seed", "5", "--rows", "exact10", "--out",
                str(small)).returncode == 0
    scene = {k: json.loads(small.read_text())["records"][0][k]
             for k in ("altitude_m", "hfov_deg", "u10", "drift")}
    assert {k: runs["binned"]["records"][0][k] for k in scene} == scene
    assert runs["binned"]["size"] == 512
    assert all(r["signal"].endswith("+binned2") for r in runs["binned"]["records"])
    assert not any("binned" in r["signal"] for r in runs["native"]["records"])
    bad = _run("--clips", "1", "--size", "4000")
    assert bad.returncode == 2 and "--size must be within 64-2048 px" in bad.stderr


def test_shallow_water_changes_the_waves_and_not_the_scene(tmp_path) -> None:
    """``--depth-m`` draws each clip's depth from a stream of its own (the scene is the one
    drawn in deep water), records it, and slows the waves (other frames); ``--tell-depth``
    needs it; a depth that is not positive is refused."""
    truths = {}
    for name, depth in (("deep", ()), ("shallow", ("--depth-m", "0.2,0.4", "--tell-depth"))):
        out = tmp_path / f"{name}.json"
        res = _run("--clips", "1", "--seed", "5", "--rows", "exact10", *depth,
                   "--save-clips", str(tmp_path / name), "--out", str(out))
        assert res.returncode == 0, res.stderr[-2000:]
        saved = json.loads(out.read_text())
        truths[name] = json.loads((tmp_path / name / "clip5.json").read_text())
        assert saved["records"][0]["depth_m"] == truths[name]["depth_m"]
    assert truths["deep"]["depth_m"] is None and 0.2 <= truths["shallow"]["depth_m"] <= 0.4
    drawn = set(truths["deep"]) - {"depth_m", "texture_dn", "noise_dn"}
    assert {k: truths["deep"][k] for k in drawn} == {k: truths["shallow"][k] for k in drawn}
    frames = [np.load(tmp_path / name / "clip5.npy") for name in ("deep", "shallow")]
    assert frames[0].shape == frames[1].shape and not np.array_equal(*frames)
    for args, message in ((("--tell-depth",), "--tell-depth needs --depth-m"),
                          (("--depth-m", "0,1"), "--depth-m must be D or LO,HI")):
        bad = _run("--clips", "1", *args)
        assert bad.returncode == 2 and message in bad.stderr


def test_h264_coding_changes_the_frames_and_not_the_scene(tmp_path) -> None:
    """``--h264-crf`` codes the clip as a video stream (libx264) instead of 8-bit frames or
    JPEG stills: the scene is the one drawn without it; the coded frames are close to the
    uncoded ones, not equal, and closer the lower the rate factor; a rate factor outside
    0-51 is refused in one line."""
    clips, truths = {}, {}
    for crf in ("", "12", "30"):
        name = crf or "none"
        args = ("--h264-crf", crf) if crf else ()
        res = _run("--clips", "1", "--seed", "5", "--rows", "exact10", *args,
                   "--save-clips", str(tmp_path / name), "--out", str(tmp_path / f"{name}.json"))
        assert res.returncode == 0, res.stderr[-2000:]
        assert json.loads((tmp_path / f"{name}.json").read_text())["h264_crf"] == (
            int(crf) if crf else None)
        clips[name] = np.load(tmp_path / name / "clip5.npy").astype(np.float64)
        truths[name] = json.loads((tmp_path / name / "clip5.json").read_text())
    drawn = set(truths["none"]) - {"texture_dn", "noise_dn"}
    assert all({k: t[k] for k in drawn} == {k: truths["none"][k] for k in drawn}
               for t in truths.values())
    err = {n: float(np.abs(clips[n] - clips["none"]).mean()) for n in ("12", "30")}
    assert clips["12"].shape == clips["none"].shape
    assert 0.0 < err["12"] < err["30"] < 8.0
    bad = _run("--clips", "1", "--h264-crf", "60")
    assert bad.returncode == 2 and "--h264-crf must be within 0-51; got 60" in bad.stderr


@pytest.mark.parametrize(("aspect", "shape"), [((16, 9), (512, 288)), ((4, 3), (512, 384)),
                                              ((9, 16), (288, 512)), ((1, 1), (512, 512))])
def test_a_frame_cropped_to_an_aspect_keeps_the_middle_and_the_longer_side(aspect,
                                                                            shape) -> None:
    """``--aspect``: a video camera's frame, the same pixels and optics (the focal length
    quoted across the longer side)."""
    fs = bench_module("bench_foreign_sea")
    frames = np.arange(2 * 512 * 512, dtype=np.int64).reshape(2, 512, 512)
    out = fs.crop_to_aspect(frames, aspect)
    w, h = shape
    assert out.shape == (2, h, w)
    top, left = (512 - h) // 2, (512 - w) // 2
    assert np.array_equal(out, frames[:, top:top + h, left:left + w])


def test_a_bad_aspect_is_refused_in_one_line() -> None:
    for bad in ("16x9", "16:0", "9:64", "a:b"):
        res = _run("--clips", "1", "--rows", "exact10", "--aspect", bad)
        assert res.returncode == 2
        assert f"--aspect must be W:H, two whole numbers within 1:4-4:1; got {bad!r}" in (
            res.stderr.strip().splitlines()[-1])
