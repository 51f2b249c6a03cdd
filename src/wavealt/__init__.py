"""wavealt: camera altimetry over the sea, through sun glint.

Stages (see DESIGN.md): scenario -> ocean surface -> renderer -> frame sequences ->
deglint -> altimeter -> evaluation.  Frames are ``float32`` arrays ``(T, H, W, 3)`` in
``[0, 1]``; all units are SI.
"""

__version__ = "0.1.0"
