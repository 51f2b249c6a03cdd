"""Ocean surface: wave spectra, surface synthesis and time evolution, optics."""
