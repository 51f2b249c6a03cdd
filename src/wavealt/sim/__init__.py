"""The simulator: scenario configs, sea synthesis, renderers and the camera sensor.

``config`` (what to simulate) -> ``sea`` (heights and slopes over time) -> ``light`` (how the
sea looks: Fresnel sky, water, glint) -> a renderer (``paper`` or ``realistic``, by name in
:data:`wavealt.sim.generate.RENDERERS`) -> frames. Writing a dataset folder is
:func:`wavealt.dataset.simulate_dataset`'s job.
"""

from wavealt.sim.base import Renderer, Sea, SequenceData
from wavealt.sim.config import (
    PRESETS,
    PaperConfig,
    RealisticConfig,
    Scenario,
    SensorModel,
    SimConfig,
    derive_seed,
    preset_config,
)
from wavealt.sim.generate import RENDERERS, generate_sequence

__all__ = ["PRESETS", "RENDERERS", "PaperConfig", "RealisticConfig", "Renderer", "Scenario",
           "Sea", "SensorModel", "SequenceData", "SimConfig", "derive_seed", "generate_sequence",
           "preset_config"]
