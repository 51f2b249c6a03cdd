"""`wavealt altitude` on a frame folder and a video file written here."""

from __future__ import annotations

import json

import numpy as np
import pytest

from wavealt.cli import main
from wavealt.dataset import write_frames_folder
from wavealt.scenario import preset_config
from wavealt.simulate import generate_sequence
from wavealt.video import read_input, read_video, write_video


@pytest.fixture(scope="module")
def frames() -> tuple[np.ndarray, float]:
    cfg = preset_config("paper", size=64, frames=12, altitude_m=(3.0, 3.0),
                        wind_speed_mps=(7.0, 7.0))
    data = generate_sequence(cfg.sample_scenario(0), cfg)
    return data.clean, cfg.focal_px


def _run(capsys, argv: list[str]) -> tuple[int, str, str]:
    try:
        main(argv)
        code = 0
    except SystemExit as exc:
        code = int(exc.code or 0)
    out = capsys.readouterr()
    return code, out.out, out.err


def test_frame_folder_json(tmp_path, capsys, frames) -> None:
    clip, focal_px = frames
    write_frames_folder(tmp_path / "f", clip)
    code, out, _ = _run(capsys, ["altitude", str(tmp_path / "f"), "--fps", "30",
                                 "--focal-px", str(focal_px), "--json", "--window", "12"])
    assert code == 0
    d = json.loads(out)
    assert d["frames"] == 12 and d["windows"] == 1
    for key in ("altitude_m", "altitude_std_m", "velocity_mps", "quality"):
        assert key in d
    assert 0.0 <= d["quality"] <= 1.0 and d["altitude_m"] > 0


def test_video_roundtrip_and_windows(tmp_path, capsys, frames) -> None:
    clip, _ = frames
    path = tmp_path / "clip.mp4"
    write_video(path, clip, fps=30.0)
    back = read_video(path)
    assert back.shape == clip.shape and back.dtype == np.float32
    assert float(np.abs(back - clip).mean()) < 0.05  # lossy codec, same picture
    assert read_input(path).shape == clip.shape
    out_dir = tmp_path / "series"
    code, out, _ = _run(capsys, ["altitude", str(path), "--fps", "30", "--fov-deg", "60",
                                 "--window", "6", "--step", "3", "--out", str(out_dir)])
    assert code == 0 and "altitude:" in out
    rows = (out_dir / "altitude.csv").read_text().splitlines()
    assert len(rows) == 1 + 3  # windows at 0, 3, 6
    assert json.loads((out_dir / "altitude.json").read_text())["summary"]["windows"] == 3
    assert (out_dir / "altitude.png").stat().st_size > 0


@pytest.mark.parametrize("argv_tail, match", [
    (["--fps", "30"], "exactly one of --focal-px and --fov-deg"),
    (["--fps", "30", "--focal-px", "50", "--fov-deg", "60"], "exactly one"),
    (["--fps", "-1", "--focal-px", "50"], "fps"),
])
def test_bad_arguments(tmp_path, capsys, frames, argv_tail, match) -> None:
    write_frames_folder(tmp_path / "f", frames[0])
    code, _, err = _run(capsys, ["altitude", str(tmp_path / "f"), *argv_tail])
    assert code == 2 and match in err and "Traceback" not in err


def test_missing_and_mixed_inputs(tmp_path, capsys, frames) -> None:
    code, _, err = _run(capsys, ["altitude", str(tmp_path / "nope.mp4"), "--fps", "30",
                                 "--focal-px", "50"])
    assert code == 2 and "not found" in err
    folder = tmp_path / "mixed"
    write_frames_folder(folder, frames[0][:3])
    from wavealt.dataset import write_png
    write_png(folder / "frame_999.png", np.zeros((32, 32, 3), np.float32))
    code, _, err = _run(capsys, ["altitude", str(folder), "--fps", "30", "--focal-px", "50"])
    assert code == 2 and "different sizes" in err
    bad = tmp_path / "bad.mp4"
    bad.write_bytes(b"not a video")
    code, _, err = _run(capsys, ["altitude", str(bad), "--fps", "30", "--focal-px", "50"])
    assert code == 2 and "bad.mp4" in err
