"""Headless LIBERO simulation (robosuite + MuJoCo): the only place that imports them."""

from libero_data.errors import RenderBackendError
from libero_data.sim.env import ACTION_DIM, CAMERAS, STATE_DIM, EnvConfig, LiberoEnv
from libero_data.sim.gl import available_backends, select_backend

__all__ = [
    "ACTION_DIM",
    "CAMERAS",
    "STATE_DIM",
    "EnvConfig",
    "LiberoEnv",
    "RenderBackendError",
    "available_backends",
    "select_backend",
]
