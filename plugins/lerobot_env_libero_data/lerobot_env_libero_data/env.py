"""One LIBERO or libero-data task as a gymnasium environment, for LeRobot's evaluation loop."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

if TYPE_CHECKING:
    from libero_data.rollout import RolloutSettings


@dataclass(frozen=True)
class TaskRef:
    index: int  # the task's index in its suite (LeRobot's task id)
    ref: str  # what libero_data.tasks.get_task resolves


def resolve_tasks(spec: str) -> tuple[str, list[TaskRef]]:
    """``--env.task`` as (suite name, tasks): a task, a suite, ``suite/i,j`` or a suite folder."""
    from libero_data.tasks import get_suite, get_task

    spec = spec.strip()
    if spec.endswith(".bddl"):
        get_task(spec)  # a missing or malformed file: one sentence now, not in a worker
        return "file", [TaskRef(0, spec)]
    head, _, tail = spec.rpartition("/")
    if head and tail and all(part.strip().lstrip("-").isdigit() for part in tail.split(",")):
        suite = get_suite(head)
        picked = [suite.task(part.strip()) for part in tail.split(",")]
        return suite.name, [TaskRef(t.index, f"{head}/{t.index}") for t in picked]
    try:
        suite = get_suite(spec)
    except KeyError:
        task = get_task(spec)  # suite/name or a bare task name
        return task.suite, [TaskRef(task.index, spec)]
    prefix = str(Path(spec).resolve()) if suite.path is not None else suite.name
    return suite.name, [TaskRef(t.index, f"{prefix}/{t.index}") for t in suite.tasks]


class LiberoDataGymEnv(gym.Env):
    """A task for LeRobot's ``rollout``: pixels (two cameras, upright) and the 8-D state.

    Sub-environment ``episode_index`` of ``stride`` runs episodes r = index, index + stride, ...;
    episode r starts from stored init state r mod n (fixture seed r), or from held-out placement
    r: the starts libero-bench rolls out from, whatever seeds LeRobot passes.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 20}  # noqa: RUF012  (gymnasium reads it)

    def __init__(
        self,
        task_ref: str,
        *,
        episode_index: int = 0,
        stride: int = 1,
        image_size: int = 256,
        starts: str = "stored",
        keys: tuple[str, str] = ("image", "image2"),
        rollout: RolloutSettings | None = None,
    ) -> None:
        from libero_data.rollout import RolloutSettings
        from libero_data.tasks import get_task

        rollout = rollout or RolloutSettings()  # the task's suite limit, settle 10, full images
        super().__init__()
        self._task = get_task(task_ref)
        self.task = self._task.name
        self.task_description = self._task.language
        self.render_mode = "rgb_array"
        # by default the task's suite limit (LeRobot's LIBERO limits; libero_data.tasks.horizons)
        self._max_episode_steps = rollout.steps_for(self._task.suite)
        self._image_size, self._starts, self._keys, self._settle = image_size, starts, keys, rollout.settle
        self._render_quality = rollout.render_quality
        self._next = episode_index
        self._stride = stride
        self._env: Any = None
        self._last: dict[str, Any] | None = None
        self.start: tuple[int, int, int] | None = None  # (rollout, init index, fixture/placement seed)
        image = spaces.Box(low=0, high=255, shape=(image_size, image_size, 3), dtype=np.uint8)
        self.observation_space = spaces.Dict(
            {
                "pixels": spaces.Dict({keys[0]: image, keys[1]: image}),
                "agent_pos": spaces.Box(low=-np.inf, high=np.inf, shape=(8,), dtype=np.float64),
            }
        )
        self.action_space = spaces.Box(low=-1.0, high=1.0, shape=(7,), dtype=np.float32)

    def _start(self, r: int) -> tuple[np.ndarray | None, int, int]:
        """(init state, init index, seed) of rollout ``r``."""
        from libero_data.seeding import heldout_starts, rollout_start

        if self._starts == "heldout":
            return None, -1, heldout_starts(self._task.name, r + 1)[r]
        stored = self._task.init_states() if self._task.init_states_path is not None else None
        index, seed = rollout_start(r, 0 if stored is None else len(stored))
        return (stored[index] if stored is not None and index >= 0 else None), index, seed

    def _observation(self, obs: dict[str, Any]) -> dict[str, Any]:
        self._last = obs
        return {
            "pixels": {self._keys[0]: obs["agentview"], self._keys[1]: obs["eye_in_hand"]},
            "agent_pos": np.asarray(obs["state"], dtype=np.float64),
        }

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, Any], dict[str, Any]]:
        from libero_data.sim import EnvConfig, LiberoEnv

        super().reset(seed=seed)
        if self._env is None:  # built here, in the process that steps it
            config = EnvConfig(image_size=self._image_size, render_quality=self._render_quality)
            self._env = LiberoEnv(self._task, config)
        state, index, env_seed = self._start(self._next)
        self.start = (self._next, index, env_seed)
        self._next += self._stride
        obs = self._env.reset(state, seed=env_seed, settle=self._settle)
        return self._observation(obs), {"is_success": False, "env_seed": env_seed}

    def step(self, action: np.ndarray) -> tuple[dict[str, Any], float, bool, bool, dict[str, Any]]:
        action = np.clip(np.asarray(action, dtype=np.float64).reshape(-1), -1.0, 1.0)
        obs, success = self._env.step(action)
        info = {"task": self.task, "is_success": bool(success)}
        return self._observation(obs), float(success), bool(success), False, info

    def render(self) -> np.ndarray:
        if self._last is None:
            return np.zeros((self._image_size, self._image_size, 3), dtype=np.uint8)
        return np.asarray(self._last["agentview"])

    def close(self) -> None:
        if self._env is not None:
            self._env.close()
            self._env = None
