"""Frames decoded from a video whose codec predicts frames from other frames (H.264, HEVC,
MPEG-4 Part 2, VP9, AV1: every codec of drone and camera recordings and of live streams),
and what that prediction does to the dispersion altimeter's fits.

An inter-frame codec codes most frames as blocks of other frames moved by a motion vector
(motion compensation) plus a quantised residual.  Texture too faint to be worth its bits is
not coded as it evolves: it rides with its block's motion instead of moving as waves.  The
faint waves are the short ones and those running against the wind, and they are what tells
the altitude from the drift where the velocity is not given (a sea that runs one way lets a
higher altitude and a little more drift fit its dominant waves almost as well): the fit
without the velocity slides up that ridge, and its uncertainty does not see it.  With the
velocity given exactly the shell is read where it is.  ``docs/dispersion.md`` (forty-third
session) has the measurements.

So a window of frames predicted with loss is not trusted unless the fit had the velocity
exactly.  Intra-coded video (Motion JPEG, all-key-frame H.264), lossless codecs (FFV1, raw
video) and image folders are not affected.
"""

from __future__ import annotations

from typing import Any

from wavealt.altimetry.dispersion.result import refuse

#: Why a fit of predicted frames without the exact velocity is not trusted (``{codec}``:
#: the codec's name, as FFmpeg gives it).
PREDICTED_FRAMES = ("the frames were decoded from {codec} video, which predicts frames from "
                    "other frames: its motion-compensated texture biases a fit without the "
                    "velocity high (by 1-12 % in our tests); give the camera's velocity over "
                    "the water exactly (--velocity-mps) or intra-coded frames")


def predicted_verdict(result: dict[str, Any], codec: str | None,
                      altitude_range_m: tuple[float, float]) -> dict[str, Any]:
    """``result`` (a ``DispersionResult.to_dict()``), in place and returned: NOT TRUSTED, its
    3-sigma interval spanning ``altitude_range_m`` as the altimeter's untrusted ones do,
    where its frames came from a video whose codec ``codec`` predicts frames from others and
    the fit was not given the velocity exactly (``mode`` other than ``"exact"``); unchanged
    where ``codec`` is None (frames not predicted) or the velocity was exact."""
    if codec is None or result.get("mode") == "exact":
        return result
    return refuse(result, PREDICTED_FRAMES.format(codec=codec), altitude_range_m)


def simulated_codec(config: Any) -> str | None:
    """The codec that predicted the frames of a dataset rendered with simulator config
    ``config`` (``SimConfig``): ``"h264"`` where the realistic renderer's camera coded them
    with libx264 (:attr:`wavealt.sim.config.SensorModel.compression`), else None."""
    if getattr(config, "renderer", None) != "realistic":
        return None
    sensor = getattr(config, "sensor", None)
    return "h264" if getattr(sensor, "compression", None) == "h264" else None


__all__ = ["PREDICTED_FRAMES", "predicted_verdict", "simulated_codec"]
