"""Estimators side by side: anything that turns a test sequence into one altitude.

``--estimator`` of ``wavealt evaluate``):

``cnn:RUN``       the trained CNN of run folder RUN (best checkpoint)
``constant:RUN``  always the training-set mean altitude of RUN (the baseline to beat)
``constant``      always the mean altitude of the dataset's own train split
``dispersion``    the physics-based dispersion-relation altimeter (``wavealt.altimetry.dispersion``)
                  with the dispersion relation of the dataset's renderer (``gravity`` for the
                  ``paper`` renderer, ``gravity-capillary`` for ``realistic``);
                  ``dispersion:gravity`` / ``dispersion:gravity-capillary`` force one;
                  blind: the camera's velocity over the water is searched too
``dispersion-aided``  the same, given the camera's true velocity from the manifest (as a
                  vehicle's navigation would give it) as exact: only the altitude is searched
``dispersion-prior[:SIGMA]``  the same velocity as a prior: the camera's velocity over the
                  water may lie about SIGMA m/s (one sigma, default 1.0) from it; a further
                  ``:gravity`` / ``:gravity-capillary`` forces the dispersion relation
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from wavealt._checks import check_finite_number
from wavealt.altimetry.coding import predicted_verdict, simulated_codec
from wavealt.altimetry.dispersion import DISPERSIONS, DispersionAltimeter
from wavealt.altimetry.relation import dispersion_of, dispersion_of_input

#: Default one-sigma spread (m/s) of ``dispersion-prior``: the camera's velocity over the
#: water may differ from the navigation's by about a strong tidal current.
PRIOR_SIGMA_MPS = 1.0


class Estimator(Protocol):
    name: str

    def estimate(self, dataset: Any, condition: str, record: Any) -> float:
        """Altitude (m) of one sequence of ``dataset`` in ``condition``; NaN if it gives up."""


@dataclass
class ConstantEstimator:
    """Always answers ``altitude_m`` (the training-set mean): the baseline to beat."""

    altitude_m: float
    source: str = ""
    name: str = "constant"

    def estimate(self, dataset: Any, condition: str, record: Any) -> float:
        return float(self.altitude_m)


class CnnEstimator:
    """The CNN of a training run folder (best checkpoint), mean over a sequence's frames."""

    def __init__(self, run: Path | str, *, device: str = "auto") -> None:
        # deferred: torch's import costs 1.8 s; only a CNN estimator needs it
        from wavealt.altimetry.predict import load_run

        self.run = Path(run)
        self.predictor = load_run(self.run, device=device)
        cfg = self.predictor.config
        kind = "temporal " if cfg.temporal else ""
        self.name = f"cnn ({kind}{cfg.model}, trained on {cfg.condition})"

    @property
    def train_mean_m(self) -> float:
        return float(self.predictor.stats["target_mean_m"])

    def estimate(self, dataset: Any, condition: str, record: Any) -> float:
        frames = dataset.read_frames(condition, record.sequence_id)
        return self.predictor.predict_sequence(frames)


@dataclass(frozen=True)
class GradedEstimate:
    """An altitude with the estimator's own verdict on it.

    Attributes
    ----------
    altitude_m : float
        Estimated altitude, metres (NaN when the estimator gave up).
    quality : float
        The fit's quality in [0, 1].
    trusted : bool
        Whether the estimator vouches for it (``DispersionResult.trusted``).
    std_m : float
        Its one-sigma uncertainty, metres (NaN when the estimator gave up).
    reason : str or None
        Why it is not trusted (None when it is): the altimeter's reason, or the error with
        which it refused the frames.
    """

    altitude_m: float
    quality: float
    trusted: bool
    std_m: float = math.nan
    reason: str | None = None


class DispersionEstimator:
    """Physics-based: fit of the wave dispersion relation (``wavealt.altimetry.dispersion``).

    Parameters
    ----------
    dispersion : {"gravity-capillary", "gravity"} or None
        Dispersion relation; None picks the one of the dataset evaluated (:func:`dispersion_of`).
    aided : bool
        Give the altimeter the camera's true velocity over the water (the manifest's
        ``camera_speed_mps`` / ``camera_dir_deg``; ``(0, 0)`` for a hovering camera), as a
        vehicle's navigation would, so it searches the altitude only ("exact" mode, or
        "prior" with ``velocity_sigma_mps > 0``).  Otherwise ("blind") it searches the
        velocity too.
    velocity_sigma_mps : float
        With ``aided``: how far (m/s, one sigma) the camera's velocity over the water may lie
        from the one given; 0 for exact.
    """

    def __init__(self, *, dispersion: str | None = None, aided: bool = False,
                 velocity_sigma_mps: float = 0.0) -> None:
        self.aided = bool(aided)
        self.velocity_sigma_mps = check_finite_number("velocity_sigma_mps", velocity_sigma_mps,
                                                      low=0.0)
        if self.velocity_sigma_mps > 0 and not self.aided:
            msg = (f"velocity_sigma_mps needs aided=True (a velocity to be uncertain about); "
                   f"got {velocity_sigma_mps!r} without it")
            raise ValueError(msg)
        self.dispersion = dispersion
        self.altimeter = None if dispersion is None else DispersionAltimeter(dispersion=dispersion)

    @property
    def name(self) -> str:
        if not self.aided:
            velocity = "blind"
        elif self.velocity_sigma_mps > 0:
            velocity = f"velocity prior ±{self.velocity_sigma_mps:g} m/s"
        else:
            velocity = "velocity known"
        parts = [p for p in (self.dispersion, velocity) if p]
        return f"dispersion ({', '.join(parts)})"

    def bind(self, dataset: Any) -> None:
        """Fix the dispersion relation to the one of ``dataset``'s renderer, if not given."""
        if self.altimeter is None:
            self.dispersion = dispersion_of(getattr(dataset, "config", None))
            self.altimeter = DispersionAltimeter(dispersion=self.dispersion)

    def estimate_graded(self, dataset: Any, condition: str, record: Any) -> GradedEstimate:
        """Altitude of one sequence (NaN if it gives up), the fit's quality, whether the
        altimeter trusts it, its uncertainty and why it is not trusted."""
        self.bind(dataset)
        frames = dataset.read_frames(condition, record.sequence_id)
        try:
            velocity = record.scenario.camera_velocity_mps if self.aided else None
            res = self.altimeter.estimate(frames, fps=record.scenario.fps,
                                          focal_px=record.scenario.focal_px,
                                          velocity_mps=velocity,
                                          velocity_sigma_mps=self.velocity_sigma_mps)
        except ValueError as exc:
            return GradedEstimate(math.nan, 0.0, False, reason=str(exc))
        # frames the simulated camera coded with H.264 are judged as a video file's are
        out = predicted_verdict(res.to_dict(), simulated_codec(getattr(dataset, "config", None)),
                                self.altimeter.altitude_range_m)
        return GradedEstimate(float(out["altitude_m"]), float(out["quality"]),
                              bool(out["trusted"]), float(out["altitude_std_m"]), out["reason"])

    def estimate(self, dataset: Any, condition: str, record: Any) -> float:
        return self.estimate_graded(dataset, condition, record).altitude_m


def train_split_mean_m(dataset: Any) -> float:
    """Mean true altitude (m) of the dataset's train split."""
    recs = dataset.split("train")
    if not recs:
        msg = f"dataset {dataset.root} has no train split to take a mean from"
        raise ValueError(msg)
    return float(np.mean([r.altitude_m for r in recs]))


def parse_estimator(spec: str, dataset: Any = None, *, device: str = "auto") -> Estimator:
    """Build an estimator from its spec string (see the module docstring); a CNN runs on
    ``device``."""
    kind, _, arg = str(spec).partition(":")
    if kind == "cnn" and arg:
        return CnnEstimator(arg, device=device)
    if kind == "constant" and arg:
        from wavealt.altimetry.predict import CONFIG_NAME  # deferred: torch, as above

        cfg = Path(arg) / CONFIG_NAME
        if not cfg.is_file():
            msg = f"run folder {arg} has no {CONFIG_NAME} (train it with `wavealt train`)"
            raise FileNotFoundError(msg)
        info = json.loads(cfg.read_text(encoding="utf-8"))
        return ConstantEstimator(float(info["stats"]["target_mean_m"]), source=str(arg))
    if kind == "constant" and dataset is not None:
        return ConstantEstimator(train_split_mean_m(dataset), source="dataset train split")
    if kind in ("dispersion", "dispersion-aided") and arg in ("", *DISPERSIONS):
        return DispersionEstimator(dispersion=arg or None, aided=kind == "dispersion-aided")
    if kind == "dispersion-prior":
        return _prior_estimator(spec, arg)
    msg = (f"unknown estimator {spec!r}; expected cnn:RUN, constant:RUN, constant, "
           "dispersion[:gravity|:gravity-capillary], dispersion-aided[:…] or "
           "dispersion-prior[:SIGMA][:…]")
    raise ValueError(msg)


def _prior_estimator(spec: str, arg: str) -> DispersionEstimator:
    """``dispersion-prior[:SIGMA][:gravity|:gravity-capillary]`` (``arg``: after the first
    colon)."""
    sigma, dispersion = PRIOR_SIGMA_MPS, None
    parts = arg.split(":") if arg else []
    if parts and parts[-1] in DISPERSIONS:
        dispersion = parts.pop()
    if len(parts) > 1:
        msg = (f"unknown estimator {spec!r}; expected "
               "dispersion-prior[:SIGMA][:gravity|:gravity-capillary]")
        raise ValueError(msg)
    if parts:
        try:
            sigma = float(parts[0])
        except ValueError:
            sigma = math.nan
        if not (math.isfinite(sigma) and sigma > 0):
            msg = (f"SIGMA of estimator {spec!r} must be a number > 0 (m/s; "
                   f"dispersion-aided for a velocity known exactly); got {parts[0]!r}")
            raise ValueError(msg)
    return DispersionEstimator(dispersion=dispersion, aided=True, velocity_sigma_mps=sigma)


__all__ = ["PRIOR_SIGMA_MPS", "CnnEstimator", "ConstantEstimator", "DispersionEstimator",
           "Estimator", "GradedEstimate", "dispersion_of", "dispersion_of_input",
           "parse_estimator", "train_split_mean_m"]
