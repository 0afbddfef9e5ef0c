"""The RL environment: gymnasium's vector API over worker processes, chunks, automatic resets,
GRPO groups, seeded starts, and memory that stays flat over many episodes."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest

from libero_bench.rl.host import ChunkHost, EpisodeStart, HostSettings
from libero_data.errors import InputError, LiberoDataError
from libero_data.seeding import heldout_seed, training_start

TASK = "libero_object/0"


class FakeEnv:
    """A stand-in simulation whose goal holds after ``success_at`` actions; counts its draws."""

    def __init__(self, success_at: int) -> None:
        self.success_at, self.t, self.draws = success_at, 0, 0
        self.resets: list[int] = []

    def reset(self, state: Any, *, seed: int, settle: int) -> dict[str, Any]:
        self.t = 0
        self.resets.append(seed)
        return self.observe()

    def advance(self, action: np.ndarray) -> bool:
        assert action.shape == (7,) and np.all(np.abs(action) <= 1.0)
        self.t += 1
        return self.t >= self.success_at

    def observe(self) -> dict[str, Any]:
        self.draws += 1
        return {"agentview": np.full((4, 4, 3), self.t, np.uint8), "state": np.full(8, self.t, np.float32)}

    def close(self) -> None:
        pass


def _host(success_at: int, max_steps: int) -> tuple[ChunkHost, FakeEnv]:
    host = ChunkHost(HostSettings(task=TASK, cameras=("agentview",), max_steps=max_steps))
    fake = host.envs[0] = FakeEnv(success_at)
    host.own_cameras = True  # the stand-in draws its own images
    host.reset({0: EpisodeStart(0, -1, 11)})
    return host, fake


def test_a_chunk_draws_once_and_stops_at_the_goal() -> None:
    host, fake = _host(success_at=7, max_steps=100)
    reply = host.step({0: np.zeros((5, 7))}, {0: EpisodeStart(1, -1, 12)})[0]
    assert (reply.steps, reply.elapsed, reply.reward, reply.terminated) == (5, 5, 0.0, False)
    assert fake.draws == 2  # the reset's observation and the chunk's last
    reply = host.step({0: np.full((5, 7), 3.0)}, {0: EpisodeStart(1, -1, 12)})[0]  # clipped to [-1, 1]
    assert (reply.steps, reply.elapsed, reply.reward, reply.terminated, reply.truncated) == (
        2,
        7,
        1.0,
        True,
        False,
    )
    assert reply.final_obs is not None and reply.final_obs["state"][0] == 7  # the goal's observation
    assert reply.obs["state"][0] == 0 and fake.resets == [11, 12]  # begun again from the start sent


def test_the_step_limit_truncates_and_resets() -> None:
    host, _fake = _host(success_at=1000, max_steps=12)
    steps = [host.step({0: np.zeros((5, 7))}, {0: EpisodeStart(1, -1, 12)})[0] for _ in range(3)]
    assert [(r.steps, r.elapsed, r.truncated) for r in steps] == [
        (5, 5, False),
        (5, 10, False),
        (2, 12, True),
    ]
    assert not steps[-1].terminated and steps[-1].reward == 0.0


def test_training_starts_stay_apart_from_the_held_out_stream() -> None:
    starts = [training_start(0, "libero_object/x", n, 50) for n in range(200)]
    assert all(0 <= index < 50 for index, _ in starts) and len({s for _, s in starts}) == 200
    assert training_start(0, "libero_object/x", 3, 50) == starts[3]  # a function of its inputs
    assert training_start(1, "libero_object/x", 3, 50) != starts[3]
    assert {s for _, s in starts}.isdisjoint(heldout_seed("libero_object/x", i) for i in range(200))
    assert training_start(0, "libero_object/x", 3, 0)[0] == -1


@pytest.mark.parametrize(
    ("kwargs", "says"),
    [
        ({"num_envs": 3, "group_size": 2}, "multiple of group_size"),
        ({"chunk": 0}, "chunk must be a whole number"),
        ({"starts": "held"}, "starts must be sampled or stored"),
        ({"task": "libero_object/99"}, "99"),
    ],
)
def test_bad_settings_get_one_sentence(kwargs: dict[str, Any], says: str) -> None:
    from libero_bench.rl.vector import LiberoVectorEnv

    with pytest.raises(LiberoDataError, match=says):
        LiberoVectorEnv(**{"task": TASK, **kwargs})


def test_stored_starts_need_stored_init_states() -> None:
    from libero_bench.rl.vector import LiberoVectorEnv
    from libero_data.tasks import get_task

    bddl = str(get_task(TASK).bddl_path)  # a task named by its file has no stored init states
    with pytest.raises(InputError, match="no stored init states; use starts='sampled'"):
        LiberoVectorEnv(bddl, starts="stored")


@pytest.fixture(scope="module")
def grouped() -> Iterator[Any]:
    """Two environments in two worker processes, one GRPO group, through gymnasium's registry."""
    import gymnasium as gym

    env = gym.make_vec(
        "libero_bench.rl.ids:Libero-v0",
        num_envs=2,
        task=TASK,
        chunk=5,
        group_size=2,
        image_size=32,
        workers=2,
        max_episode_steps=12,
    )
    yield env
    env.close()


@pytest.mark.sim
def test_the_vector_environment_steps_chunks_in_workers(grouped: Any) -> None:
    env = grouped.unwrapped if hasattr(grouped, "unwrapped") else grouped
    assert len(set(env.worker_pids())) == 2
    obs, info = grouped.reset(seed=5)
    assert grouped.observation_space.contains(obs)
    assert obs["pixels"]["image"].shape == (2, 32, 32, 3) and obs["agent_pos"].dtype == np.float32
    assert list(info["start"]) == [0, 0] and info["task"][0] == env.task_description
    # one group: both environments begin from the same start, in different processes
    assert np.array_equal(obs["pixels"]["image"][0], obs["pixels"]["image"][1])
    assert np.array_equal(obs["agent_pos"][0], obs["agent_pos"][1])
    moves = np.zeros((2, 5, 7))
    moves[1, :, 2] = 1.0  # the second arm rises
    for elapsed in (5, 10):
        obs, reward, terminated, truncated, info = grouped.step(moves)
        assert list(info["elapsed"]) == [elapsed, elapsed] and not truncated.any()
    assert obs["agent_pos"][1, 2] > obs["agent_pos"][0, 2] + 0.02
    obs, reward, terminated, truncated, info = grouped.step(moves)
    assert list(truncated) == [True, True] and list(info["steps"]) == [2, 2] and not terminated.any()
    assert list(reward) == [0.0, 0.0] and list(info["_final_obs"]) == [True, True]
    assert info["final_obs"][1]["agent_pos"][2] > info["final_obs"][0]["agent_pos"][2]
    assert list(info["final_info"]["elapsed"]) == [12, 12]
    assert list(info["start"]) == [1, 1] and list(info["elapsed"]) == [0, 0]
    assert np.array_equal(obs["agent_pos"][0], obs["agent_pos"][1])  # the group's next start, together


@pytest.mark.sim
def test_a_seed_gives_the_same_starts(grouped: Any) -> None:
    first = grouped.reset(seed=9)[0]["agent_pos"]
    other = grouped.reset(seed=10)[0]["agent_pos"]
    again = grouped.reset(seed=9)[0]["agent_pos"]
    assert np.array_equal(first, again) and not np.array_equal(first, other)


@pytest.mark.sim
def test_bad_actions_get_one_sentence(grouped: Any) -> None:
    grouped.reset(seed=0)
    with pytest.raises(InputError, match=r"shape \(2, chunk, 7\)"):
        grouped.step(np.zeros((3, 5, 7)))
    with pytest.raises(InputError, match="finite"):
        grouped.step(np.full((2, 5, 7), np.nan))


@pytest.mark.sim
def test_stored_starts_are_libero_init_states_drawn_as_robosuite_draws() -> None:
    from libero_bench.rl.vector import LiberoVectorEnv
    from libero_data.sim import EnvConfig, LiberoEnv
    from libero_data.tasks import get_task

    # two environments in this process: they share one GL context
    env = LiberoVectorEnv(
        TASK, 2, starts="stored", image_size=32, cameras=("agentview",), workers=1, settle=0
    )
    try:
        obs, info = env.reset(seed=2)
    finally:
        env.close()
    assert set(obs["pixels"]) == {"image"}
    stored = get_task(TASK).init_states()
    with LiberoEnv(TASK, EnvConfig(image_size=32, cameras=("agentview",))) as direct:  # robosuite's cameras
        for i in range(2):
            index, seed = training_start(2, env.task_key, i, 50)
            assert (info["init_index"][i], info["reset_seed"][i]) == (index, seed)
            expected = direct.reset(stored[index], seed=seed)
            assert np.array_equal(obs["agent_pos"][i], expected["state"])
            assert np.array_equal(obs["pixels"]["image"][i], expected["agentview"])


@pytest.mark.slow
@pytest.mark.sim
def test_memory_stays_flat_over_many_episodes() -> None:
    """Two workers run 600 one-step episodes; their memory after the first 100 and after the last
    differs by less than 20 MiB each (a scene rebuilt per reset would add hundreds)."""
    from libero_bench.rl.vector import LiberoVectorEnv

    env = LiberoVectorEnv(TASK, 2, image_size=64, workers=2, max_episode_steps=1, settle=0)
    try:
        env.reset(seed=0)
        trace = []
        for episode in range(300):
            env.step(np.zeros((2, 7)))
            if episode in (50, 299):
                trace.append([_resident_mib(pid) for pid in env.worker_pids()])
        assert max(b - a for a, b in zip(*trace, strict=True)) < 20.0, trace
    finally:
        env.close()


def _resident_mib(pid: int) -> float:
    with open(f"/proc/{pid}/status") as status:
        for line in status:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    raise RuntimeError(f"no VmRSS for process {pid}")
