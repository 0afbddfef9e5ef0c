"""Training: a run's plan, the trainer, fitting, evaluation rounds, checkpoints, presets."""
