"""wavealt: camera altimetry over the sea, through sun glint.

Stages, one package each (docs/architecture.md): ``sim`` (scenario, sea, light, renderer)
-> ``dataset`` -> ``deglint`` -> ``altimetry`` -> ``evaluation`` -> ``report``, with ``io``
under all of them and ``cli`` on top.  Frames are ``float32`` arrays ``(T, H, W, 3)`` in
``[0, 1]``; all units are SI.
"""

__version__ = "0.1.0"
