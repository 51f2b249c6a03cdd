"""`wavealt altitude` on a frame folder and a video file written here."""

from __future__ import annotations

import json

import numpy as np
import pytest

from wavealt.cli import main
from wavealt.io import read_input, read_video, write_frames_folder, write_video
from wavealt.sim.config import preset_config
from wavealt.sim.generate import generate_sequence


@pytest.fixture(scope="module")
def frames() -> tuple[np.ndarray, float]:
    cfg = preset_config("paper", size=64, frames=12, altitude_m=(3.0, 3.0),
                        wind_speed_mps=(7.0, 7.0))
    data = generate_sequence(cfg.sample_scenario(0), cfg)
    return data.clean, cfg.focal_px




def test_16_bit_grey_frames_keep_their_16_bits(tmp_path, run_cli, frames) -> None:
    """A machine-vision camera's 16-bit grey PNG and TIFF frames are read to the bit, not
    clipped at 255 as an 8-bit conversion does; waves within four 8-bit grey levels read as
    the same frames given as floats.  A float TIFF, which has no scale, is refused in one
    line naming it."""
    from PIL import Image

    from wavealt.altimetry.dispersion import estimate_altitude

    clip, focal_px = frames
    grey = clip.mean(axis=-1)
    grey = (grey - grey.min()) / (grey.max() - grey.min())
    faint = np.round(20000 + 1000 * grey).astype(np.uint16)  # 1000 / 257: 3.9 8-bit levels
    for ext in ("png", "tif"):
        folder = tmp_path / ext
        folder.mkdir()
        for i, frame in enumerate(faint):
            Image.fromarray(frame).save(folder / f"frame_{i}.{ext}")
        read = read_input(folder)
        want = faint.astype(np.float32) / np.float32(65535.0)
        assert read.shape == (*faint.shape, 3) and read.dtype == np.float32
        assert all(np.array_equal(read[..., c], want) for c in range(3))
    code, out, err = run_cli(["altitude", str(tmp_path / "png"), "--fps", "30",
                              "--focal-px", str(focal_px), "--dispersion", "gravity", "--json",
                              "--window", "12", "--velocity-mps", "0,0"])
    assert code == 0, err
    ref = estimate_altitude(np.repeat(want[..., None], 3, axis=3), fps=30.0,
                            focal_px=focal_px, dispersion="gravity", velocity_mps=(0.0, 0.0))
    assert json.loads(out)["altitude_m"] == ref.altitude_m
    Image.fromarray(want[0]).save(tmp_path / "png" / "frame_99.tif")
    with pytest.raises(ValueError, match="frame_99.tif: 32-bit float pixels have no scale"):
        read_input(tmp_path / "png")
    code, _, err = run_cli(["altitude", str(tmp_path / "png"), "--fps", "30",
                            "--focal-px", str(focal_px)])
    assert code != 0 and "frame_99.tif: 32-bit float pixels have no scale" in err


def test_16_bit_colour_frames_keep_their_16_bits(tmp_path) -> None:
    """16-bit colour PNG and TIFF frames, which Pillow opens as 8-bit RGB, are read with
    their lower 8 bits too, in RGB order."""
    import cv2

    rng = np.random.default_rng(5)
    frames = rng.integers(0, 65536, size=(3, 32, 40, 3), dtype=np.uint16)
    assert np.any(frames % 257)  # not 8-bit values scaled up: 8 bits could not hold them
    for ext in ("png", "tif"):
        folder = tmp_path / ext
        folder.mkdir()
        for i, frame in enumerate(frames):
            assert cv2.imwrite(str(folder / f"f{i}.{ext}"), frame[..., ::-1])  # OpenCV: BGR
        read = read_input(folder)
        assert read.dtype == np.float32
        assert np.array_equal(read, frames.astype(np.float32) / np.float32(65535.0))


def test_frame_folder_json(tmp_path, run_cli, frames) -> None:
    """Blind, 12 frames of 64 px at 3 m: the estimate is within 4 of its own sigmas of the
    truth, or it says it is not to be trusted."""
    clip, focal_px = frames
    write_frames_folder(tmp_path / "f", clip)
    code, out, _ = run_cli(["altitude", str(tmp_path / "f"), "--fps", "30",
                                 "--focal-px", str(focal_px), "--json", "--window", "12",
                                 "--dispersion", "gravity"])
    assert code == 0
    d = json.loads(out)
    assert d["frames"] == 12 and d["windows"] == 1
    assert 0.0 <= d["quality"] <= 1.0 and d["altitude_std_m"] > 0
    assert d["mode"] == "blind" and isinstance(d["trusted"], bool)
    assert abs(d["altitude_m"] - 3.0) <= 4.0 * d["altitude_std_m"] or not d["trusted"]
    assert d["trusted_windows"] == int(d["trusted"])
    assert (d["reason"] is None) == d["trusted"]


@pytest.mark.parametrize(("velocity", "mode"), [
    ([], "blind"),
    (["--velocity-mps", "0,0", "--velocity-sigma-mps", "0.5"], "prior"),
    (["--velocity-mps", "0,0"], "exact"),
    (["--velocity-mps", "0,0", "--velocity-sigma-mps", "0"], "exact"),
])
def test_json_carries_the_contract(tmp_path, run_cli, frames, velocity, mode) -> None:
    """The design contract's keys, the mode that produced the estimate, and the camera's
    velocity under both its names.  The camera hovers at 3 m over still water: the estimate
    is within 4 of its sigmas of that, or marked untrusted with a reason."""
    clip, focal_px = frames
    write_frames_folder(tmp_path / "f", clip)
    code, out, err = run_cli(["altitude", str(tmp_path / "f"), "--fps", "30",
                                   "--focal-px", str(focal_px), "--dispersion", "gravity",
                                   "--json", *velocity])
    assert code == 0, err
    d = json.loads(out)
    assert d["mode"] == mode
    assert isinstance(d["trusted"], bool) and isinstance(d["altitude_m"], float)
    assert d["altitude_std_m"] > 0
    assert len(d["camera_velocity_mps"]) == 2 and d["velocity_mps"] == d["camera_velocity_mps"]
    assert abs(d["altitude_m"] - 3.0) <= 4.0 * d["altitude_std_m"] or not d["trusted"]
    assert (d["reason"] is None) == d["trusted"]
    assert d["trusted_windows"] == int(d["trusted"]) and d["windows"] == 1
    if mode == "exact":  # the velocity is given, not fitted
        assert d["camera_velocity_mps"] == [0.0, 0.0]


@pytest.fixture(scope="module")
def long_frames() -> tuple[np.ndarray, float]:
    """20 frames of 128 px at 3 m: enough waves for a fit the altimeter vouches for."""
    cfg = preset_config("paper", size=128, frames=20, altitude_m=(3.0, 3.0),
                        wind_speed_mps=(7.0, 7.0))
    return generate_sequence(cfg.sample_scenario(0), cfg).clean, cfg.focal_px


@pytest.mark.parametrize(("velocity", "mode"),
                         [([], "blind"), (["--velocity-mps", "0,0"], "exact")])
def test_a_trusted_estimate_is_the_true_altitude(tmp_path, run_cli, long_frames, velocity,
                                                 mode) -> None:
    """A hovering camera 3 m over still water: the estimate is trusted, within 5 % of 3 m
    and within 3 of its own sigmas (a bare altitude_m > 0 would pass a broken fit)."""
    clip, focal_px = long_frames
    write_frames_folder(tmp_path / "f", clip)
    code, out, err = run_cli(["altitude", str(tmp_path / "f"), "--fps", "30", "--focal-px",
                              str(focal_px), "--dispersion", "gravity", "--json", *velocity])
    assert code == 0, err
    d = json.loads(out)
    assert d["mode"] == mode and d["trusted"] is True and d["reason"] is None
    assert abs(d["altitude_m"] - 3.0) < 0.05 * 3.0
    assert abs(d["altitude_m"] - 3.0) <= 3.0 * d["altitude_std_m"]
    assert 0.0 < d["altitude_std_m"] < 0.1 * 3.0


def test_text_output_says_whether_to_trust_it(tmp_path, run_cli, frames) -> None:
    clip, focal_px = frames
    write_frames_folder(tmp_path / "f", clip)
    code, out, _ = run_cli(["altitude", str(tmp_path / "f"), "--fps", "30",
                                 "--focal-px", str(focal_px), "--dispersion", "gravity",
                                 "--velocity-mps", "0.5,-0.25", "--velocity-sigma-mps", "0.2"])
    assert code == 0
    assert out.startswith("altitude:") and "TRUSTED" in out
    assert "mode: prior (gravity dispersion)" in out
    assert "camera velocity over the water: (" in out and "image +x columns, +y rows" in out
    # no calibration: the frames are taken for a pinhole, and the output says so
    assert "camera: taken as a distortion-free pinhole" in out and "--calibration" in out
    # a frozen clip (one frame repeated) holds no moving waves: printed, but marked
    write_frames_folder(tmp_path / "frozen", np.repeat(clip[:1], 12, axis=0))
    code, out, _ = run_cli(["altitude", str(tmp_path / "frozen"), "--fps", "30",
                                 "--focal-px", str(focal_px), "--velocity-mps", "0,0"])
    assert code == 0
    assert "altitude:" in out and "NOT TRUSTED (" in out and "0 trusted" in out


@pytest.fixture(scope="module")
def paper_dataset(tmp_path_factory: pytest.TempPathFactory):
    """A paper-preset dataset written by `wavealt simulate`: 2 sequences of 12 frames, 64 px,
    the camera hovering at 3 m."""
    root = tmp_path_factory.mktemp("altitude-cli") / "ds"
    main(["simulate", str(root), "--sequences", "2", "--size", "64", "--frames", "12",
          "--altitude-m", "3,3", "--wind-speed-mps", "7,7", "--camera-speed-mps", "0",
          "--no-figures"])
    return root


def test_auto_dispersion_of_a_dataset_folder_is_its_renderers(tmp_path, run_cli,
                                                               paper_dataset) -> None:
    """A sequence folder of a paper-preset dataset is read with the paper renderer's
    dispersion relation (gravity); the same frames elsewhere are taken for real water."""
    seq = sorted((paper_dataset / "clean").iterdir())[0]
    copy = tmp_path / "elsewhere"
    copy.mkdir()
    for f in seq.iterdir():
        (copy / f.name).write_bytes(f.read_bytes())

    def run(folder, dispersion: str) -> dict:
        code, out, err = run_cli(["altitude", str(folder), "--fps", "30", "--fov-deg", "60",
                                       "--velocity-mps", "0,0", "--json",
                                       "--dispersion", dispersion])
        assert code == 0, err
        return json.loads(out)

    gravity, capillary = run(seq, "gravity"), run(seq, "gravity-capillary")
    assert gravity != capillary  # the two relations read these frames differently
    assert run(seq, "auto") == gravity
    assert run(copy, "auto") == capillary


def test_video_roundtrip_and_windows(tmp_path, run_cli, frames) -> None:
    clip, _ = frames
    path = tmp_path / "clip.mp4"
    write_video(path, clip, fps=30.0)
    back = read_video(path)
    assert back.shape == clip.shape and back.dtype == np.float32
    assert float(np.abs(back - clip).mean()) < 0.05  # lossy codec, same picture
    assert read_input(path).shape == clip.shape
    out_dir = tmp_path / "series"
    code, out, _ = run_cli(["altitude", str(path), "--fps", "30", "--fov-deg", "60",
                                 "--window", "6", "--step", "3", "--out", str(out_dir)])
    assert code == 0 and "altitude:" in out
    rows = (out_dir / "altitude.csv").read_text().splitlines()
    assert len(rows) == 1 + 3  # windows at 0, 3, 6
    assert {"trusted", "mode", "reason", "camera_vx_mps", "camera_vy_mps"} <= set(
        rows[0].split(","))
    summary = json.loads((out_dir / "altitude.json").read_text())["summary"]
    assert summary["windows"] == 3 and summary["mode"] == "blind"
    assert (out_dir / "altitude.png").stat().st_size > 0


@pytest.mark.parametrize("argv_tail, match", [
    (["--fps", "30"], "exactly one of --focal-px, --fov-deg and --calibration"),
    (["--fps", "30", "--focal-px", "50", "--fov-deg", "60"], "exactly one"),
    (["--fps", "-1", "--focal-px", "50"], "fps"),
    # a single number is not read as (1, 1)
    (["--fps", "30", "--focal-px", "50", "--velocity-mps", "1"], "--velocity-mps"),
    (["--fps", "30", "--focal-px", "50", "--velocity-mps", "1,2,3"], "--velocity-mps"),
    (["--fps", "30", "--focal-px", "50", "--velocity-mps", "nan,0"], "--velocity-mps"),
    (["--fps", "30", "--focal-px", "50", "--velocity-mps", "east"], "--velocity-mps"),
    (["--fps", "30", "--focal-px", "50", "--velocity-sigma-mps", "0.5"],
     "--velocity-sigma-mps needs --velocity-mps"),
    (["--fps", "30", "--focal-px", "50", "--velocity-mps", "0,0", "--velocity-sigma-mps", "-1"],
     "--velocity-sigma-mps"),
    (["--fps", "30", "--focal-px", "50", "--velocity-mps", "0,0", "--velocity-sigma-mps", "inf"],
     "--velocity-sigma-mps"),
    (["--fps", "30", "--focal-px", "50", "--dispersion", "shallow"], "--dispersion"),
    (["--fps", "30", "--focal-px", "50", "--readout-ms", "-5"],
     "--readout-ms must be a finite number >= 0; got -5.0"),
    (["--fps", "30", "--focal-px", "50", "--readout-ms", "50"],
     "readout_s 0.05 s is longer than a frame interval at 30 fps"),
    (["--fps", "30", "--focal-px", "50", "--yaw-rate-dps", "500"],
     "--yaw-rate-dps must be a number within +-180; got 500.0"),
    (["--fps", "30", "--focal-px", "50", "--yaw-rate-dps", "nan"], "--yaw-rate-dps"),
    (["--fps", "30", "--focal-px", "50", "--water-depth-m", "0"],
     "--water-depth-m must be a positive number of metres; got 0.0"),
])
def test_bad_arguments(tmp_path, run_cli, frames, argv_tail, match) -> None:
    write_frames_folder(tmp_path / "f", frames[0])
    code, out, err = run_cli(["altitude", str(tmp_path / "f"), *argv_tail])
    assert code == 2 and match in err and "Traceback" not in err
    assert err.startswith("wavealt: error:") and err.count("\n") == 1 and out == ""


def test_missing_and_mixed_inputs(tmp_path, run_cli, frames) -> None:
    code, _, err = run_cli(["altitude", str(tmp_path / "nope.mp4"), "--fps", "30",
                                 "--focal-px", "50"])
    assert code == 2 and "not found" in err
    folder = tmp_path / "mixed"
    write_frames_folder(folder, frames[0][:3])
    from wavealt.io import write_png
    write_png(folder / "frame_999.png", np.zeros((32, 32, 3), np.float32))
    code, _, err = run_cli(["altitude", str(folder), "--fps", "30", "--focal-px", "50"])
    assert code == 2 and "different sizes" in err
    bad = tmp_path / "bad.mp4"
    bad.write_bytes(b"not a video")
    code, _, err = run_cli(["altitude", str(bad), "--fps", "30", "--focal-px", "50"])
    assert code == 2 and "bad.mp4" in err


@pytest.mark.parametrize(("option", "made", "kwarg"), [
    (("--readout-ms", "20"), {}, {"readout_s": 0.02}),
    (("--yaw-rate-dps", "20"), {}, {"yaw_rate_dps": 20.0}),
    (("--water-depth-m", "0.02"), {"water_depth_m": 0.02}, {})])
def test_a_camera_option_reaches_the_altimeter(tmp_path, run_cli, frames, option, made,
                                                kwarg) -> None:
    """``--readout-ms`` is the altimeter's ``readout_s``, ``--yaw-rate-dps`` its
    ``yaw_rate_dps``, ``--water-depth-m`` the ``water_depth_m`` it is made with: the same
    window, the same altitude as the call made directly, and not the one without it."""
    from wavealt.altimetry.dispersion import DispersionAltimeter

    clip, focal_px = frames
    write_frames_folder(tmp_path / "f", clip)
    code, out, err = run_cli(["altitude", str(tmp_path / "f"), "--fps", "30", "--focal-px",
                              str(focal_px), "--json", "--window", "12", "--dispersion",
                              "gravity", "--velocity-mps", "0.2,0", *option])
    assert code == 0, err
    kw = {"fps": 30.0, "focal_px": focal_px, "velocity_mps": (0.2, 0.0)}
    direct = DispersionAltimeter(dispersion="gravity", **made).estimate(
        read_input(tmp_path / "f"), **kwarg, **kw)
    plain = DispersionAltimeter(dispersion="gravity").estimate(read_input(tmp_path / "f"), **kw)
    assert json.loads(out)["altitude_m"] == pytest.approx(direct.altitude_m, rel=1e-12)
    assert direct.altitude_m != plain.altitude_m


@pytest.mark.parametrize(("codec", "velocity"), [
    ("libx264", []), ("libx264", ["--velocity-mps", "0,0"]), ("mjpeg", [])])
def test_a_video_that_predicts_frames_is_not_trusted_without_the_exact_velocity(
        tmp_path, run_cli, long_frames, codec, velocity) -> None:
    """The clip the altimeter vouches for as frames (above), as H.264 (most frames coded from
    others: the motion-compensated texture biases a fit without the velocity high) and as
    Motion JPEG (every frame coded alone).  From H.264 the blind window is read but not
    trusted, the codec named; with the velocity exact, and from Motion JPEG, the fit's own
    verdict stands: trusted, within 5 % of 3 m."""
    clip, focal_px = long_frames
    write_video(tmp_path / "clip.mp4", clip, fps=30.0, codec=codec)
    code, out, err = run_cli(["altitude", str(tmp_path / "clip.mp4"), "--focal-px",
                              str(focal_px), "--dispersion", "gravity", "--json",
                              "--out", str(tmp_path / "out"), *velocity])
    assert code == 0, err
    d = json.loads(out)
    rows = json.loads((tmp_path / "out" / "altitude.json").read_text())["windows"]
    assert d["predicted_by"] == ("h264" if codec == "libx264" else None)
    if codec == "libx264" and not velocity:
        assert d["trusted"] is False and not any(r["trusted"] for r in rows)
        assert d["reason"].startswith("the frames were decoded from h264 video, which "
                                      "predicts frames from other frames")
        assert all(r["reason"] == d["reason"] for r in rows)
        assert 3.0 * d["altitude_std_m"] >= 19.5
    else:
        assert d["trusted"] is True and d["reason"] is None
        assert abs(d["altitude_m"] - 3.0) < 0.05 * 3.0
