"""Real camera geometry: OpenCV calibration files, lens distortion and attitude, turned to the
level nadir view the altimeter assumes (``camera.NadirView``), through the real renderer."""

from __future__ import annotations

import json
import math

import cv2
import numpy as np
import pytest

from wavealt.altimetry.dispersion import DispersionAltimeter, DispersionResult
from wavealt.altimetry.dispersion.attitude import tile_centres
from wavealt.altimetry.dispersion.constants import WEAK_TILE_SD_LOG
from wavealt.altimetry.dispersion.levelling import UNCONFIRMED_TILT
from wavealt.camera import (
    Calibration,
    NadirView,
    pinhole,
    read_attitude,
    read_calibration,
    tilt_rotation,
    write_calibration,
)
from wavealt.sim.config import preset_config
from wavealt.sim.generate import generate_sequence

K = np.array([[410.0, 0.0, 322.5], [0.0, 412.0, 238.0], [0.0, 0.0, 1.0]])
D = np.array([-0.28, 0.09, 0.001, -0.0005, -0.01])


@pytest.mark.parametrize("suffix", [".yaml", ".xml", ".json"])
def test_calibration_round_trips_through_opencvs_own_format(tmp_path, suffix) -> None:
    path = tmp_path / f"cam{suffix}"
    # written by OpenCV itself, as its calibration sample does
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    fs.write("image_width", 640)
    fs.write("image_height", 480)
    fs.write("camera_matrix", K)
    fs.write("distortion_coefficients", D.reshape(-1, 1))
    fs.release()
    cal = read_calibration(path)
    assert np.array_equal(cal.camera_matrix, K) and np.array_equal(cal.dist_coeffs, D)
    assert cal.image_size == (640, 480)
    again = tmp_path / f"again{suffix}"
    write_calibration(again, cal)
    back = read_calibration(again)
    assert np.array_equal(back.camera_matrix, K) and np.array_equal(back.dist_coeffs, D)
    assert back.image_size == (640, 480)


def test_calibration_scales_with_the_frames_and_refuses_a_crop() -> None:
    cal = Calibration(K, D, (640, 480))
    half = cal.for_size(320, 240)
    assert half.camera_matrix[0, 0] == pytest.approx(205.0)
    assert half.camera_matrix[1, 2] == pytest.approx(119.0)
    assert np.array_equal(half.dist_coeffs, D)  # normalised coordinates: unchanged
    with pytest.raises(ValueError, match="aspect ratio"):
        cal.for_size(480, 480)


@pytest.mark.parametrize("text, match", [
    ("not: [a, calibration", "OpenCV can read"),
    ("%YAML:1.0\nimage_width: 640\n", "no camera matrix"),
    ("%YAML:1.0\ncamera_matrix: !!opencv-matrix\n   rows: 2\n   cols: 2\n   dt: d\n"
     "   data: [1., 0., 0., 1.]\n", "3x3"),
    ("%YAML:1.0\ncamera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
     "   data: [400., 0., 320., 0., 400., 240., 0., 0., 1.]\n"
     "distortion_coefficients: !!opencv-matrix\n   rows: 3\n   cols: 1\n   dt: d\n"
     "   data: [0.1, 0.2, 0.3]\n", "distortion coefficients"),
    ("%YAML:1.0\ncamera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
     "   data: [-400., 0., 320., 0., 400., 240., 0., 0., 1.]\n", "fx, fy > 0"),
])
def test_bad_calibration_files_are_one_line_errors(tmp_path, text, match) -> None:
    path = tmp_path / "cam.yaml"
    path.write_text(text)
    with pytest.raises(ValueError, match=match):
        read_calibration(path)
    with pytest.raises(FileNotFoundError, match="calibration file not found"):
        read_calibration(tmp_path / "missing.yaml")


def test_tilt_rotation_follows_the_vehicles_convention() -> None:
    assert np.allclose(tilt_rotation(0.0, 0.0), np.eye(3))
    for roll, pitch in ((10.0, 0.0), (0.0, -7.0), (12.0, 5.0)):
        r = tilt_rotation(roll, pitch)
        assert np.allclose(r @ r.T, np.eye(3)) and np.linalg.det(r) == pytest.approx(1.0)
        axis = r @ [0.0, 0.0, 1.0]  # the optical axis, seen from the level camera
        assert math.degrees(math.acos(axis[2])) == pytest.approx(
            math.degrees(math.acos(math.cos(math.radians(roll)) * math.cos(math.radians(pitch)))))
    # right side down: the view swings to the image's left; nose up: toward its top
    assert (tilt_rotation(10.0, 0.0) @ [0, 0, 1])[0] < 0
    assert (tilt_rotation(0.0, 10.0) @ [0, 0, 1])[1] < 0
    with pytest.raises(ValueError, match="roll_deg"):
        tilt_rotation(45.0, 0.0)


def test_a_level_pinhole_is_left_as_it_is() -> None:
    frames = np.random.default_rng(0).random((3, 48, 64)).astype(np.float32)
    view = NadirView(pinhole(64, 48, 60.0), 64, 48)
    assert view.out_size == (64, 48) and view.focal_px == pytest.approx(60.0)
    assert np.array_equal(view(frames), frames)
    with pytest.raises(ValueError, match="made for 64x48"):
        view(frames[:, :40])


def _scene(preset: str, h: float, seed: int):
    """A wide nadir render (512 px, 90 deg) to take other cameras' views from."""
    cfg = preset_config(preset, size=512, fov_deg=90.0, frames=10, altitude_m=(h, h),
                        wind_speed_mps=(7.0, 7.0), camera_speed_mps=(0.3, 0.3),
                        **({"roll_deg": (0.0, 0.0), "pitch_deg": (0.0, 0.0)}
                           if preset == "realistic" else {}))
    sc = cfg.sample_scenario(seed)
    return generate_sequence(sc, cfg).clean, sc, cfg


def _remap(nadir: np.ndarray, f_n: float, rays: np.ndarray) -> np.ndarray:
    """What a camera whose pixels look along ``rays`` (level frame, OpenCV axes) sees of the
    nadir render of focal ``f_n``, from the same optical centre."""
    n = nadir.shape[1]
    mx = (f_n * rays[..., 0] / rays[..., 2] + n / 2 - 0.5).astype(np.float32)
    my = (f_n * rays[..., 1] / rays[..., 2] + n / 2 - 0.5).astype(np.float32)
    assert 0 <= mx.min() and mx.max() <= n - 1 and 0 <= my.min() and my.max() <= n - 1
    return np.stack([cv2.remap(f, mx, my, cv2.INTER_LINEAR) for f in nadir])


def _pixel_rays(size: int, focal: float) -> np.ndarray:
    u = (np.arange(size) + 0.5 - size / 2) / focal
    uu, vv = np.meshgrid(u, u)
    return np.stack([uu, vv, np.ones_like(uu)], axis=-1)


@pytest.mark.parametrize("h, roll, pitch, seed", [(6.0, -8.0, 12.0, 1), (4.5, 0.0, 15.0, 3)])
def test_a_tilted_camera_reads_right_when_its_attitude_is_known(h, roll, pitch, seed) -> None:
    nadir, sc, cfg = _scene("paper", h, seed)
    rays = _pixel_rays(256, cfg.focal_px) @ tilt_rotation(roll, pitch).T
    frames = _remap(nadir, cfg.focal_px, rays)
    # the attitude known: the levelled frames are a level camera's (as the command line
    # takes them)
    est = DispersionAltimeter(dispersion="gravity", attitude="level")
    kw = {"fps": cfg.fps, "velocity_mps": sc.camera_velocity_mps}
    view = NadirView(pinhole(256, 256, cfg.focal_px), 256, 256, roll_deg=roll, pitch_deg=pitch)
    known = est.estimate(view(frames), focal_px=view.focal_px, **kw)
    ignored = DispersionAltimeter(dispersion="gravity", attitude="level").estimate(
        frames, focal_px=cfg.focal_px, **kw)
    assert known.trusted and abs(known.altitude_m / h - 1) < 0.03, known
    # the tilt foreshortens the far side: ignored, it reads high
    assert ignored.altitude_m / h - 1 > 0.08, ignored


@pytest.mark.parametrize("h, roll, pitch, seed", [(4.5, 0.0, 15.0, 3), (3.0, 10.0, -5.0, 4),
                                                  (6.0, -8.0, 12.0, 1)])
def test_a_tilted_camera_whose_attitude_is_not_given_is_levelled_at_its_tiles_tilt(
        h, roll, pitch, seed) -> None:
    """Without an attitude, the corner tiles' scales measure the tilt (to a few degrees on
    10 frames), the frames are levelled at it, and the estimate keeps its contract: 3 sigma
    covers the error, and a trusted one is within 10 %; ignoring the tilt reads high."""
    nadir, sc, cfg = _scene("paper", h, seed)
    frames = _remap(nadir, cfg.focal_px,
                    _pixel_rays(256, cfg.focal_px) @ tilt_rotation(roll, pitch).T)
    kw = {"fps": cfg.fps, "velocity_mps": sc.camera_velocity_mps, "focal_px": cfg.focal_px}
    res = DispersionAltimeter(dispersion="gravity").estimate(frames, **kw)
    assert res.attitude_deg is not None and res.signal.endswith("+levelled"), res
    assert np.allclose(res.attitude_deg, (roll, pitch), atol=4.0), res.attitude_deg
    err = abs(res.altitude_m / h - 1)
    assert err * h <= 3.0 * res.altitude_std_m, res
    assert err < 0.10 or not res.trusted, res
    assert res.to_dict()["attitude_deg"] == [float(v) for v in res.attitude_deg]
    ignored = DispersionAltimeter(dispersion="gravity", attitude="level").estimate(frames, **kw)
    assert ignored.attitude_deg is None and ignored.altitude_m / h - 1 > 0.08, ignored
    assert err < ignored.altitude_m / h - 1


@pytest.mark.parametrize("h", [5.0, 9.0])
def test_a_tilt_that_smears_the_shell_away_is_still_measured_and_levelled(h) -> None:
    """16 degrees from nadir change the scale across the frame by a quarter: fitted blind as
    level, the 1-s clip's shell is smeared below a prominent peak, and its tiles, searched
    over the whole range, still measure the tilt; levelled at it, the clip reads right."""
    roll, pitch = 0.0, 16.0
    cfg = preset_config("paper", size=512, fov_deg=90.0, frames=30, altitude_m=(h, h),
                        wind_speed_mps=(7.0, 7.0), camera_speed_mps=(0.3, 0.3))
    sc = cfg.sample_scenario(3)
    frames = _remap(generate_sequence(sc, cfg).clean, cfg.focal_px,
                    _pixel_rays(256, cfg.focal_px) @ tilt_rotation(roll, pitch).T)
    kw = {"fps": cfg.fps, "focal_px": cfg.focal_px}
    as_level = DispersionAltimeter(attitude="level").estimate(frames, **kw)
    assert as_level.reason == "no prominent wave-shell peak", as_level
    res = DispersionAltimeter().estimate(frames, **kw)
    assert res.signal.endswith("+levelled"), res
    assert np.allclose(res.attitude_deg, (roll, pitch), atol=4.0), res.attitude_deg
    err = abs(res.altitude_m / h - 1)
    assert err < 0.10 and err * h <= 3.0 * res.altitude_std_m, res
    assert err < abs(as_level.altitude_m / h - 1)


def _fit_of(h: float, quality: float) -> DispersionResult:
    return DispersionResult(altitude_m=h, altitude_std_m=0.02 * h, camera_velocity_mps=(0.0, 0.0),
                            quality=quality, trusted=False, reason=None, mode="blind",
                            frames=3, n_modes=100, significance=100.0)


@pytest.mark.parametrize("given_holds_shell", [True, False])
def test_a_tilt_the_levelled_views_tiles_do_not_confirm(monkeypatch, given_holds_shell) -> None:
    """The corner tiles show a 12-degree pitch and the frames are levelled at it; the
    levelled view's two tiles that hold the waves lie in one row and cannot see a pitch.  A
    fit of the frames as given that held a shell's peak is read as it was; one that held
    none gives way to the levelled view, read, not trusted, and saying why."""
    focal, est = 268.5, DispersionAltimeter()
    b = math.sin(math.radians(12.0))
    tiles = [(x, y, math.log(6.0) - 1.5 * math.log(b * y / focal + math.sqrt(1 - b * b)), 0.02)
             for x, y in tile_centres((256, 256), (100, 100))]
    levelled = _fit_of(5.0, 0.8)
    frames = np.zeros((3, 256, 256), np.float32)
    monkeypatch.setattr(est, "_fit", lambda *a, **k: (levelled, frames, {}))
    monkeypatch.setattr(est, "_corner_fits", lambda *a, **k: (
        [(-78.0, -78.0, math.log(5.0), 0.02), (78.0, -78.0, math.log(5.0), 0.02)], []))
    given = _fit_of(6.0, 0.8 if given_holds_shell else 0.05)
    res = est._level(frames, 30.0, focal, None, given, tiles, {}, signal=frames)[0]
    if given_holds_shell:
        assert res is given and res.attitude_deg is None and res.reason is None
    else:
        assert res is levelled and res.signal.endswith("+levelled"), res
        assert abs(res.attitude_deg[1]) > 8.0 and res.reason == UNCONFIRMED_TILT


@pytest.mark.parametrize("held", [2, 4])
def test_faint_tiles_help_to_measure_a_tilt_only_where_too_few_tiles_hold_the_shell(
        monkeypatch, held) -> None:
    """A camera pitched 12 degrees: where only the two far tiles hold the shell, the two
    near ones, faint (weak: :meth:`_corner_fits`), join them to measure the pitch, and the
    frames are levelled at it; where all four hold the shell and read one scale, weak tiles
    that read a pitch level nothing.  The weak tiles judge nothing: the levelled fit's tiles
    are those that hold the shell."""
    focal, est = 268.5, DispersionAltimeter()
    b = math.sin(math.radians(12.0))
    centres = tile_centres((256, 256), (100, 100))
    pitched = [(x, y, math.log(6.0) - 1.5 * math.log(b * y / focal + math.sqrt(1 - b * b)),
                0.03) for x, y in centres]
    far = [t for t in pitched if t[1] < 0]  # the pitch reads these high
    near = [t for t in pitched if t[1] > 0]
    level = [(x, y, math.log(6.0), 0.03) for x, y in centres]
    levelled = _fit_of(5.0, 0.8)
    frames = np.zeros((3, 256, 256), np.float32)
    seen = [(x, y, math.log(5.0), 0.02) for x, y in centres]
    monkeypatch.setattr(est, "_fit", lambda *a, **k: (levelled, frames, {}))
    monkeypatch.setattr(est, "_corner_fits", lambda *a, **k: (seen, []))
    given = _fit_of(6.0, 0.8)
    fits = far if held == 2 else level
    res, tiles = est._level(frames, 30.0, focal, None, given, fits, {}, signal=frames,
                            weak=near)[:2]
    if held == 2:
        assert res is levelled and res.signal.endswith("+levelled+faint"), res
        assert abs(res.attitude_deg[1] - 12.0) < 1.0 and abs(res.attitude_deg[0]) < 1.0
        assert tiles is seen and res.reason is None
    else:
        assert res is given and res.attitude_deg is None and tiles is level
    # without the weak tiles the two far ones cannot measure the pitch
    again = _fit_of(6.0, 0.8)
    assert est._level(frames, 30.0, focal, None, again, far, {}, signal=frames)[0] is again


def test_a_tilt_that_faint_tiles_measure_carries_their_doubt(monkeypatch) -> None:
    """A camera pitched 12 degrees whose two near tiles are faint (weak), in the view as
    given and in the levelled one: they measure the pitch with the two far tiles, and the
    levelled fit's uncertainty holds what they leave of it with a weak tile's doubt
    (``WEAK_TILE_SD_LOG``).  The two far tiles, on one side, read the scale at the centre
    only through the slope the near ones give it: in the linear model, the centre's log
    altitude has the variance of the mean of the two sides' means, against the level
    model's weighted mean.  The levelling and the altitude read are those of tiles taken
    at their own sigma; only the uncertainty differs."""
    from wavealt.altimetry.dispersion import levelling

    focal, est = 268.5, DispersionAltimeter()
    b = math.sin(math.radians(12.0))
    centres = tile_centres((256, 256), (100, 100))
    sd = 0.02
    pitched = [(x, y, math.log(6.0) - 1.5 * math.log(b * y / focal + math.sqrt(1 - b * b)),
                sd) for x, y in centres]
    level = [(x, y, math.log(5.0), sd) for x, y in centres]
    frames = np.zeros((3, 256, 256), np.float32)
    monkeypatch.setattr(est, "_fit", lambda *a, **k: (_fit_of(5.0, 0.8), frames, {}))
    monkeypatch.setattr(est, "_corner_fits", lambda *a, **k: (
        [t for t in level if t[1] < 0], [t for t in level if t[1] > 0]))

    def levelled() -> DispersionResult:
        return est._level(frames, 30.0, focal, None, _fit_of(6.0, 0.8),
                          [t for t in pitched if t[1] < 0], {}, signal=frames,
                          weak=[t for t in pitched if t[1] > 0])[0]
    doubted = levelled()
    monkeypatch.setattr(levelling, "WEAK_TILE_SD_LOG", 0.0)
    plain = levelled()
    for res in (doubted, plain):
        assert res.signal.endswith("+levelled+faint") and res.reason is None, res
    assert doubted.altitude_m == plain.altitude_m
    assert doubted.attitude_deg == plain.attitude_deg
    assert abs(plain.attitude_deg[1] - 12.0) < 1.0

    def var(res: DispersionResult) -> float:
        return (res.altitude_std_m / res.altitude_m) ** 2
    v_far = sd * sd / 2.0
    v_near = (sd * sd + WEAK_TILE_SD_LOG**2) / 2.0
    centre = (v_far + v_near) / 4.0
    level_var = 1.0 / (1.0 / v_far + 1.0 / v_near)
    assert var(doubted) - var(plain) >= 0.9 * (centre - level_var), (doubted, plain)
    assert est._distrust(doubted) is not None and est._distrust(plain) is None


@pytest.mark.parametrize("waves", [True, False])
def test_a_levelled_view_whose_peak_flattened_is_read_where_it_holds_waves(monkeypatch,
                                                                           waves) -> None:
    """The frames as given hold a prominent peak at 6 m, their tiles a 12-degree pitch; the
    view levelled at it, resampled, holds the waves (significant) but no prominent peak,
    and its tiles read one scale: it is read, and not trusted.  A levelled view without
    wave signal is not: the frames as given are."""
    focal, est = 268.5, DispersionAltimeter()
    b = math.sin(math.radians(12.0))
    centres = tile_centres((256, 256), (100, 100))
    tiles = [(x, y, math.log(6.0) - 1.5 * math.log(b * y / focal + math.sqrt(1 - b * b)),
              0.02) for x, y in centres]
    levelled = _fit_of(5.0, 0.1)
    levelled.significance = 100.0 if waves else 10.0
    frames = np.zeros((3, 256, 256), np.float32)
    monkeypatch.setattr(est, "_fit", lambda *a, **k: (levelled, frames, {}))
    monkeypatch.setattr(est, "_corner_fits", lambda *a, **k: (
        [(x, y, math.log(5.0), 0.02) for x, y in centres], []))
    given = _fit_of(6.0, 0.8)
    res = est._level(frames, 30.0, focal, None, given, tiles, {}, signal=frames)[0]
    if waves:
        assert res is levelled and abs(res.attitude_deg[1] - 12.0) < 1.0, res
        assert est._distrust(res) is not None
    else:
        assert res is given and res.attitude_deg is None


def test_a_level_camera_is_not_levelled() -> None:
    nadir, sc, cfg = _scene("paper", 5.0, 2)
    frames = _remap(nadir, cfg.focal_px, _pixel_rays(256, cfg.focal_px))
    res = DispersionAltimeter(dispersion="gravity").estimate(
        frames, fps=cfg.fps, focal_px=cfg.focal_px, velocity_mps=sc.camera_velocity_mps)
    assert res.attitude_deg is None and "levelled" not in res.signal and res.trusted, res
    assert res.to_dict()["attitude_deg"] is None
    with pytest.raises(ValueError, match="attitude"):
        DispersionAltimeter(attitude="sideways")


def test_lens_distortion_is_undone_by_the_calibration(tmp_path) -> None:
    h = 5.0
    nadir, sc, cfg = _scene("paper", h, 2)
    size, f = 256, cfg.focal_px * 1.1
    k = np.array([[f, 0.0, 131.0], [0.0, f, 125.0], [0.0, 0.0, 1.0]])
    d = np.array([-0.35, 0.12, 0.0, 0.0, 0.0])  # strong barrel, as of a wide-angle lens
    # each distorted pixel's ray, by OpenCV's inverse of its own distortion model
    u, v = np.meshgrid(np.arange(size, dtype=np.float64), np.arange(size, dtype=np.float64))
    pts = np.stack([u.ravel(), v.ravel()], -1)[:, None, :]
    norm = cv2.undistortPoints(pts, k, d).reshape(size, size, 2)
    rays = np.concatenate([norm, np.ones((size, size, 1))], axis=-1)
    frames = _remap(nadir, cfg.focal_px, rays)
    path = tmp_path / "cam.yaml"
    write_calibration(path, Calibration(k, d, (size, size)))
    view = NadirView(read_calibration(path), size, size)
    est = DispersionAltimeter(dispersion="gravity")
    kw = {"fps": cfg.fps, "velocity_mps": sc.camera_velocity_mps}
    fixed = est.estimate(view(frames), focal_px=view.focal_px, **kw)
    raw = est.estimate(frames, focal_px=f, **kw)
    assert fixed.trusted and abs(fixed.altitude_m / h - 1) < 0.03, fixed
    assert abs(raw.altitude_m / h - 1) > 2 * abs(fixed.altitude_m / h - 1), (raw, fixed)


def test_attitude_log_is_interpolated_and_checked(tmp_path) -> None:
    path = tmp_path / "att.csv"
    path.write_text("time_s,roll_deg,pitch_deg\n0,0,10\n1,4,6\n")
    roll, pitch = read_attitude(path, np.array([0.0, 0.25, 1.0]))
    assert np.allclose(roll, [0, 1, 4]) and np.allclose(pitch, [10, 9, 6])
    with pytest.raises(ValueError, match="covers 0.000-1.000 s"):
        read_attitude(path, np.array([0.0, 1.5]))
    path.write_text("time_s,roll\n0,1\n")
    with pytest.raises(ValueError, match="time_s, roll_deg, pitch_deg"):
        read_attitude(path, np.zeros(2))
    path.write_text("time_s,roll_deg,pitch_deg\n0,1,x\n")
    with pytest.raises(ValueError, match="must be a number"):
        read_attitude(path, np.zeros(2))


def test_per_frame_attitude_levels_every_frame_alike() -> None:
    # a still pattern seen through a swaying camera: levelled, every frame is the same
    nadir = np.repeat(np.random.default_rng(1).random((1, 512, 512)).astype(np.float32), 4, 0)
    nadir = cv2.GaussianBlur(nadir[0], (0, 0), 2.0)[None].repeat(4, 0)
    roll, pitch = np.array([0.0, 3.0, 6.0, 9.0]), np.array([8.0, 6.0, 4.0, 2.0])
    frames = np.stack([_remap(nadir[:1], 256.0, _pixel_rays(256, 256.0)
                              @ tilt_rotation(r, p).T)[0] for r, p in zip(roll, pitch)])
    view = NadirView(pinhole(256, 256, 256.0), 256, 256, roll_deg=roll, pitch_deg=pitch)
    level = view(frames)
    inner = level[:, 8:-8, 8:-8]
    assert np.abs(inner - inner[:1]).max() < 0.05 * np.ptp(inner)
    assert np.abs(frames - frames[:1]).max() > 0.3 * np.ptp(frames)


def test_a_view_made_for_a_box_of_attitudes_levels_each_frame_within_it() -> None:
    """``level_each``: frames at attitudes within the box a view was made for are levelled
    alike, as the view made for those very attitudes levels them, up to the canvas; a frame
    met again costs its remap only (its map is kept); frames and attitudes that do not
    match are refused."""
    nadir = cv2.GaussianBlur(np.random.default_rng(1).random((512, 512)).astype(np.float32),
                             (0, 0), 2.0)[None]
    roll, pitch = np.array([0.0, 1.5, 3.0, 0.7]), np.array([2.0, 1.0, 0.0, 0.4])
    frames = np.stack([_remap(nadir, 256.0, _pixel_rays(256, 256.0)
                              @ tilt_rotation(r, p).T)[0] for r, p in zip(roll, pitch)])
    own = NadirView(pinhole(256, 256, 256.0), 256, 256, roll_deg=roll, pitch_deg=pitch)
    assert np.array_equal(own.level_each(frames, roll, pitch), own(frames))
    box = NadirView(pinhole(256, 256, 256.0), 256, 256, roll_deg=[0, 3, 0, 3],
                    pitch_deg=[0, 0, 2, 2])
    level = box.level_each(frames, roll, pitch)
    inner = level[:, 8:-8, 8:-8]
    assert np.abs(inner - inner[:1]).max() < 0.05 * np.ptp(inner)
    assert len(box._maps) == 4
    box.level_each(frames[::-1], roll[::-1], pitch[::-1])
    assert len(box._maps) == 4  # the same attitudes: the same maps
    with pytest.raises(ValueError, match="4 attitudes"):
        box.level_each(frames[:3], roll, pitch)


def test_cli_levels_a_tilted_clip_from_its_calibration(tmp_path, run_cli) -> None:
    from wavealt.io import write_frames_folder

    h, roll, pitch = 6.0, -8.0, 12.0
    nadir, sc, cfg = _scene("paper", h, 1)
    frames = _remap(nadir, cfg.focal_px,
                    _pixel_rays(256, cfg.focal_px) @ tilt_rotation(roll, pitch).T)
    write_frames_folder(tmp_path / "clip", frames)
    cal = tmp_path / "cam.json"
    write_calibration(cal, pinhole(256, 256, cfg.focal_px))
    vel = ",".join(str(v) for v in sc.camera_velocity_mps)
    base = ["altitude", str(tmp_path / "clip"), "--fps", str(cfg.fps), "--calibration", str(cal),
            "--dispersion", "gravity", "--velocity-mps", vel]
    code, out, err = run_cli([*base, "--roll-deg", str(roll), "--pitch-deg", str(pitch), "--json"])
    assert code == 0, err
    res = json.loads(out)
    assert res["trusted"] and abs(res["altitude_m"] / h - 1) < 0.03, res
    att = tmp_path / "att.csv"
    att.write_text(f"time_s,roll_deg,pitch_deg\n0,{roll},{pitch}\n")
    code, out, err = run_cli([*base, "--attitude", str(att)])
    assert code == 0, err
    assert "levelled to nadir (attitude from" in out
    assert "distortion-free pinhole" not in out  # the calibration given says what the lens is
    code, out, err = run_cli([*base, "--attitude", str(att), "--roll-deg", "1"])
    assert code == 2 and "not both" in err
    code, out, err = run_cli([*base, "--focal-px", "200"])
    assert code == 2 and "exactly one of --focal-px, --fov-deg and --calibration" in err
