"""Altimeters: the CNN regressor and the physics-based dispersion fit."""
