"""Which dispersion relation the waves of a source obey: a simulated dataset's renderer
decides, anything else is real water.

It reads a dataset folder's ``dataset.json`` directly rather than through
:class:`wavealt.dataset.Dataset`: ``wavealt altitude`` asks it on every start, and the
dataset module (with the simulator behind it) would add 0.4 s to that start (measured).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any


def dispersion_of(config: Any) -> str:
    """The dispersion relation a dataset's waves obey: ``"gravity"`` or ``"gravity-capillary"``.

    The ``paper`` renderer moves its waves with the deep-water relation ``omega = sqrt(g k)``
    only (paper §3.1); the ``realistic`` renderer with ``omega^2 = g k + (sigma/rho) k^3``.

    Parameters
    ----------
    config : SimConfig or None
        The dataset's generator config; None (unknown data) gives the real-water relation.
    """
    if config is None:
        return "gravity-capillary"
    return dispersion_of_renderer(getattr(config, "renderer", "paper"))


def dispersion_of_renderer(renderer: str) -> str:
    """``"gravity"`` for the ``paper`` renderer, ``"gravity-capillary"`` for any other."""
    return "gravity" if renderer == "paper" else "gravity-capillary"


def dispersion_of_input(path: Path | str) -> str:
    """The dispersion relation for the frames at ``path`` (``wavealt altitude --dispersion
    auto``).

    A sequence folder of a wavealt dataset (``DATASET/<condition>/<sequence_id>/`` with
    ``DATASET/dataset.json``) takes the relation of the dataset's renderer
    (:func:`dispersion_of` of its config); anything else is taken for real water
    (``"gravity-capillary"``).

    Parameters
    ----------
    path : path
        A frame folder or a video file.
    """
    folder = Path(path)
    if folder.is_dir():
        info_path = folder.resolve().parent.parent / "dataset.json"
        if info_path.is_file():
            try:
                info = json.loads(info_path.read_text(encoding="utf-8"))
            except json.JSONDecodeError as exc:
                msg = f"corrupt dataset.json in {info_path.parent}: {exc}"
                raise ValueError(msg) from None
            # both dataset formats name the renderer; format 1 left out the default, paper
            return dispersion_of_renderer(info.get("config", {}).get("renderer", "paper"))
    return dispersion_of(None)


__all__ = ["dispersion_of", "dispersion_of_input", "dispersion_of_renderer"]
