"""libero_bench: lifelong learners trained on libero-data datasets, evaluated in simulation."""

__version__ = "0.1.0"
