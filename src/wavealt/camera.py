"""Nadir pinhole camera: focal length in pixels, ground sampling distance, footprint.

Image axes: column ``u`` grows along ground +x, row ``v`` grows along ground +y.  The
camera looks straight down (-z); +z points up, out of the water.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from wavealt._checks import check_finite_number

MAX_ALTITUDE_M = 15.0


def focal_px_from_fov(width_px: int, fov_x_deg: float) -> float:
    """Focal length in pixels of a pinhole with horizontal field of view ``fov_x_deg``.

    ``focal_px = (W / 2) / tan(fov_x / 2)`` (DESIGN.md).
    """
    fov = check_finite_number("fov_deg", fov_x_deg, low=0.0, high=180.0, low_open=True,
                              high_open=True)
    if width_px < 1:
        msg = f"width_px must be >= 1; got {width_px}"
        raise ValueError(msg)
    return (width_px / 2.0) / math.tan(math.radians(fov) / 2.0)


@dataclass(frozen=True)
class Camera:
    """A nadir pinhole camera at ``altitude_m`` above the mean sea surface.

    Parameters
    ----------
    width_px, height_px : int
        Image size in pixels.
    focal_px : float
        Focal length in pixels (same in x and y; square pixels).
    altitude_m : float
        Height of the optical centre above mean sea level, metres, in (0, 15].
    """

    width_px: int
    height_px: int
    focal_px: float
    altitude_m: float

    def __post_init__(self) -> None:
        for name in ("width_px", "height_px"):
            v = getattr(self, name)
            if int(v) != v or v < 1:
                msg = f"{name} must be a positive integer; got {v!r}"
                raise ValueError(msg)
        check_finite_number("focal_px", self.focal_px, low=0.0, low_open=True)
        check_finite_number("altitude_m", self.altitude_m, low=0.0, low_open=True,
                            high=MAX_ALTITUDE_M)

    @classmethod
    def from_fov(cls, width_px: int, height_px: int, fov_x_deg: float,
                 altitude_m: float) -> Camera:
        return cls(width_px, height_px, focal_px_from_fov(width_px, fov_x_deg), altitude_m)

    @property
    def gsd_m(self) -> float:
        """Ground sampling distance at nadir, metres per pixel: ``altitude_m / focal_px``."""
        return self.altitude_m / self.focal_px

    @property
    def footprint_m(self) -> tuple[float, float]:
        """Ground footprint (x extent, y extent) in metres."""
        return self.width_px * self.gsd_m, self.height_px * self.gsd_m

    @property
    def fov_x_deg(self) -> float:
        return math.degrees(2.0 * math.atan((self.width_px / 2.0) / self.focal_px))

    def view_vectors(self) -> np.ndarray:
        """Unit vectors from each ground point toward the camera, ``(H, W, 3)`` float32.

        For pixel ``(v, u)`` the ray leaves the camera along ``((u-cx)/f, (v-cy)/f, -1)``;
        the vector from the sea toward the camera is its opposite.
        """
        u = (np.arange(self.width_px, dtype=np.float64) + 0.5 - self.width_px / 2.0)
        v = (np.arange(self.height_px, dtype=np.float64) + 0.5 - self.height_px / 2.0)
        uu, vv = np.meshgrid(u / self.focal_px, v / self.focal_px)
        c = np.stack([-uu, -vv, np.ones_like(uu)], axis=-1)
        c /= np.linalg.norm(c, axis=-1, keepdims=True)
        return c.astype(np.float32)
