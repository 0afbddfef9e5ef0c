"""Procedural LIBERO-style tasks: catalogue, behaviour templates, sampler and feasibility."""
