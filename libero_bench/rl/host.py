"""The worker side of the RL environment: the simulations of some slots, stepped a chunk at a time.

A :class:`ChunkHost` lives in a worker process (one per process, built by :func:`make_chunk_host`; in
a thread of this process for one worker) and holds one :class:`~libero_data.sim.LiberoEnv` per slot, built
at the slot's first reset and kept for every episode after (a scene takes seconds to build; a
reset reuses it, so memory stays flat over thousands of episodes).

**One GL context per worker.** robosuite gives every environment a GL context of its own, which
holds the scene's meshes and textures (~440 MB for a LIBERO scene under llvmpipe, against ~250 MB
for the rest of the environment). The slots of a worker all simulate the same task, so at full
quality their environments are built without cameras and one
:class:`~libero_data.sim.fast.renderer.OffscreenRenderer` draws every slot's scene, robosuite's
pixels exactly (tested). A task that changes its images after drawing them (a robustness
perturbation's ``observe`` hook) keeps each environment's own cameras; with ``fast`` rendering
each environment has its cameras, and the worker's environments of one scene share their fast
renderers (:class:`~libero_data.sim.fast.images.FastImages`).

Per call, each slot gets a chunk of actions. The first ``k - 1`` run physics only
(:meth:`~libero_data.sim.LiberoEnv.advance`: no observation is built, no frame drawn); the cameras
draw once, after the chunk's last action, or after the action that reached the goal or the step
limit. An episode that ends is reset at once to the start the driver sent with the chunk, and the
reply carries both the last observation of the ended episode and the first of the new one.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from libero_data.config import Config

if TYPE_CHECKING:
    from libero_data.runtime.jobs import WorkerContext

#: LIBERO's reward: 1 on the step the goal holds (the episode then ends), 0 before.
SUCCESS_REWARD = 1.0


@dataclass(frozen=True)
class HostSettings(Config):
    """What every slot's environment is: the task, its images, its clock."""

    task: str  # what libero_data.tasks.get_task resolves (a suite task, a .bddl file, plus/..., PRO)
    image_size: int = 256
    cameras: tuple[str, ...] = ("agentview", "eye_in_hand")
    render_quality: str = "full"
    max_steps: int = 280  # steps of an episode after the waiting ones
    settle: int = 10  # no-op steps after each reset (LIBERO's evaluation waits 10)

    def __post_init__(self) -> None:
        from libero_data.sim.env import CAMERAS, RENDER_QUALITIES

        self._check_positive("image_size", "max_steps")
        self._check_non_negative("settle")
        self._check_choice("render_quality", RENDER_QUALITIES)
        unknown = [c for c in self.cameras if c not in CAMERAS]
        if not self.cameras or unknown:
            self._fail("cameras", f"must name one or more of {', '.join(CAMERAS)}")


@dataclass(frozen=True)
class EpisodeStart:
    """Where one episode begins: its number in the environment's stream of starts, the stored
    init state it starts from (-1: LIBERO's sampler places the objects) and the reset seed."""

    number: int
    init_index: int
    reset_seed: int


@dataclass
class SlotReply:
    """One slot's answer to a chunk: the observation the policy sees next, what the chunk earned
    and, when the episode ended in it, its last observation (the new episode's first is ``obs``)."""

    obs: dict[str, np.ndarray]
    reward: float = 0.0
    terminated: bool = False
    truncated: bool = False
    steps: int = 0  # actions of the chunk that ran (fewer than sent when the episode ended)
    elapsed: int = 0  # steps of the episode so far (of the ended one, when it ended)
    final_obs: dict[str, np.ndarray] | None = None


class ChunkHost:
    """The environments of a worker's slots (see the module docstring)."""

    def __init__(self, settings: HostSettings) -> None:
        self.settings = settings
        self.envs: dict[int, Any] = {}
        self.elapsed: dict[int, int] = {}
        self._stored: np.ndarray | None = None
        self.renderer: Any = None  # the worker's one GL context, where the slots share it
        self.own_cameras: bool | None = None  # whether each environment draws its own images

    def _build(self, cameras: tuple[str, ...]) -> Any:
        from libero_data.sim import EnvConfig, LiberoEnv

        s = self.settings
        config = EnvConfig(image_size=s.image_size, cameras=cameras, render_quality=s.render_quality)
        return LiberoEnv(s.task, config)

    def _env(self, slot: int) -> Any:
        env = self.envs.get(slot)
        if env is not None:
            return env
        if self.own_cameras is None:  # the first: whether the slots can share one GL context
            from libero_data.sim.gl import select_backend

            backend = select_backend()  # before robosuite and MuJoCo load: they read it once
            env = self._build(())
            self.own_cameras = env.perturbation is not None or self.settings.render_quality != "full"
            if self.own_cameras:
                env.close()
                env = self._build(self.settings.cameras)
            else:
                from libero_data.sim.fast.renderer import OffscreenRenderer

                self.renderer = OffscreenRenderer(env.sim.model._model, self.settings.image_size, backend)
        else:
            env = self._build(self.settings.cameras if self.own_cameras else ())
        self.envs[slot] = env
        return env

    def _observe(self, env: Any) -> dict[str, np.ndarray]:
        """The slot's observation, its images drawn by its own cameras or the shared context."""
        if self.own_cameras:
            return self._view(env.observe())
        obs = env.observe(render=False)
        model, data = env.sim.model._model, env.sim.data._data
        for camera in self.settings.cameras:
            obs[camera] = self.renderer.render(model, data, env.camera_id(camera))
        return self._view(obs)

    def _init_state(self, index: int) -> np.ndarray | None:
        if index < 0:
            return None
        if self._stored is None:
            from libero_data.tasks import get_task

            self._stored = get_task(self.settings.task).init_states()
        return self._stored[index]

    def _view(self, obs: Mapping[str, Any]) -> dict[str, np.ndarray]:
        """What the driver gets of an observation: the images and the 8-D state."""
        view = {camera: obs[camera] for camera in self.settings.cameras}
        view["state"] = np.asarray(obs["state"], dtype=np.float32)
        return view

    def reset(self, starts: Mapping[int, EpisodeStart]) -> dict[int, dict[str, np.ndarray]]:
        """Begin an episode in each slot of ``starts``; their first observations."""
        return {slot: self._begin(slot, start) for slot, start in starts.items()}

    def _begin(self, slot: int, start: EpisodeStart) -> dict[str, np.ndarray]:
        env = self._env(slot)
        state = self._init_state(start.init_index)
        self.elapsed[slot] = 0
        if self.own_cameras:
            return self._view(env.reset(state, seed=start.reset_seed, settle=self.settings.settle))
        env.reset(state, seed=start.reset_seed, settle=self.settings.settle, render=False)
        return self._observe(env)

    def step(
        self, chunks: Mapping[int, np.ndarray], next_starts: Mapping[int, EpisodeStart]
    ) -> dict[int, SlotReply]:
        """Run each slot's chunk; an episode that ends begins again from its slot's next start."""
        replies = {}
        for slot, chunk in chunks.items():
            reply = self._run_chunk(slot, np.asarray(chunk, dtype=np.float64))
            if reply.terminated or reply.truncated:
                reply.final_obs, reply.obs = reply.obs, self._begin(slot, next_starts[slot])
            replies[slot] = reply
        return replies

    def _run_chunk(self, slot: int, chunk: np.ndarray) -> SlotReply:
        env = self.envs[slot]
        limit = self.settings.max_steps
        reached = False
        steps = 0
        for action in np.clip(chunk, -1.0, 1.0):
            reached = env.advance(action)
            steps += 1
            self.elapsed[slot] += 1
            if reached or self.elapsed[slot] >= limit:
                break
        return SlotReply(
            obs=self._observe(env),
            reward=SUCCESS_REWARD if reached else 0.0,
            terminated=reached,
            truncated=not reached and self.elapsed[slot] >= limit,
            steps=steps,
            elapsed=self.elapsed[slot],
        )

    def close(self) -> None:
        for env in self.envs.values():
            env.close()
        self.envs.clear()
        if self.renderer is not None:
            self.renderer.close()
            self.renderer = None


def lean_worker() -> None:
    """A worker process's set-up: MuJoCo's asset cache off. It keeps the decoded textures and
    meshes of every model compiled (~300 MB for a LIBERO scene) to compile the same files again
    faster, which a worker does once per slot; a reset does not compile. A trial here: resets
    34 ms without it against 46 ms with it, 300 MB less per worker; benchmarks/RESULTS.md, RL
    environment, has the memory per environment it gives."""
    from libero_data.sim.gl import select_backend

    select_backend()  # before MuJoCo loads: it reads the backend once
    import mujoco

    mujoco.mj_setCacheCapacity(mujoco.mj_getCache(), 0)


def make_chunk_host(settings: HostSettings, ctx: WorkerContext) -> ChunkHost:
    """The actor factory (bound to the settings with :func:`functools.partial`)."""
    return ChunkHost(settings)
