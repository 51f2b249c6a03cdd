"""Ocean surface synthesis by inverse FFT and its time evolution.

The height field on a periodic ``n x n`` grid of spacing ``dx_m`` is

    h(x, t) = sum_k H(k, t) exp(i k.x),      H(k, t) = D(k, t) + conj(D(-k, t)),
    D(k, t) = c_k exp(-i (omega(k) - k.v) t)  for downwind k, 0 elsewhere,

so every wave travels downwind with the dispersion ``omega(k)`` (paper §3.1; Tessendorf
2001), the field is real (``H`` is Hermitian by construction), and a camera moving at
``v`` over the water sees each mode Doppler-shifted by ``k.v``.  The complex amplitudes
``c_k`` are circular Gaussian with ``E|c_k|^2 = S(k) dk^2 / 2``, so ``E[h^2] = sum S dk^2``.
Nyquist rows/columns carry no energy (their derivative is ill-defined).  Slopes are the
spectral gradient; the whole field is rescaled once so that the mean-square slope over the
periodic domain equals Cox & Munk's, paper eq. (2).  By Parseval that mean is the same at
every time, so one scale serves the whole sequence.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import scipy.fft

from wavealt._checks import as_rng, check_finite_number
from wavealt.sim.sea.spectrum import cox_munk_slope_variance, deep_water_omega, phillips


def _negated_index(n: int) -> np.ndarray:
    """Index array mapping FFT bin ``i`` to the bin of ``-k``: ``(-i) mod n``."""
    return (-np.arange(n)) % n


class OceanSurface:
    """A random, wind-driven sea on a periodic square grid.

    Parameters
    ----------
    n : int
        Grid points per side (even).
    dx_m : float
        Grid spacing, metres.
    wind_speed_mps : float
        Wind speed at 10 m, m/s (> 0).
    wind_dir_rad : float
        Direction the wind blows toward, radians from +x toward +y.
    rng : numpy.random.Generator or int
        Source of the random amplitudes.
    spectrum : callable, optional
        ``spectrum(kx, ky) -> S`` density; default the Phillips spectrum of eq. (1).
    dispersion : callable, optional
        ``omega(k)``; default deep water ``sqrt(g k)``.
    slope_variance : float, optional
        Target mean-square slope; default Cox–Munk eq. (2) for the wind speed.
    """

    def __init__(self, *, n: int, dx_m: float, wind_speed_mps: float, wind_dir_rad: float,
                 rng: Any = None,
                 spectrum: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
                 dispersion: Callable[[np.ndarray], np.ndarray] | None = None,
                 slope_variance: float | None = None) -> None:
        if int(n) != n or n < 4 or n % 2:
            msg = f"n must be an even integer >= 4; got {n!r}"
            raise ValueError(msg)
        self.n = int(n)
        self.dx_m = check_finite_number("dx_m", dx_m, low=0.0, low_open=True)
        self.wind_speed_mps = check_finite_number("wind_speed_mps", wind_speed_mps, low=0.0,
                                                  low_open=True)
        self.wind_dir_rad = check_finite_number("wind_dir_rad", wind_dir_rad)
        rng = as_rng(rng)
        k1 = 2.0 * np.pi * np.fft.fftfreq(self.n, d=self.dx_m)
        self.kx = k1[np.newaxis, :]
        self.ky = k1[:, np.newaxis]
        self.dk = 2.0 * np.pi / (self.n * self.dx_m)

        downwind = (self.kx * np.cos(self.wind_dir_rad) + self.ky * np.sin(self.wind_dir_rad)) > 0
        nyq = self.n // 2
        downwind[nyq, :] = False
        downwind[:, nyq] = False
        self.downwind = downwind
        # Work on the downwind modes alone: their mirrors at -k follow by Hermitian symmetry.
        iy, ix = np.nonzero(downwind)
        kx_d, ky_d = k1[ix], k1[iy]
        if spectrum is None:
            s = phillips(kx_d, ky_d, wind_speed_mps=self.wind_speed_mps,
                         wind_dir_rad=self.wind_dir_rad)
        else:
            s = np.broadcast_to(np.asarray(spectrum(self.kx, self.ky), dtype=np.float64),
                                (self.n, self.n))[iy, ix]
        # circular Gaussian c_k with E|c_k|^2 = S dk^2 / 2: real and imaginary parts each
        # of standard deviation sqrt(S) dk / 2 (single-precision draws: twice as fast, and
        # far finer than the 8-bit images they end in)
        xi = rng.standard_normal((2, iy.size), dtype=np.float32)
        sd = np.sqrt(s) * (self.dk / 2.0)
        c = np.empty(iy.size, dtype=np.complex128)
        c.real = sd * xi[0]
        c.imag = sd * xi[1]
        k2_d = kx_d**2 + ky_d**2
        k_d = np.sqrt(k2_d)
        # Cox–Munk rescaling, paper eq. (2): mean-square slope over the domain, all k.
        ms_slope = 2.0 * float(np.dot(k2_d, c.real**2 + c.imag**2))
        target = (float(cox_munk_slope_variance(self.wind_speed_mps)) if slope_variance is None
                  else check_finite_number("slope_variance", slope_variance, low=0.0,
                                           low_open=True))
        if ms_slope <= 0:
            msg = "the spectrum holds no energy on this grid; widen the domain or change the wind"
            raise ValueError(msg)
        self.scale = float(np.sqrt(target / ms_slope))
        omega_fn = deep_water_omega if dispersion is None else dispersion
        self._neg = _negated_index(self.n)
        keep = c != 0
        self._iy, self._ix = iy[keep], ix[keep]
        self._amp = c[keep] * self.scale
        self._omega = np.asarray(omega_fn(k_d[keep]), dtype=np.float64)
        self._pos = self._iy * self.n + self._ix
        self._negpos = self._neg[self._iy] * self.n + self._neg[self._ix]
        self._kx_d, self._ky_d = k1[self._ix], k1[self._iy]

    def _full(self, values: np.ndarray, dtype: type) -> np.ndarray:
        out = np.zeros(self.n * self.n, dtype=dtype)
        out[self._pos] = values
        return out.reshape(self.n, self.n)

    @property
    def k(self) -> np.ndarray:
        """Wavenumber magnitude of every grid bin, rad/m, ``(n, n)``."""
        return np.sqrt(self.kx**2 + self.ky**2)

    @property
    def amplitudes(self) -> np.ndarray:
        """Complex amplitudes ``c_k`` at t = 0 on the downwind bins (0 elsewhere), ``(n, n)``."""
        return self._full(self._amp, np.complex128)

    @property
    def omega(self) -> np.ndarray:
        """Angular frequency of each downwind bin, rad/s (0 elsewhere), ``(n, n)``."""
        return self._full(self._omega, np.float64)

    # -- spectral state ------------------------------------------------------------------
    def _phase_rate(self, velocity: tuple[float, float]) -> np.ndarray:
        """Observed angular frequency of each downwind mode: ``omega(k) - k.v``."""
        return self._omega - (self._kx_d * velocity[0] + self._ky_d * velocity[1])

    def _hermitian(self, d: np.ndarray, dtype: type = np.complex128) -> np.ndarray:
        """Full spectrum from downwind values ``d``: ``H(k) = d``, ``H(-k) = conj(d)``."""
        out = np.zeros(self.n * self.n, dtype=dtype)
        out[self._pos] = d
        out[self._negpos] = np.conj(d)
        return out.reshape(self.n, self.n)

    def coefficients(self, t: float, *, velocity_mps: tuple[float, float] = (0.0, 0.0)) -> np.ndarray:
        """Fourier coefficients ``H(k, t)`` of the height, ``(n, n)`` complex, Hermitian.

        ``h = scipy.fft.ifft2(H, norm="forward").real`` (no ``1/n^2`` on the inverse).
        """
        return self._hermitian(self._amp * np.exp(-1j * self._phase_rate(velocity_mps) * float(t)))

    def height(self, t: float, **kw: Any) -> np.ndarray:
        """Height field ``(n, n)`` in metres at time ``t`` seconds."""
        return scipy.fft.ifft2(self.coefficients(t, **kw), norm="forward").real

    def slopes(self, t: float, **kw: Any) -> tuple[np.ndarray, np.ndarray]:
        """Slopes ``(dh/dx, dh/dy)``, each ``(n, n)``, at time ``t`` seconds."""
        z = scipy.fft.ifft2((1j * self.kx - self.ky) * self.coefficients(t, **kw), norm="forward")
        return z.real, z.imag

    def mean_square_slope(self) -> float:
        """Mean of ``sx^2 + sy^2`` over the periodic domain (time-invariant)."""
        return float(2.0 * np.sum((self._kx_d**2 + self._ky_d**2) * np.abs(self._amp) ** 2))

    # -- fast frame path -----------------------------------------------------------------
    def iter_fields(self, times_s: np.ndarray, *, crop: tuple[int, int] | None = None,
                    velocity_mps: tuple[float, float] = (0.0, 0.0),
                    with_height: bool = False) -> Iterator[dict[str, np.ndarray]]:
        """Yield ``{"slope_x", "slope_y"[, "height_m"]}`` float32 fields for each time.

        ``crop=(H, W)`` keeps the central ``H x W`` window of the domain (the camera
        footprint).  Works on the downwind modes alone (half the plane) and advances their
        phases by one complex multiply per frame when the times are evenly spaced.
        Single-precision FFTs: slopes carry ~1e-6 relative error, far below the 8-bit
        quantisation of the rendered images.
        """
        if crop is None:
            crop = (self.n, self.n)
        ch, cw = crop
        if ch > self.n or cw > self.n:
            msg = f"crop {crop} is larger than the domain of {self.n} points"
            raise ValueError(msg)
        times = np.asarray(times_s, dtype=np.float64).ravel()
        r0, c0 = (self.n - ch) // 2, (self.n - cw) // 2
        n = self.n
        pos, neg = self._pos, self._negpos
        grad_pos = (1j * self._kx_d - self._ky_d).astype(np.complex64)
        grad_neg = -grad_pos  # the gradient operator (i kx - ky) at -k
        phase_rate = self._phase_rate(velocity_mps)
        steps = np.diff(times)
        uniform = steps.size > 0 and np.allclose(steps, steps[0], rtol=0, atol=1e-12)
        rot = np.exp(-1j * phase_rate * steps[0]).astype(np.complex64) if uniform else None
        spec = np.zeros(n * n, dtype=np.complex64)
        state = None
        for t in times:
            if state is None or rot is None:
                state = (self._amp * np.exp(-1j * phase_rate * t)).astype(np.complex64)
            else:
                state = state * rot
            spec[pos] = grad_pos * state
            spec[neg] = grad_neg * np.conj(state)
            z = _crop_ifft2(spec.reshape(n, n), r0, c0, ch, cw)
            out = {"slope_x": np.ascontiguousarray(z.real), "slope_y": np.ascontiguousarray(z.imag)}
            if with_height:
                hh = _crop_ifft2(self._hermitian(state, np.complex64), r0, c0, ch, cw)
                out["height_m"] = np.ascontiguousarray(hh.real)
            yield out


def _crop_ifft2(spec: np.ndarray, r0: int, c0: int, ch: int, cw: int) -> np.ndarray:
    """``ifft2(spec, norm="forward")[r0:r0+ch, c0:c0+cw]`` transforming only what the crop
    needs: rows in full, then only the kept columns."""
    z = scipy.fft.ifft(spec, axis=1, norm="forward")[:, c0:c0 + cw]
    return scipy.fft.ifft(z, axis=0, norm="forward", overwrite_x=True)[r0:r0 + ch]
