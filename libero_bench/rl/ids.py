"""The gymnasium ids of the RL environment: importing this module registers them (gymnasium's way).

``gymnasium.make_vec("libero_bench.rl.ids:Libero-v0", num_envs=4, task="libero_object/0",
chunk=5)`` imports it and builds a :class:`~libero_bench.rl.vector.LiberoVectorEnv`; so does
``gymnasium.make_vec("Libero-v0", ...)`` once ``gymnasium.register_envs(libero_bench.rl.ids)``
has run. Nothing else in the packages registers anything on import.
"""

from __future__ import annotations

import gymnasium as gym

#: The environment's id (its keyword arguments are LiberoVectorEnv's).
ENV_ID = "Libero-v0"

if ENV_ID not in gym.registry:
    gym.register(ENV_ID, vector_entry_point="libero_bench.rl.vector:LiberoVectorEnv")
