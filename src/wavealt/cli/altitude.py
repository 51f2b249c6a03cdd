"""``wavealt altitude``: recorded frames or a live stream, through the dispersion altimeter,
to the terminal, files and the autopilot."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from wavealt.cli.parse import number_range, vector

if TYPE_CHECKING:  # annotations only: numpy is 0.1 s of --help
    import numpy as np

# Each command imports its stage when it runs, not at the top: the whole library imports in
# 2.7 s (torch alone 1.8 s), `wavealt --help` in 0.06 s (measured on 2 CPU cores, 2026-11-23).


@click.command(short_help="Altitude from frames, a video or a live stream.")
@click.argument("input_path", metavar="[INPUT]", type=click.Path(path_type=Path), required=False)
@click.option("--live", default=None, metavar="SOURCE",
              help="Estimate continuously from a camera device (/dev/video0 with --live-format "
                   "v4l2), a stream URL (rtsp://, udp://, ...), a video file played at its own "
                   "pace, or - for a pipe on standard input; instead of INPUT.  Windows of "
                   "1 s of frames at the stream's rate, a new estimate every fifteenth of a "
                   "window (--window, --step).  Logs to "
                   "OUT/live.csv with --out; stops at the end of the stream, after --duration, "
                   "or on Ctrl-C / SIGTERM.")
@click.option("--live-format", default=None, metavar="FMT",
              help="FFmpeg's input format of the --live source (v4l2, mpegts, h264, ...).")
@click.option("--duration", type=float, default=None, metavar="S",
              help="With --live: stop after S seconds.")
@click.option("--velocity-from-vehicle", is_flag=True,
              help="With --live and --mavlink: the vehicle's velocity over ground as the prior "
                   "on the camera's velocity over the water, with --velocity-sigma-mps for the "
                   "water's unknown current [1 m/s]; blind while none is heard.")
@click.option("--tilt-from-vehicle", is_flag=True,
              help="With --live and --mavlink: level each frame with the vehicle's ATTITUDE "
                   "when it was taken and turn it back at its heading (a camera fixed to the "
                   "airframe, image top toward the nose; ATTITUDE is asked for at 50 Hz), or "
                   "each window with the latest where ATTITUDE comes too seldom.")
@click.option("--camera-latency-ms", type=float, default=None, metavar="MS",
              help="With --tilt-from-vehicle: how long a frame takes from its exposure to its "
                   "decoding here (the camera's and the link's delay); each frame is levelled "
                   "at the attitude of that long before it arrived.  [default: measured from "
                   "the frames' own shake against ATTITUDE; until then each window is levelled "
                   "at its mean attitude]")
@click.option("--fps", type=float, default=None,
              help="Frame rate of a frame folder, frames/s.  A video's own timestamps give its "
                   "frame times; --fps that contradicts them is an error unless --force-fps.  "
                   "With --live: the rate of a source whose frames carry no timestamps (a raw "
                   "H.264 stream), which without it is an error.")
@click.option("--force-fps", is_flag=True,
              help="Use --fps for a video, evenly spaced, instead of its timestamps.")
@click.option("--frame-times", type=click.Path(path_type=Path), default=None, metavar="CSV",
              help="A frame folder's frame times: a CSV with a time_s column (seconds), one "
                   "row per frame in natural name order.")
@click.option("--focal-px", type=float, default=None, help="Focal length in pixels.")
@click.option("--fov-deg", type=float, default=None, help="Horizontal field of view, degrees.")
@click.option("--calibration", type=click.Path(path_type=Path), default=None, metavar="FILE",
              help="The camera's intrinsics and lens distortion, in OpenCV's format (YAML, XML "
                   "or JSON of cv2.FileStorage: camera_matrix, distortion_coefficients); the "
                   "frames are undistorted.  Instead of --focal-px / --fov-deg.")
@click.option("--roll-deg", type=float, default=None,
              help="The camera's roll from nadir, degrees (positive: right side down, the view "
                   "toward the image's left; top of the image toward the nose).")
@click.option("--pitch-deg", type=float, default=None,
              help="The camera's pitch from nadir, degrees (positive: nose up, the view toward "
                   "the image's top).")
@click.option("--attitude", type=click.Path(path_type=Path), default=None, metavar="CSV",
              help="Per-frame attitude: a CSV with time_s, roll_deg, pitch_deg on the frames' "
                   "clock, interpolated at each frame (instead of --roll-deg / --pitch-deg).")
@click.option("--attitude-sigma-deg", type=float, default=None, metavar="S",
              help="How far the camera may be tilted, degrees (one sigma about each axis), "
                   "from the attitude given (--roll-deg / --pitch-deg, --attitude, "
                   "--tilt-from-vehicle) or, with none given, from looking straight down (a "
                   "gimbal's error): the tilt the frames' corner tiles show is weighed against "
                   "it, and what they cannot measure of it joins the uncertainty.  [default: "
                   "an attitude given is exact; none given, a tilt of up to about 15 degrees, "
                   "7.5 a side]")
@click.option("--window", type=int, default=None,
              help="Frames per estimate; longer inputs are cut into sliding windows "
                   "[1 s of frames, at least 10].")
@click.option("--step", type=int, default=None,
              help="Frames between windows [window/2; with --live, window/15].")
@click.option("--dispersion", type=click.Choice(["auto", "gravity-capillary", "gravity"]),
              default="auto", show_default=True,
              help="Dispersion relation of the waves.  auto: a sequence folder of a wavealt "
                   "dataset (DATASET/<condition>/<sequence_id>/) takes its renderer's (gravity "
                   "for the paper preset), anything else real water's (gravity-capillary).")
@click.option("--water-depth-m", type=float, default=None, metavar="D",
              help="The water's depth, m, where it is shallower than about a tenth of the "
                   "altitude (a tidal flat, a beach): waves longer than about twice the depth "
                   "slow down, which a deep-water fit reads as a higher camera.  "
                   "[default: deep water]")
@click.option("--velocity-mps", default=None, metavar="VX,VY",
              help="The camera's velocity over the water, m/s, along image +x (columns) and +y "
                   "(rows); 0,0 when hovering over still water.  Without it (blind) the "
                   "velocity is searched too, which needs about 1 s of frames.")
@click.option("--velocity-sigma-mps", type=float, default=None, metavar="S",
              help="How far (m/s, one sigma) the camera's velocity over the water may lie from "
                   "--velocity-mps, e.g. the water's unknown current (a vehicle's navigation "
                   "gives its velocity over ground); 0 = exact.  [default: 0]")
@click.option("--readout-ms", type=float, default=None, metavar="MS",
              help="A rolling shutter's readout time, ms: the rows are read top to bottom "
                   "over it (a drone camera's is typically 10-30 ms; see its sensor's data). "
                   "A row read later sees the sea carried further; given, the fit undoes it.  "
                   "[default: a global shutter]")
@click.option("--yaw-rate-dps", type=float, default=None, metavar="DPS",
              help="The camera's yaw rate, deg/s, positive turning the image top (the nose) "
                   "right, as a steady turn over the input; each window's frames are turned "
                   "back to its middle frame's orientation, the rate taken as the truth (0: a "
                   "camera that does not turn).  With --tilt-from-vehicle, live, the "
                   "vehicle's own ATTITUDE yawspeed is taken.  [default: measured from the "
                   "corner tiles where they show a turn]")
@click.option("--json", "as_json", is_flag=True,
              help="Print one JSON object: altitude_m, altitude_std_m (1 sigma), trusted, reason "
                   "(why not, else null), mode (blind, prior, exact), camera_velocity_mps (the "
                   "camera relative to the water surface, image axes, m/s; also as "
                   "velocity_mps, the design contract's name), quality, frames, windows, "
                   "trusted_windows; attitude_deg (roll, pitch) where the frames' own tilt was "
                   "measured and levelled, else null; yaw_rate_dps, the rate the frames were "
                   "turned back at (given, or measured), deg/s; shake_px, the camera's shake "
                   "taken out of the frames (root mean square image shift, px).")
@click.option("--out", type=click.Path(path_type=Path), default=None,
              help="Folder for altitude.csv, altitude.json and altitude.png (windowed input).")
@click.option("--force", is_flag=True, help="Replace the altitude files already in --out.")
@click.option("--mavlink", default=None, metavar="ENDPOINT",
              help="Send each window's altitude to a flight controller as a downward "
                   "DISTANCE_SENSOR (pymavlink: udpout:HOST:PORT, udpin:HOST:PORT, tcp:HOST:PORT "
                   "or a serial device); untrusted windows go out as invalid and out of range.")
@click.option("--mavlink-range", default="0.5,20", show_default=True, metavar="MIN,MAX",
              help="The range (m) sent as the sensor's min/max distance.")
def altitude(input_path: Path | None, live: str | None, live_format: str | None,
             duration: float | None, velocity_from_vehicle: bool, tilt_from_vehicle: bool,
             fps: float | None, force_fps: bool, frame_times: Path | None,
             focal_px: float | None, fov_deg: float | None, calibration: Path | None,
             roll_deg: float | None, pitch_deg: float | None, attitude: Path | None,
             attitude_sigma_deg: float | None, window: int | None, step: int | None,
             dispersion: str, water_depth_m: float | None, velocity_mps: str | None,
             velocity_sigma_mps: float | None, readout_ms: float | None,
             yaw_rate_dps: float | None, camera_latency_ms: float | None, as_json: bool,
             out: Path | None, force: bool, mavlink: str | None, mavlink_range: str) -> None:
    """Altitude from a folder of frames, a video file or a live stream, by the wave
    dispersion relation.

    An estimate the altimeter cannot vouch for is still printed, marked NOT TRUSTED with
    the reason.
    """
    from wavealt.altimetry.series import OUT_FILES, altitude_series
    from wavealt.io import check_output_folder, read_clip

    if sum(x is not None for x in (focal_px, fov_deg, calibration)) != 1:
        msg = "give exactly one of --focal-px, --fov-deg and --calibration"
        raise ValueError(msg)
    if attitude is not None and (roll_deg, pitch_deg) != (None, None):
        msg = "give --attitude or --roll-deg/--pitch-deg, not both"
        raise ValueError(msg)
    if (input_path is None) == (live is None):
        msg = "give INPUT (a frame folder or a video file) or --live SOURCE, one of them"
        raise ValueError(msg)
    if live is None and (live_format, duration) != (None, None):
        msg = "--live-format and --duration go with --live"
        raise ValueError(msg)
    if (velocity_from_vehicle or tilt_from_vehicle) and (live is None or mavlink is None):
        msg = "--velocity-from-vehicle and --tilt-from-vehicle need --live and --mavlink"
        raise ValueError(msg)
    if tilt_from_vehicle and (attitude, roll_deg, pitch_deg) != (None, None, None):
        msg = "give --tilt-from-vehicle or a fixed/logged attitude, not both"
        raise ValueError(msg)
    if camera_latency_ms is not None:
        if not tilt_from_vehicle:
            msg = "--camera-latency-ms goes with --tilt-from-vehicle"
            raise ValueError(msg)
        if not (math.isfinite(camera_latency_ms) and 0 <= camera_latency_ms <= 1000):
            msg = f"--camera-latency-ms must be in [0, 1000] ms; got {camera_latency_ms!r}"
            raise ValueError(msg)
    if velocity_from_vehicle and velocity_mps is not None:
        msg = "give --velocity-from-vehicle or --velocity-mps, not both"
        raise ValueError(msg)
    velocity = vector(velocity_mps, "velocity-mps", "VX,VY (m/s)")
    if velocity_sigma_mps is not None:
        if velocity is None and not velocity_from_vehicle:
            msg = "--velocity-sigma-mps needs --velocity-mps (the velocity it is the spread of)"
            raise ValueError(msg)
        if not (math.isfinite(velocity_sigma_mps) and velocity_sigma_mps >= 0):
            msg = f"--velocity-sigma-mps must be a finite number >= 0; got {velocity_sigma_mps!r}"
            raise ValueError(msg)
    if attitude_sigma_deg is not None:
        from wavealt.altimetry.dispersion.levelling import check_attitude_sigma

        check_attitude_sigma("--attitude-sigma-deg", attitude_sigma_deg)
    if readout_ms is not None and not (math.isfinite(readout_ms) and readout_ms >= 0):
        msg = f"--readout-ms must be a finite number >= 0; got {readout_ms!r}"
        raise ValueError(msg)
    readout_s = (readout_ms or 0.0) / 1000.0
    if water_depth_m is not None and not (math.isfinite(water_depth_m) and water_depth_m > 0):
        msg = f"--water-depth-m must be a positive number of metres; got {water_depth_m!r}"
        raise ValueError(msg)
    if yaw_rate_dps is not None:
        from wavealt.camera import MAX_YAW_RATE_DPS

        if not (math.isfinite(yaw_rate_dps) and abs(yaw_rate_dps) <= MAX_YAW_RATE_DPS):
            msg = (f"--yaw-rate-dps must be a number within +-{MAX_YAW_RATE_DPS:g}; "
                   f"got {yaw_rate_dps!r}")
            raise ValueError(msg)
    if live is not None:
        if dispersion == "auto":
            dispersion = "gravity-capillary"
        _altitude_live(live, live_format=live_format, duration=duration, focal_px=focal_px,
                       fov_deg=fov_deg, calibration=calibration, roll_deg=roll_deg,
                       pitch_deg=pitch_deg, attitude=attitude,
                       attitude_sigma_deg=attitude_sigma_deg, window=window, step=step,
                       dispersion=dispersion, water_depth_m=water_depth_m, velocity=velocity,
                       velocity_sigma_mps=velocity_sigma_mps, readout_s=readout_s,
                       yaw_rate_dps=yaw_rate_dps,
                       latency_s=None if camera_latency_ms is None else camera_latency_ms / 1e3,
                       velocity_from_vehicle=velocity_from_vehicle,
                       tilt_from_vehicle=tilt_from_vehicle, as_json=as_json, out=out,
                       force=force, mavlink=mavlink, mavlink_range=mavlink_range, fps=fps)
        return
    if dispersion == "auto":
        from wavealt.altimetry.relation import dispersion_of_input

        dispersion = dispersion_of_input(input_path)
    if out is not None:
        check_output_folder(out, OUT_FILES, force=force)  # before the work, not after it
    clip = read_clip(input_path, fps=fps, frame_times=frame_times, force_fps=force_fps)
    frames, focal_px, view = _level_view(clip, focal_px, fov_deg, calibration, roll_deg,
                                         pitch_deg, attitude)
    link = None
    if mavlink is not None:
        from wavealt.live.mavlink import MavlinkLink

        lo, hi = number_range(mavlink_range, "mavlink-range")
        fov_h = 2 * math.atan(frames.shape[2] / (2 * focal_px))
        fov_v = 2 * math.atan(frames.shape[1] / (2 * focal_px))
        link = MavlinkLink(mavlink, min_m=lo, max_m=hi, fov_rad=(fov_h, fov_v))
    try:
        known = attitude is not None or (roll_deg, pitch_deg) != (None, None)
        summary, rows = altitude_series(
            frames, times_s=clip.times_s, focal_px=focal_px, window=window, step=step,
            dispersion=dispersion, water_depth_m=water_depth_m,
            **attitude_prior(known, attitude_sigma_deg), out=out,
            velocity_mps=velocity,
            velocity_sigma_mps=velocity_sigma_mps or 0.0, readout_s=readout_s,
            yaw_rate_dps=yaw_rate_dps, predicted_by=clip.predicted_by,
            on_window=link.send_altitude if link is not None else None)
    finally:
        if link is not None:
            link.close()
        if hasattr(clip.frames, "close"):  # a video's decoder
            clip.frames.close()
    if as_json:
        click.echo(json.dumps({**summary, "velocity_mps": summary["camera_velocity_mps"]}))
        return
    vx, vy = summary["camera_velocity_mps"]
    verdict = ("TRUSTED" if summary["trusted"]
               else f"NOT TRUSTED ({summary['reason'] or 'no reason given'})")
    click.echo(f"altitude: {summary['altitude_m']:.3f} +/- {summary['altitude_std_m']:.3f} m "
               f"(1 sigma), {verdict}")
    water = "" if water_depth_m is None else f", water {water_depth_m:g} m deep"
    click.echo(f"mode: {summary['mode']} ({dispersion} dispersion{water})")
    if attitude_sigma_deg is not None:
        around = "the attitude given" if known else "nadir"
        click.echo(f"camera attitude: within {attitude_sigma_deg:g} deg of {around} a side "
                   "(1 sigma, --attitude-sigma-deg)")
    click.echo(f"camera velocity over the water: ({vx:+.2f}, {vy:+.2f}) m/s "
               "(image +x columns, +y rows)")
    if summary.get("attitude_deg") is not None:
        roll, pitch = summary["attitude_deg"]
        click.echo(f"camera tilt measured from the frames: roll {roll:+.1f}, pitch {pitch:+.1f} "
                   "deg (frames levelled at it)")
    turned = summary.get("yaw_rate_dps") or 0.0
    if yaw_rate_dps is None and turned != 0.0:
        click.echo(f"camera turning {turned:+.1f} deg/s about its axis, measured from the "
                   "frames (frames turned back at it)")
    shaken = summary.get("shake_px") or 0.0
    if shaken > 0.0:
        click.echo(f"camera shaking: {shaken:.1f} px of image shift taken out of the frames "
                   "(a gimbal, or the attitude frame by frame, does better)")
    click.echo(f"quality {summary['quality']:.2f}, {summary['frames']} frames, "
               f"{summary['windows']} window(s), {summary['trusted_windows']} trusted")
    timing = {"timestamps": "the video's timestamps", "fps": "--fps", "csv": "--frame-times"}
    click.echo(f"frame times from {timing[clip.timing]} ({clip.source_fps:.3g} fps), "
               f"{summary['dropped_frames']} dropped frame(s)")
    click.echo(view)
    if out is not None:
        click.echo(f"written: {out}")


def _altitude_live(source: str, *, live_format: str | None, duration: float | None,
                   focal_px: float | None, fov_deg: float | None, calibration: Path | None,
                   roll_deg: float | None, pitch_deg: float | None, attitude: Path | None,
                   window: int | None, step: int | None, dispersion: str,
                   water_depth_m: float | None, attitude_sigma_deg: float | None,
                   velocity: tuple[float, float] | None, velocity_sigma_mps: float | None,
                   readout_s: float, yaw_rate_dps: float | None, latency_s: float | None,
                   velocity_from_vehicle: bool, tilt_from_vehicle: bool, as_json: bool,
                   out: Path | None, force: bool, mavlink: str | None, mavlink_range: str,
                   fps: float | None = None) -> None:
    """``wavealt altitude --live``: :func:`wavealt.live.run_live` with the altimeter, the
    camera's levelling and the autopilot link."""
    import numpy as np

    from wavealt.altimetry.dispersion import DispersionAltimeter, warm_up
    from wavealt.camera import MAX_YAW_RATE_DPS as MAX_YAW
    from wavealt.camera import NadirView, read_calibration
    from wavealt.io import check_output_folder
    from wavealt.live import LIVE_FILE, run_live
    from wavealt.live.levelling import VehicleLevelling, judge

    if attitude is not None:
        msg = "--attitude is a log for recorded input; live, use --tilt-from-vehicle"
        raise ValueError(msg)
    if duration is not None and not (math.isfinite(duration) and duration > 0):
        msg = f"--duration must be a positive number of seconds; got {duration!r}"
        raise ValueError(msg)
    if fps is not None and not (math.isfinite(fps) and fps > 0):
        msg = f"--fps must be a positive number of frames/s; got {fps!r}"
        raise ValueError(msg)
    # window None: one second of the stream's frames; step None: 15 estimates/s at most
    if (window is not None and window < 3) or (step is not None and step < 1):
        msg = f"--window must be >= 3 and --step >= 1; got {window} and {step}"
        raise ValueError(msg)
    if out is not None:
        check_output_folder(out, (LIVE_FILE,), force=force)
        out.mkdir(parents=True, exist_ok=True)
    est = {known: DispersionAltimeter(dispersion=dispersion, water_depth_m=water_depth_m,
                                      **attitude_prior(known, attitude_sigma_deg))
           for known in (False, True)}
    # the compiled loops before the stream opens (on a cold cache about 10 s, which would
    # otherwise hold up the first estimate); every window then takes them, exact ones too
    warm_up()
    sigma = velocity_sigma_mps
    if velocity_from_vehicle and sigma is None:
        sigma = 1.0
    link = None
    views: dict[tuple[int, int, float, float], Any] = {}

    # the file is read once, before the stream opens (a bad one fails first)
    lens = read_calibration(calibration) if calibration is not None else None
    # each frame at the vehicle's attitude of its moment, the camera's delay behind ATTITUDE
    # measured where not given (wavealt.live.levelling)
    vehicle = VehicleLevelling(lambda w, h: _calibration(w, h, focal_px, fov_deg, lens),
                               latency_s=latency_s, altimeter=est[True])

    def camera(w: int, h: int, roll: float, pitch: float) -> tuple[Any, float]:
        key = (w, h, roll, pitch)
        if key not in views:
            calib = _calibration(w, h, focal_px, fov_deg, lens)
            fixed = lens is None and (roll, pitch) == (0.0, 0.0)
            views[key] = (None if fixed else NadirView(calib, w, h, roll_deg=roll,
                                                         pitch_deg=pitch),
                          calib.camera_matrix[0, 0])
        return views[key]

    def estimate(frames: np.ndarray, fps: float, arrivals: np.ndarray) -> dict[str, Any]:
        roll, pitch = roll_deg or 0.0, pitch_deg or 0.0
        known = (roll_deg, pitch_deg) != (None, None)
        vel, sd, yaw = velocity, sigma or 0.0, yaw_rate_dps
        levelled = None
        if link is not None:
            state = link.poll()
            if tilt_from_vehicle:
                if state.yaw_rate_rad_s is not None:
                    # a spin past the altimeter's reach is turned back as far as it goes
                    yaw = max(-MAX_YAW, min(MAX_YAW, math.degrees(state.yaw_rate_rad_s)))
                levelled = vehicle.level(frames, arrivals, link.attitude_at,
                                         state.attitude_rad and state.attitude_rad[:2],
                                         link.heading_at)
            if velocity_from_vehicle:
                # in the axes of the frames' middle moment, which every turn is taken back to
                middle = 0.5 * (arrivals[0] + arrivals[-1]) - (vehicle.delay_s or 0.0)
                heading = link.heading_at(np.array([middle]))
                vel = link.camera_velocity_mps(
                    yaw_rad=None if heading is None else float(heading[0]))
        info: dict[str, Any] = {}
        if levelled is not None:
            frames, f, info = levelled
            known = True
            if "yaw_rate_dps" in info:
                yaw = 0.0  # each frame was turned back at its own heading
        else:
            roll, pitch = round(roll * 2) / 2, round(pitch * 2) / 2  # a new view per 0.5 deg
            view, f = camera(frames.shape[2], frames.shape[1], roll, pitch)
            if view is not None:
                frames, f = view(frames), view.focal_px
                info = {"roll_deg": roll, "pitch_deg": pitch}
        res = est[known].estimate(frames, fps=fps, focal_px=f, velocity_mps=vel,
                                  velocity_sigma_mps=sd if vel is not None else 0.0,
                                  readout_s=readout_s,
                                  yaw_rate_dps=yaw).to_dict()
        return judge(res, info, est[known].altitude_range_m)

    def deliver(res: dict[str, Any]) -> None:
        """Each estimate as judged whole (run_live's verdict on predicted frames too): shown,
        and sent where a flight controller is linked."""
        if not as_json:
            verdict = "TRUSTED" if res["trusted"] else f"NOT TRUSTED ({res['reason']})"
            click.echo(f"{res['altitude_m']:.3f} +/- {res['altitude_std_m']:.3f} m  "
                       f"{res['mode']}  {verdict}")
        if link is not None:
            link.send_altitude(res)

    if mavlink is not None:
        from wavealt.live.mavlink import MavlinkLink

        lo, hi = number_range(mavlink_range, "mavlink-range")
        link = MavlinkLink(mavlink, min_m=lo, max_m=hi)
        if tilt_from_vehicle:
            link.request_attitude_rate()
    try:
        summary = run_live(source, estimate=estimate, window=window, step=step, fmt=live_format,
                           duration_s=duration, fps=fps,
                           log=out / LIVE_FILE if out is not None else None,
                           on_estimate=deliver, altitude_range_m=est[False].altitude_range_m)
    finally:
        if link is not None:
            link.close()
    if as_json:
        click.echo(json.dumps(summary))
        return
    click.echo(f"{summary['estimates']} estimates ({summary['trusted_estimates']} trusted) from "
               f"{summary['frames']} frames in {summary['seconds']:.1f} s, "
               f"{summary['dropped_frames']} dropped; latency median "
               f"{summary['latency_ms_median']:.0f} ms; stopped by {summary['stopped_by']}")
    if out is not None:
        click.echo(f"written: {out / LIVE_FILE}")


def _calibration(w: int, h: int, focal_px: float | None, fov_deg: float | None,
                 lens: Any) -> Any:
    """The camera of ``w x h`` frames: the calibration ``lens`` (read from --calibration)
    scaled to them, else a pinhole of --focal-px or --fov-deg."""
    from wavealt.camera import focal_px_from_fov, pinhole

    if lens is not None:
        return lens.for_size(w, h)
    return pinhole(w, h, focal_px if focal_px is not None else focal_px_from_fov(w, fov_deg))


def _level_view(clip: Any, focal_px: float | None, fov_deg: float | None,
                calibration: Path | None, roll_deg: float | None, pitch_deg: float | None,
                attitude: Path | None) -> tuple[Any, float, str]:
    """The frames the altimeter fits, their focal length, and a line saying how they were
    made: as read, taken for a distortion-free pinhole (which the waves cannot check: an
    uncalibrated barrel lens reads high, ``docs/dispersion.md``, forty-fifth session);
    undistorted and levelled (``camera.NadirView``) for a calibration or an attitude."""
    import numpy as np

    from wavealt.camera import NadirView, read_attitude, read_calibration

    frames = clip.frames
    h, w = frames.shape[1:3]
    lens = read_calibration(calibration) if calibration is not None else None
    calib = _calibration(w, h, focal_px, fov_deg, lens)
    tilted = attitude is not None or (roll_deg, pitch_deg) != (None, None)
    if lens is None and not tilted:
        return frames, float(calib.camera_matrix[0, 0]), (
            "camera: taken as a distortion-free pinhole (a lens that distorts reads high: "
            "give --calibration)")
    if attitude is not None:
        roll, pitch = read_attitude(attitude, clip.times_s)
        source = f"attitude from {attitude}"
    else:
        roll, pitch = roll_deg or 0.0, pitch_deg or 0.0
        source = f"roll {roll:+.1f} deg, pitch {pitch:+.1f} deg"
    view = NadirView(calib, w, h, roll_deg=roll, pitch_deg=pitch)
    ow, oh = view.out_size
    lens = f"undistorted ({calibration}), " if calibration is not None else ""
    if isinstance(frames, np.ndarray):
        levelled = view(frames)
    else:  # a video read window by window: each window levelled as it is read
        from wavealt.framesource import WindowMap

        levelled = WindowMap(frames, lambda window, start: view(window, first=start),
                             (frames.shape[0], oh, ow, *frames.shape[3:]), frames.dtype)
    return levelled, view.focal_px, (f"camera: {lens}levelled to nadir ({source}): "
                                     f"{ow}x{oh} px at focal {view.focal_px:.1f} px")


def attitude_prior(known: bool, sigma_deg: float | None) -> dict[str, Any]:
    """The altimeter's ``attitude`` and ``attitude_sigma_deg`` for frames levelled at an
    attitude given (``known``; fixed, logged or the vehicle's) or not, ``sigma_deg`` how far
    the camera may be tilted from it (None: not given).  Frames levelled at an attitude
    given exactly are taken as level: no tilt is measured, nor allowed for; with a
    ``sigma_deg`` the tilt left is measured against it."""
    if sigma_deg is None:
        return {"attitude": "level" if known else "estimate"}
    return {"attitude": "estimate", "attitude_sigma_deg": sigma_deg}
