"""Policy package: see config.py and model.py."""
