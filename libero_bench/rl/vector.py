"""A gymnasium vector environment of one LIBERO task for reinforcement learning, stepped in chunks.

``LiberoVectorEnv(task, num_envs, chunk=...)`` runs ``num_envs`` copies of any task
:func:`libero_data.tasks.get_task` resolves (LIBERO's 130, LIBERO-PRO's, LIBERO-Plus's with their
files given, a procedural or robustness task's ``.bddl``) in worker processes
(:mod:`libero_bench.rl.host`), while the policy runs once, batched, in the caller's process.

- **Actions**: ``(num_envs, chunk, 7)`` per :meth:`step` (``(num_envs, 7)`` where ``chunk`` is 1):
  LIBERO's OSC deltas and gripper, clipped to [-1, 1]. A chunk runs until its end, the goal or the
  step limit; the cameras draw once per chunk, for the observation returned.
- **Observations**: LeRobot's gym convention, as its LIBERO environment: ``pixels`` (one upright
  ``uint8`` image per camera, ``image`` the agent view and ``image2`` the wrist) and ``agent_pos``
  (the 8-D state: end-effector position, axis-angle, the two gripper fingers; float32), what our
  datasets store as ``observation.images.*`` and ``observation.state``.
- **Rewards and ends**: LIBERO's sparse reward, 1 on the step the goal holds; ``terminated`` is
  LIBERO's ``done`` (success); ``truncated`` is the step limit (by default the task's standard
  limit, openpi's, counted after the ``settle`` waiting steps).
- **Automatic reset** in the same step (gymnasium's ``AutoresetMode.SAME_STEP``): an ended
  environment's reply is the next episode's first observation, with the ended one's last in
  ``info["final_obs"]`` and its info in ``info["final_info"]`` (masks ``_final_obs``/``_final_info``).
  ``info`` also holds ``steps`` (actions run this call), ``elapsed`` (the episode's steps so far),
  ``is_success``, ``start`` (the episode's start number) and ``task`` (the instruction).
- **Starts and groups**: environment ``i``'s ``r``-th episode begins from start
  ``r * num_envs / group_size + i // group_size`` of a stream drawn from the seed given to
  :meth:`reset` (:func:`libero_data.seeding.training_start`): with ``group_size`` g, each g
  consecutive environments begin every episode from the same start (GRPO's groups), however their
  episodes end. ``starts="sampled"`` (the default) places objects with LIBERO's sampler, apart from
  the held-out stream evaluations use and from the stored init states the standard protocol
  evaluates; ``starts="stored"`` draws LIBERO's stored init states, as RLinf's environment does.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
from gymnasium import spaces
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from libero_bench.rl.host import EpisodeStart, HostSettings, SlotReply, lean_worker, make_chunk_host
from libero_data.errors import InputError

#: LeRobot's LIBERO pixel keys for our cameras (``observation.images.image``, ``...image2``).
PIXEL_KEYS = {"agentview": "image", "eye_in_hand": "image2"}
STARTS = ("sampled", "stored")


class LiberoVectorEnv(VectorEnv):
    """``num_envs`` environments of one task, stepped a chunk at a time (module docstring)."""

    metadata = {"autoreset_mode": AutoresetMode.SAME_STEP, "render_modes": []}  # noqa: RUF012

    def __init__(
        self,
        task: str,
        num_envs: int = 1,
        *,
        chunk: int = 1,
        group_size: int = 1,
        image_size: int = 256,
        cameras: Sequence[str] = ("agentview", "eye_in_hand"),
        render_quality: str = "full",
        starts: str = "sampled",
        max_episode_steps: int | None = None,
        settle: int = 10,
        workers: int | None = None,
    ) -> None:
        from libero_data.runtime.actors import ActorPool
        from libero_data.runtime.jobs import JobPlacement
        from libero_data.tasks import get_task
        from libero_data.tasks.horizons import standard_limit

        _check_counts(num_envs, chunk, group_size, starts)
        resolved = get_task(task)  # an unknown task: one sentence here, not in a worker
        self.task_key = f"{resolved.suite}/{resolved.name}"
        self.task_description = resolved.language
        if starts == "stored" and resolved.init_states_path is None:
            raise InputError(f"task {task} has no stored init states; use starts='sampled'")
        self._stored = len(resolved.init_states()) if starts == "stored" else 0
        if max_episode_steps is None:
            max_episode_steps = standard_limit(resolved.suite, resolved.name)
        self.settings = HostSettings(
            task=task,
            image_size=image_size,
            cameras=tuple(cameras),
            render_quality=render_quality,
            max_steps=max_episode_steps,
            settle=settle,
        )
        self.num_envs, self.chunk, self.group_size = num_envs, chunk, group_size
        self._build_spaces()
        workers = min(num_envs, workers or os.cpu_count() or 1)
        self._slots = [list(block) for block in np.array_split(np.arange(num_envs), workers)]
        self._pool = ActorPool(
            JobPlacement("local", workers),
            Path.cwd(),
            partial(make_chunk_host, self.settings),
            setup=lean_worker,  # worker processes only: this process's MuJoCo is left as it is
        )
        self._seed = 0
        self._episodes = np.zeros(num_envs, dtype=np.int64)  # episodes begun per environment
        self._running: list[EpisodeStart] = [
            EpisodeStart(-1, -1, 0)
        ] * num_envs  # each environment's episode's start

    # -- spaces ------------------------------------------------------------------------------------
    def _build_spaces(self) -> None:
        size = self.settings.image_size
        image = spaces.Box(0, 255, (size, size, 3), np.uint8)
        self.single_observation_space = spaces.Dict(
            {
                "pixels": spaces.Dict({PIXEL_KEYS[c]: image for c in self.settings.cameras}),
                "agent_pos": spaces.Box(-np.inf, np.inf, (8,), np.float32),
            }
        )
        shape = (7,) if self.chunk == 1 else (self.chunk, 7)
        self.single_action_space = spaces.Box(-1.0, 1.0, shape, np.float32)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)

    # -- starts ------------------------------------------------------------------------------------
    def _next_start(self, env: int) -> EpisodeStart:
        """Environment ``env``'s next episode's start (module docstring, "Starts and groups")."""
        from libero_data.seeding import training_start

        groups = self.num_envs // self.group_size
        number = int(self._episodes[env]) * groups + env // self.group_size
        init_index, reset_seed = training_start(self._seed, self.task_key, number, self._stored)
        return EpisodeStart(number, init_index, reset_seed)

    def _take_starts(self, envs: Sequence[int]) -> dict[int, EpisodeStart]:
        starts = {env: self._next_start(env) for env in envs}
        for env, start in starts.items():
            self._episodes[env] += 1
            self._running[env] = start
        return starts

    def _start_info(self) -> dict[str, Any]:
        """What the info says of each environment's running episode: its start number, the
        stored init state it began from (-1: placed by LIBERO's sampler), its reset seed."""
        return {
            "start": np.array([s.number for s in self._running], dtype=np.int64),
            "init_index": np.array([s.init_index for s in self._running], dtype=np.int64),
            "reset_seed": np.array([s.reset_seed for s in self._running], dtype=np.int64),
            "task": np.full(self.num_envs, self.task_description, dtype=object),
        }

    # -- the gymnasium API -------------------------------------------------------------------------
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, Any], dict[str, Any]]:
        """Begin an episode in every environment; ``seed`` picks the stream of starts (and starts
        it again from its first); without it the stream goes on."""
        if seed is not None:
            self._seed = int(seed)
            self._episodes[:] = 0
        starts = self._take_starts(range(self.num_envs))
        replies = self._pool.call(
            {a: ("reset", ({e: starts[e] for e in slots},)) for a, slots in enumerate(self._slots)}
        )
        views = {e: view for reply in replies.values() for e, view in reply.items()}
        obs = self._batch([views[e] for e in range(self.num_envs)])
        return obs, self._start_info()

    def step(self, actions: Any) -> tuple[dict[str, Any], np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Run one chunk in every environment (module docstring)."""
        chunks = self._chunks(actions)
        running = list(self._running)
        next_starts = {e: self._next_start(e) for e in range(self.num_envs)}
        calls = {
            a: ("step", ({e: chunks[e] for e in slots}, {e: next_starts[e] for e in slots}))
            for a, slots in enumerate(self._slots)
        }
        replies: dict[int, SlotReply] = {
            e: r for answer in self._pool.call(calls).values() for e, r in answer.items()
        }
        ordered = [replies[e] for e in range(self.num_envs)]
        ended = [e for e, r in enumerate(ordered) if r.terminated or r.truncated]
        for e in ended:  # the host began the next episode from the start it was sent
            self._episodes[e] += 1
            self._running[e] = next_starts[e]
        infos = self._infos(ordered, running, ended)
        return (
            self._batch([r.obs for r in ordered]),
            np.array([r.reward for r in ordered], dtype=np.float32),
            np.array([r.terminated for r in ordered]),
            np.array([r.truncated for r in ordered]),
            infos,
        )

    def _chunks(self, actions: Any) -> np.ndarray:
        array = np.asarray(actions, dtype=np.float64)
        if array.ndim == 2 and self.chunk == 1:
            array = array[:, None]
        if array.ndim != 3 or array.shape[0] != self.num_envs or array.shape[2] != 7 or array.shape[1] < 1:
            raise InputError(
                f"actions must have shape ({self.num_envs}, chunk, 7) (or ({self.num_envs}, 7) with "
                f"chunk 1), got {array.shape}"
            )
        if not np.all(np.isfinite(array)):
            raise InputError("actions must be finite numbers; some are NaN or infinite")
        return array

    def _infos(
        self, replies: Sequence[SlotReply], running: Sequence[EpisodeStart], ended: Sequence[int]
    ) -> dict[str, Any]:
        infos: dict[str, Any] = {
            "steps": np.array([r.steps for r in replies], dtype=np.int64),
            "elapsed": np.array(
                [0 if e in ended else r.elapsed for e, r in enumerate(replies)], dtype=np.int64
            ),
            "is_success": np.array([r.terminated for r in replies]),
            **self._start_info(),
        }
        for e in ended:
            r, start = replies[e], running[e]
            final = {
                "is_success": r.terminated,
                "elapsed": r.elapsed,
                "start": start.number,
                "init_index": start.init_index,
                "reset_seed": start.reset_seed,
            }
            infos = self._add_info(infos, {"final_obs": self._single(r.final_obs), "final_info": final}, e)
        return infos

    # -- observations ------------------------------------------------------------------------------
    def _single(self, view: dict[str, np.ndarray] | None) -> dict[str, Any]:
        assert view is not None, "an ended episode's reply holds its last observation"
        pixels = {PIXEL_KEYS[c]: view[c] for c in self.settings.cameras}
        return {"pixels": pixels, "agent_pos": view["state"]}

    def _batch(self, views: Sequence[dict[str, np.ndarray]]) -> dict[str, Any]:
        pixels = {PIXEL_KEYS[c]: np.stack([v[c] for v in views]) for c in self.settings.cameras}
        return {"pixels": pixels, "agent_pos": np.stack([v["state"] for v in views])}

    def worker_pids(self) -> list[int]:
        """The worker processes' ids (this process's where the environments run here)."""
        return self._pool.worker_pids() or [os.getpid()]

    def close_extras(self, **kwargs: Any) -> None:
        self._pool.close()


def _check_counts(num_envs: int, chunk: int, group_size: int, starts: str) -> None:
    for name, value in (("num_envs", num_envs), ("chunk", chunk), ("group_size", group_size)):
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            raise InputError(f"{name} must be a whole number of at least 1, got {value!r}")
    if num_envs % group_size:
        raise InputError(f"num_envs ({num_envs}) must be a multiple of group_size ({group_size})")
    if starts not in STARTS:
        raise InputError(f"starts must be {' or '.join(STARTS)}, got {starts!r}")
