"""Robustness perturbations: kinds, severity levels, and how each is applied to a scene."""
