"""Robustness sweeps: variants by kind and level, the sweep, a run's rollouts on them, paired comparisons."""
