"""Simulation: the physics of a two-layer FSR skin, a family of skins, scenes and datasets."""
