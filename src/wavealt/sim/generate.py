"""The renderers by name, and one sequence from one scenario: sea -> light -> frames."""

from __future__ import annotations

import numpy as np

from wavealt.sim.base import Renderer, SequenceData
from wavealt.sim.config import RENDERERS as RENDERER_NAMES
from wavealt.sim.config import Scenario, SimConfig
from wavealt.sim.paper import PaperRenderer
from wavealt.sim.realistic import RealisticRenderer

#: The renderers, by the name ``SimConfig.renderer`` selects them with.
RENDERERS: dict[str, Renderer] = {r.name: r for r in (PaperRenderer(), RealisticRenderer())}
if set(RENDERERS) != set(RENDERER_NAMES):  # the config's list and this registry are one set
    msg = f"renderer registry {sorted(RENDERERS)} differs from the config's {sorted(RENDERER_NAMES)}"
    raise ImportError(msg)


def generate_sequence(scenario: Scenario, config: SimConfig, *,
                      with_height: bool = False) -> SequenceData:
    """Synthesise and render the paired clean/glinty frames of ``scenario`` with the
    renderer ``config.renderer``.

    Raises ``ValueError`` if a rendered frame is not finite (a scenario outside the range
    the spectrum models hold for), rather than writing blank or NaN frames.
    """
    data = RENDERERS[config.renderer].render(scenario, config, with_height=with_height)
    for name in ("clean", "glinty"):
        frames = getattr(data, name)
        if not np.isfinite(frames).all():
            bad = int(np.count_nonzero((~np.isfinite(frames)).reshape(frames.shape[0], -1)
                                       .any(axis=1)))
            msg = (f"the {config.renderer} renderer made {bad} non-finite {name} frame(s) for "
                   f"altitude {scenario.altitude_m:.3g} m, wind {scenario.wind_speed_mps:.3g} m/s "
                   f"(seed {scenario.seed})")
            raise ValueError(msg)
    return data


__all__ = ["RENDERERS", "generate_sequence"]
