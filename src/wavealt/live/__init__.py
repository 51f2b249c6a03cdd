"""Live altimetry: ``stream`` (frames from a camera, stream or pipe into rolling windows) and
``mavlink`` (altitude to the flight controller, the vehicle's state back)."""

from wavealt.live.stream import (
    LIVE_COLUMNS,
    LIVE_FILE,
    FrameReader,
    ReaderStats,
    run_live,
)

__all__ = ["LIVE_COLUMNS", "LIVE_FILE", "FrameReader", "ReaderStats", "run_live"]
