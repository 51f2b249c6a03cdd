"""Cameras: the nadir pinhole (focal length in pixels, ground sampling distance, footprint),
and real cameras (calibration, lens distortion, attitude) turned to its view.

Image axes: column ``u`` grows along ground +x, row ``v`` grows along ground +y.  The
camera looks straight down (-z); +z points up, out of the water.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from wavealt._checks import check_finite_number, check_integer, read_number_columns

MAX_ALTITUDE_M = 15.0


def focal_px_from_fov(width_px: int, fov_x_deg: float) -> float:
    """Focal length in pixels of a pinhole with horizontal field of view ``fov_x_deg``.

    ``focal_px = (W / 2) / tan(fov_x / 2)`` (pinhole).
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
            check_integer(name, getattr(self, name), low=1)
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


# -- real cameras: calibration, lens distortion, attitude ------------------------------------
#: Names of the camera matrix and distortion coefficients in calibration files, in the order
#: tried: OpenCV's calibration sample and ``cv2.FileStorage`` users write the first.
_MATRIX_KEYS = ("camera_matrix", "cameraMatrix", "K")
_DIST_KEYS = ("distortion_coefficients", "dist_coeffs", "distCoeffs", "D")
#: Largest tilt from nadir a frame may have, degrees: beyond it the far edge of the view
#: reaches toward the horizon and the rectified sea is mostly interpolated.
MAX_TILT_DEG = 30.0


@dataclass(frozen=True)
class Calibration:
    """Intrinsics and lens distortion of a real camera (OpenCV's model).

    Attributes
    ----------
    camera_matrix : (3, 3) array
        ``[[fx, 0, cx], [0, fy, cy], [0, 0, 1]]``, pixels.
    dist_coeffs : (N,) array
        OpenCV's distortion coefficients ``(k1, k2, p1, p2[, k3[, k4, k5, k6[, ...]]])``.
    image_size : (int, int) or None
        ``(width, height)`` of the images it was made from, when the file says.
    """

    camera_matrix: np.ndarray
    dist_coeffs: np.ndarray
    image_size: tuple[int, int] | None = None

    def for_size(self, width: int, height: int) -> Calibration:
        """The calibration of the same lens and sensor at ``width x height`` (frames scaled,
        e.g. 1920x1080 read at 960x540); a different aspect ratio is an error (a crop, not a
        scaling: the principal point would move)."""
        if self.image_size is None or self.image_size == (width, height):
            return self
        w0, h0 = self.image_size
        sx, sy = width / w0, height / h0
        if abs(sx / sy - 1.0) > 0.01:
            msg = (f"frames are {width}x{height} px but the calibration is for {w0}x{h0}: "
                   "not the same aspect ratio (a crop?); calibrate at this size")
            raise ValueError(msg)
        k = self.camera_matrix.copy()
        k[0] *= sx
        k[1] *= sy
        return Calibration(k, self.dist_coeffs, (width, height))


def read_calibration(path: str | Path) -> Calibration:
    """A camera calibration in OpenCV's ``cv2.FileStorage`` format (YAML, XML or JSON), as
    OpenCV's calibration sample and most calibration tools write it: ``camera_matrix`` (3x3)
    and ``distortion_coefficients``, optionally ``image_width`` and ``image_height``."""
    import cv2  # deferred: 0.45 s of `wavealt altitude`, only with a calibration

    path = Path(path)
    if not path.is_file():
        msg = f"calibration file not found: {path}"
        raise FileNotFoundError(msg)
    try:
        fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    except (cv2.error, SystemError):  # OpenCV's parser reports a syntax error as either
        msg = (f"{path} is not a calibration file OpenCV can read (YAML, XML or JSON of "
               "cv2.FileStorage)")
        raise ValueError(msg) from None
    try:
        if not fs.isOpened():
            msg = f"{path} is not a calibration file OpenCV can read"
            raise ValueError(msg)

        def mat(keys: tuple[str, ...]) -> np.ndarray | None:
            for key in keys:
                node = fs.getNode(key)
                if not node.empty():
                    m = node.mat()
                    if m is None:  # a plain sequence rather than an opencv-matrix
                        m = np.array([node.at(i).real() for i in range(node.size())])
                    return np.asarray(m, dtype=np.float64)
            return None

        k = mat(_MATRIX_KEYS)
        d = mat(_DIST_KEYS)
        size = tuple(int(fs.getNode(n).real()) for n in ("image_width", "image_height")
                     if not fs.getNode(n).empty())
    finally:
        fs.release()
    if k is None:
        msg = f"{path} has no camera matrix (one of {', '.join(_MATRIX_KEYS)})"
        raise ValueError(msg)
    if k.size != 9:
        msg = f"{path}: the camera matrix must be 3x3; got {k.size} numbers"
        raise ValueError(msg)
    k = k.reshape(3, 3)
    d = np.zeros(5) if d is None else d.ravel()
    if d.size not in (4, 5, 8, 12, 14):
        msg = f"{path}: OpenCV takes 4, 5, 8, 12 or 14 distortion coefficients; got {d.size}"
        raise ValueError(msg)
    if not (np.all(np.isfinite(k)) and np.all(np.isfinite(d))):
        msg = f"{path}: the camera matrix or distortion coefficients are not finite"
        raise ValueError(msg)
    if not (k[0, 0] > 0 and k[1, 1] > 0 and abs(k[2, 2] - 1.0) < 1e-9
            and k[1, 0] == k[2, 0] == k[2, 1] == 0):
        msg = f"{path}: not a camera matrix [[fx, s, cx], [0, fy, cy], [0, 0, 1]], fx, fy > 0"
        raise ValueError(msg)
    image_size = (size[0], size[1]) if len(size) == 2 and min(size) > 0 else None
    return Calibration(k, d, image_size)


def write_calibration(path: str | Path, calib: Calibration) -> None:
    """Write ``calib`` in OpenCV's format (the file type from the suffix: .yaml, .xml, .json),
    as :func:`read_calibration` and OpenCV read it."""
    import cv2  # deferred: 0.45 s of `wavealt altitude`, only with a calibration

    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    try:
        if calib.image_size is not None:
            fs.write("image_width", int(calib.image_size[0]))
            fs.write("image_height", int(calib.image_size[1]))
        fs.write("camera_matrix", np.asarray(calib.camera_matrix, dtype=np.float64))
        fs.write("distortion_coefficients",
                 np.asarray(calib.dist_coeffs, dtype=np.float64).reshape(-1, 1))
    finally:
        fs.release()


def pinhole(width: int, height: int, focal_px: float) -> Calibration:
    """A distortion-free pinhole with its principal point at the image centre."""
    k = np.array([[focal_px, 0.0, width / 2.0], [0.0, focal_px, height / 2.0], [0.0, 0.0, 1.0]])
    return Calibration(k, np.zeros(5), (int(width), int(height)))


def tilt_rotation(roll_deg: float, pitch_deg: float) -> np.ndarray:
    """Rotation from a tilted camera's axes to those of a level one looking straight down,
    OpenCV's camera convention (x right, y down the image, z along the optical axis).

    The camera is mounted looking down with the top of the image toward the vehicle's nose;
    ``roll_deg`` and ``pitch_deg`` are the camera's attitude in the aerospace convention of
    the vehicle's (roll positive right side down, pitch positive nose up; MAVLink's
    ``ATTITUDE``).  Positive roll turns the view toward the image's left, positive pitch
    toward its top.  Heading is kept: the level camera's image top is the nose's direction.
    """
    for name, v in (("roll_deg", roll_deg), ("pitch_deg", pitch_deg)):
        check_finite_number(name, v, low=-MAX_TILT_DEG, high=MAX_TILT_DEG)
    r, p = math.radians(roll_deg), math.radians(pitch_deg)
    rx = np.array([[1.0, 0.0, 0.0], [0.0, math.cos(r), -math.sin(r)],
                   [0.0, math.sin(r), math.cos(r)]])
    ry = np.array([[math.cos(p), 0.0, math.sin(p)], [0.0, 1.0, 0.0],
                   [-math.sin(p), 0.0, math.cos(p)]])
    # camera (x right, y toward the tail, z down) -> body (forward, right, down)
    m = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    return m.T @ ry @ rx @ m


class NadirView:
    """Undistorts frames and turns them to the view of a level camera looking straight
    down: a distortion-free pinhole whose image plane is parallel to the sea, so that one
    pixel is the same distance on the sea everywhere (``altitude / focal_px``), which the
    dispersion altimeter assumes.

    The level view is taken from the same optical centre (a pure rotation: an exact
    homography for any scene), centred where the real camera's mean optical axis meets the
    sea, at the real camera's resolution there, and cropped to the largest centred rectangle
    the real frame covers.  Remapping is OpenCV's (``cv2.initUndistortRectifyMap``,
    ``cv2.remap``, bilinear).

    Parameters
    ----------
    calib : Calibration
        The camera's intrinsics and distortion, at the frames' size (:meth:`Calibration.for_size`).
    width, height : int
        Frame size, pixels.
    roll_deg, pitch_deg : float or (T,) array
        The camera's attitude (:func:`tilt_rotation`), one for all frames or one per frame.
    """

    def __init__(self, calib: Calibration, width: int, height: int, *,
                 roll_deg: float | np.ndarray = 0.0, pitch_deg: float | np.ndarray = 0.0) -> None:
        import cv2  # deferred: 0.45 s of `wavealt altitude`, only with a calibration

        self._cv2 = cv2
        self.calib = calib.for_size(width, height)
        self.size = (int(width), int(height))
        roll = np.atleast_1d(np.asarray(roll_deg, dtype=np.float64))
        pitch = np.atleast_1d(np.asarray(pitch_deg, dtype=np.float64))
        roll, pitch = np.broadcast_arrays(roll, pitch)
        self.rotations = [tilt_rotation(float(r), float(p)) for r, p in zip(roll, pitch)]
        k = self.calib.camera_matrix
        mean_rot = tilt_rotation(float(roll.mean()), float(pitch.mean()))
        axis = mean_rot @ np.array([0.0, 0.0, 1.0])  # the optical axis in the level frame
        # resolution of the real camera where its axis meets the sea, as a level focal length
        self.focal_px = float(math.sqrt(k[0, 0] * k[1, 1]) * axis[2])
        # the axis's point on the sea, in a level camera of that focal, centred on a canvas
        # twice the frame (room for the crop's search)
        cw, ch = 2 * width, 2 * height
        off = self.focal_px * axis[:2] / axis[2]
        k_canvas = np.array([[self.focal_px, 0.0, cw / 2.0 - off[0]],
                             [0.0, self.focal_px, ch / 2.0 - off[1]], [0.0, 0.0, 1.0]])
        valid = np.ones((ch, cw), dtype=bool)
        for rot in _spanning(self.rotations, roll, pitch):
            mx, my = cv2.initUndistortRectifyMap(k, self.calib.dist_coeffs, rot, k_canvas,
                                                 (cw, ch), cv2.CV_32FC1)
            # within the frame's outer pixel edges (half a pixel beyond the outer centres)
            valid &= (mx >= -0.5) & (mx <= width - 0.5) & (my >= -0.5) & (my <= height - 0.5)
        s = _largest_centred(valid, width / height)
        ow = max(16, int(s * width / height + 1e-6) // 2 * 2)
        oh = max(16, int(s + 1e-6) // 2 * 2)
        k_out = k_canvas.copy()
        k_out[0, 2] -= (cw - ow) / 2.0
        k_out[1, 2] -= (ch - oh) / 2.0
        self.camera_matrix = k_out
        self.out_size = (ow, oh)
        # one attitude: its map is made once; one per frame: each frame's when it is remapped
        self._map = self._make_map(self.rotations[0]) if len(self.rotations) == 1 else None

    def _make_map(self, rot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return self._cv2.initUndistortRectifyMap(
            self.calib.camera_matrix, self.calib.dist_coeffs, rot, self.camera_matrix,
            self.out_size, self._cv2.CV_16SC2)

    def __call__(self, frames: np.ndarray, first: int | None = None) -> np.ndarray:
        """The level, undistorted view of ``(T, H, W[, 3])`` frames (one attitude, or one
        per frame), same dtype.  ``first``: the frames are a window of the clip the
        attitudes are of, starting at frame ``first`` (None: the whole clip)."""
        frames = np.asarray(frames)
        t, h, w = frames.shape[:3]
        if (w, h) != self.size:
            msg = f"frames are {w}x{h} px; this view was made for {self.size[0]}x{self.size[1]}"
            raise ValueError(msg)
        n_rot = len(self.rotations)
        if n_rot != 1 and (t != n_rot if first is None
                           else not (0 <= first and first + t <= n_rot)):
            where = f"{t} frames" if first is None else f"frames {first}-{first + t - 1}"
            msg = f"{n_rot} attitudes for {where}"
            raise ValueError(msg)
        first = first or 0
        out = np.empty((t, self.out_size[1], self.out_size[0], *frames.shape[3:]),
                       dtype=frames.dtype)
        for i in range(t):
            m1, m2 = self._map or self._make_map(self.rotations[first + i])
            out[i] = self._cv2.remap(frames[i], m1, m2, self._cv2.INTER_LINEAR,
                                     borderMode=self._cv2.BORDER_REPLICATE)
        return out

    def level_each(self, frames: np.ndarray, roll_deg: np.ndarray,
                   pitch_deg: np.ndarray) -> np.ndarray:
        """``(T, H, W[, 3])`` frames, each at its own attitude (``(T,)`` degrees), onto this
        view's level canvas: a stream's windows, whose attitudes lie within those the view
        was made for (its crop holds only pixels every one of those sees).  Each attitude's
        map is kept (the newest 256): a frame met again in the next window costs only its
        remap."""
        frames = np.asarray(frames)
        t, h, w = frames.shape[:3]
        if (w, h) != self.size or np.shape(roll_deg) != (t,) or np.shape(pitch_deg) != (t,):
            msg = (f"{t} frames of {w}x{h} px and {np.size(roll_deg)} attitudes; this view "
                   f"was made for {self.size[0]}x{self.size[1]}")
            raise ValueError(msg)
        cache = self.__dict__.setdefault("_maps", {})
        out = np.empty((t, self.out_size[1], self.out_size[0], *frames.shape[3:]),
                       dtype=frames.dtype)
        for i in range(t):
            key = (float(roll_deg[i]), float(pitch_deg[i]))
            if key not in cache:
                cache[key] = self._make_map(tilt_rotation(*key))
                while len(cache) > 256:
                    del cache[next(iter(cache))]  # the oldest
            m1, m2 = cache[key]
            out[i] = self._cv2.remap(frames[i], m1, m2, self._cv2.INTER_LINEAR,
                                     borderMode=self._cv2.BORDER_REPLICATE)
        return out


def _spanning(rotations: list[np.ndarray], roll: np.ndarray,
              pitch: np.ndarray) -> list[np.ndarray]:
    """The attitudes whose common view bounds the crop: all of up to 16, else 16 evenly
    spaced ones and the corners of the roll-pitch box."""
    if len(rotations) <= 16:
        return rotations
    pick = [rotations[i] for i in np.linspace(0, len(rotations) - 1, 16).astype(int)]
    return pick + [tilt_rotation(float(r), float(p)) for r in (roll.min(), roll.max())
                   for p in (pitch.min(), pitch.max())]


def _largest_centred(valid: np.ndarray, aspect: float) -> float:
    """Height (px) of the largest rectangle of width/height ``aspect`` centred on ``valid``
    (a boolean canvas) that holds only valid pixels; bisection on its size."""
    ch, cw = valid.shape
    # a prefix sum answers "any invalid pixel in this rectangle" in O(1)
    bad = np.pad(np.cumsum(np.cumsum(~valid, 0), 1), ((1, 0), (1, 0)))

    def fits(s: float) -> bool:
        hh, hw = s / 2.0, s * aspect / 2.0
        y0, y1 = int(math.floor(ch / 2 - hh)), int(math.ceil(ch / 2 + hh))
        x0, x1 = int(math.floor(cw / 2 - hw)), int(math.ceil(cw / 2 + hw))
        if y0 < 0 or x0 < 0 or y1 > ch or x1 > cw:
            return False
        return bad[y1, x1] - bad[y0, x1] - bad[y1, x0] + bad[y0, x0] == 0

    lo, hi = 0.0, float(ch)
    for _ in range(30):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if fits(mid) else (lo, mid)
    if lo < 16:
        msg = "the level view of these frames is smaller than 16 px (tilt too large?)"
        raise ValueError(msg)
    return lo


def read_attitude(path: str | Path, times_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The camera's roll and pitch (degrees, :func:`tilt_rotation`) at ``times_s``, linearly
    interpolated from a log: a CSV with the columns ``time_s``, ``roll_deg`` and
    ``pitch_deg``, its times on the frames' clock (the first frame at 0 s) and covering them."""
    rows = read_number_columns(path, ("time_s", "roll_deg", "pitch_deg"), "attitude file")
    if rows.shape[0] < 1 or not np.all(np.isfinite(rows)):
        msg = f"attitude file {path}: needs at least one row of finite numbers"
        raise ValueError(msg)
    t = rows[:, 0]
    if np.any(np.diff(t) <= 0):
        msg = f"attitude file {path}: time_s must be strictly increasing"
        raise ValueError(msg)
    times_s = np.asarray(times_s, np.float64)
    if rows.shape[0] > 1 and (times_s.min() < t[0] - 1e-6 or times_s.max() > t[-1] + 1e-6):
        msg = (f"attitude file {path} covers {t[0]:.3f}-{t[-1]:.3f} s; the frames span "
               f"{times_s.min():.3f}-{times_s.max():.3f} s")
        raise ValueError(msg)
    if rows.shape[0] == 1:
        return np.full(times_s.shape, rows[0, 1]), np.full(times_s.shape, rows[0, 2])
    return np.interp(times_s, t, rows[:, 1]), np.interp(times_s, t, rows[:, 2])


#: The fastest yaw the altimeter turns back, degrees per second (a multirotor's yaw rate
#: limit is typically 90-200 deg/s; at more the frames' corners turn out of view within
#: a second of clip).
MAX_YAW_RATE_DPS = 180.0


def unturn_yaw(frames: np.ndarray, yaw_rate_dps: float, fps: float) -> np.ndarray:
    """Frames of a camera looking straight down while it yaws at ``yaw_rate_dps``, turned
    back to the orientation of the clip's middle frame, about the image centre.

    The camera is mounted as :func:`tilt_rotation` says (top of the image toward the nose,
    +x columns the vehicle's right); the rate is the vehicle's yaw rate, positive turning
    the nose right (clockwise seen from above; MAVLink's ``ATTITUDE.yawspeed``).  A turn
    of the nose by ``d`` moves the scene point at ``(x, y)`` from the centre (y down) to
    ``(x cos d + y sin d, -x sin d + y cos d)``: frame ``t`` is sampled there with
    ``d = rate (t - t_mid) / fps`` (bilinear, OpenCV), so that every frame shows the sea
    where the middle frame does.  Near the corners the sea turns out of view: those pixels
    mirror the frame's edge (what no frame saw).  ``(T, H, W[, 3])`` in, the same out.
    """
    yaw_rate_dps = check_finite_number("yaw_rate_dps", yaw_rate_dps, low=-MAX_YAW_RATE_DPS,
                                       high=MAX_YAW_RATE_DPS)
    fps = check_finite_number("fps", fps, low=0.0, low_open=True)
    t = frames.shape[0]
    return unturn_headings(frames, [yaw_rate_dps * (i - (t - 1) / 2.0) / fps
                                    for i in range(t)])


def unturn_headings(frames: np.ndarray, headings_deg: np.ndarray | list[float]) -> np.ndarray:
    """:func:`unturn_yaw` of frames whose heading (degrees, positive the nose right) each
    is ``headings_deg[i]`` from the one they are turned back to (a heading log, as a
    vehicle's ``ATTITUDE.yaw`` gives it, less the middle frame's): frame ``i`` is sampled
    where ``d = headings_deg[i]`` moved the scene."""
    import cv2  # deferred: only for a yawing camera

    t, h, w = frames.shape[:3]
    if len(headings_deg) != t:
        msg = f"{len(headings_deg)} headings for {t} frames"
        raise ValueError(msg)
    cx, cy = (w - 1) / 2.0, (h - 1) / 2.0
    out = np.empty_like(frames)
    for i in range(t):
        d = math.radians(headings_deg[i])
        c, s = math.cos(d), math.sin(d)
        # out(x, y) = frame(c x + s y, -s x + c y), coordinates from the centre
        m = np.array([[c, s, cx - c * cx - s * cy], [-s, c, cy + s * cx - c * cy]])
        out[i] = cv2.warpAffine(frames[i], m, (w, h),
                                flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
                                borderMode=cv2.BORDER_REFLECT_101)
    return out
