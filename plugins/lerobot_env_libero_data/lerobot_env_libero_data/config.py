"""The ``libero_data`` environment type for LeRobot (registered on import)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym
from lerobot.configs import FeatureType, PolicyFeature
from lerobot.envs.configs import EnvConfig
from lerobot.processor import PolicyProcessorPipeline
from lerobot.utils.constants import ACTION, OBS_IMAGES, OBS_STATE

#: The kinds of start an episode can begin from.
STARTS = ("stored", "heldout")


@EnvConfig.register_subclass("libero_data")
@dataclass
class LiberoDataEnvConfig(EnvConfig):
    """A LIBERO or libero-data task (or a suite of them) as a LeRobot environment."""

    task: str = "libero_object/0"
    fps: int = 20
    # Steps before an episode is cut; None: the task's suite limit, as LeRobot's LIBERO env
    # (libero_spatial 280, libero_object 280, libero_goal 300, libero_10 520, libero_90 400,
    # other tasks 500; LIBERO's paper gives every task 600).
    episode_length: int | None = None
    image_size: int = 256  # square camera images, as LeRobot's LIBERO datasets
    starts: str = "stored"  # "stored" (LIBERO's init states) or "heldout" (held-out placements)
    agentview_key: str = "image"  # observation.images.<agentview_key>
    wrist_key: str = "image2"  # observation.images.<wrist_key>; wrist_image for libero-data names
    settle: int = 10  # no-op steps after a reset (LIBERO's and LeRobot's evaluations wait 10)
    render_quality: str = "full"  # "fast": simplified visual meshes (libero-data's render_quality)
    features: dict[str, PolicyFeature] = field(default_factory=dict)
    features_map: dict[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.starts not in STARTS:
            raise ValueError(f"--env.starts must be {' or '.join(STARTS)}, got {self.starts!r}")
        if self.render_quality not in ("full", "fast"):
            raise ValueError(f"--env.render_quality must be full or fast, got {self.render_quality!r}")
        if self.image_size <= 0 or (self.episode_length is not None and self.episode_length <= 0):
            raise ValueError("--env.image_size and --env.episode_length must be positive")
        self.rollout_settings()  # the rollout settings every evaluation shares, checked
        image = PolicyFeature(type=FeatureType.VISUAL, shape=(self.image_size, self.image_size, 3))
        self.features = {
            ACTION: PolicyFeature(type=FeatureType.ACTION, shape=(7,)),
            f"pixels/{self.agentview_key}": image,
            f"pixels/{self.wrist_key}": image,
            "agent_pos": PolicyFeature(type=FeatureType.STATE, shape=(8,)),
        }
        self.features_map = {
            ACTION: ACTION,
            f"pixels/{self.agentview_key}": f"{OBS_IMAGES}.{self.agentview_key}",
            f"pixels/{self.wrist_key}": f"{OBS_IMAGES}.{self.wrist_key}",
            "agent_pos": OBS_STATE,
        }

    def rollout_settings(self) -> Any:
        """``--env.episode_length``, ``--env.settle`` and ``--env.render_quality`` as the rollout
        settings libero-bench's evaluations share (``libero_data.rollout.RolloutSettings``)."""
        from libero_data.rollout import RolloutSettings
        from libero_data.tasks.horizons import SUITE

        limit = SUITE if self.episode_length is None else self.episode_length
        return RolloutSettings(max_steps=limit, settle=self.settle, render_quality=self.render_quality)

    @property
    def gym_kwargs(self) -> dict[str, Any]:
        return {
            "image_size": self.image_size,
            "starts": self.starts,
            "keys": (self.agentview_key, self.wrist_key),
            "rollout": self.rollout_settings(),
        }

    def create_envs(
        self, n_envs: int, use_async_envs: bool = False
    ) -> dict[str, dict[int, gym.vector.VectorEnv]]:
        """{suite: {task index: a vector of ``n_envs`` environments}}; environments are built
        lazily in the process that steps them (a GL context does not survive a fork).

        Sub-environment i runs episodes i, i + n_envs, ...: LeRobot's batch b is rollouts
        b * n_envs ... (b + 1) * n_envs - 1, as libero-bench numbers them. Each sub-environment is
        wrapped in LeRobot's ``FreezeAfterEpisodeEnd``, which absorbs gymnasium's autoreset of a
        finished sub-environment: only LeRobot's explicit reset of a new rollout takes the next start.
        """
        from lerobot.envs.utils import freeze_after_episode_end

        from lerobot_env_libero_data.env import LiberoDataGymEnv, resolve_tasks

        suite, tasks = resolve_tasks(self.task)
        out: dict[int, gym.vector.VectorEnv] = {}
        for task in tasks:

            def make(i: int, task_ref: str = task.ref) -> gym.Env:
                return LiberoDataGymEnv(task_ref, episode_index=i, stride=n_envs, **self.gym_kwargs)

            fns = [freeze_after_episode_end(lambda i=i, make=make: make(i)) for i in range(n_envs)]
            if use_async_envs and n_envs > 1:
                out[task.index] = gym.vector.AsyncVectorEnv(fns, context="forkserver")
            else:
                out[task.index] = gym.vector.SyncVectorEnv(fns)
        return {suite: out}

    def get_env_processors(self) -> tuple[PolicyProcessorPipeline, PolicyProcessorPipeline]:
        # Images are upright and the state is LeRobot's 8-D LIBERO state already.
        return PolicyProcessorPipeline(steps=[]), PolicyProcessorPipeline(steps=[])
