"""Experience replay: bounded memory split across tasks, replay mixed into each step."""

from __future__ import annotations

import functools

import pytest
import torch
from bench_helpers import synthetic_batch

from libero_bench.algos.er import ER, ERConfig
from libero_bench.policies import make_policy


def _task_batches(task: int, n_batches: int = 3, size: int = 4) -> list[dict[str, torch.Tensor]]:
    return [
        synthetic_batch(batch_size=size, window=2, seed=100 * task + i, task_id=task)
        for i in range(n_batches)
    ]


def test_memory_never_exceeds_its_size_and_is_shared() -> None:
    torch.manual_seed(0)
    policy = make_policy("resnet_t", "smoke", image_size=32)
    algo = ER(ERConfig(memory_size=10, seed=3))
    assert algo.config.__class__().memory_size == 1000  # the paper's size
    for task in range(4):
        algo.start_task(task, policy)
        batches = _task_batches(task)
        algo.loss(batches[0])
        algo.end_task(task, functools.partial(list, batches))
        share = 10 // (task + 1)
        assert algo.memory_count() <= 10
        assert sorted(algo.memories) == list(range(task + 1))
        for k, memory in algo.memories.items():
            assert len(memory["task_id"]) == share
            assert (memory["task_id"] == k).all()


def test_replay_is_mixed_into_the_loss() -> None:
    torch.manual_seed(0)
    policy = make_policy("resnet_t", "smoke", image_size=32).eval()
    algo = ER(ERConfig(memory_size=8, seed=0))
    algo.start_task(0, policy)
    first = _task_batches(0)
    plain = algo.loss(first[0])["bc"]
    assert plain.item() == pytest.approx(policy.loss(first[0]).item())
    algo.end_task(0, lambda: first)
    algo.start_task(1, policy)
    current = _task_batches(1)[0]
    replay = algo.replay_batch(4, torch.device("cpu"))
    assert (replay["task_id"] == 0).all() and replay["agentview"].shape == (4, 2, 3, 32, 32)
    # stored images are 8-bit: a replayed window is a stored one up to half a grey level
    pool = torch.cat([b["agentview"] for b in first]).flatten(1)
    nearest = pool[torch.cdist(replay["agentview"].flatten(1), pool).argmin(1)]
    assert (replay["agentview"].flatten(1) - nearest).abs().max() <= 0.5 / 255 + 1e-6
    # the loss covers current + replayed windows
    state = algo.rng.bit_generator.state
    mixed = algo.loss(current)["bc"]
    algo.rng.bit_generator.state = state
    replayed = algo.replay_batch(4, torch.device("cpu"))
    merged = {k: torch.cat([current[k], replayed[k]]) for k in current}
    assert mixed.item() == pytest.approx(policy.loss(merged).item(), rel=1e-5)


def test_state_round_trip_replays_the_same_windows() -> None:
    policy = make_policy("vit_t", "smoke", image_size=32)
    algo = ER(ERConfig(memory_size=6, seed=1))
    algo.start_task(0, policy)
    algo.end_task(0, lambda: _task_batches(0))
    other = ER(ERConfig(memory_size=6, seed=99))
    other.load_state_dict(algo.state_dict())
    a = algo.replay_batch(5, torch.device("cpu"))
    b = other.replay_batch(5, torch.device("cpu"))
    assert all(torch.equal(a[k], b[k]) for k in a)


def test_a_state_carried_in_the_first_task_loads_without_its_empty_memory() -> None:
    # lifelong_carry leaves ER's windows behind; in the first task there are none, and the state
    # must still load (it failed: "neither its memory nor the updates that rebuild it")
    from libero_bench.algos.er import without_memories

    policy = make_policy("resnet_t", "smoke", image_size=32)
    algo = ER(ERConfig(memory_size=6, seed=1))
    algo.start_task(0, policy)
    state = algo.state_dict()
    stripped = {k: v for k, v in state.items() if k != "memories"}  # as carried before the fix
    for carried in (without_memories(state), stripped):
        other = ER(ERConfig(memory_size=6, seed=1))
        other.load_state_dict(carried)
        assert other.memories == {} and other.memory_count() == 0
    algo.end_task(0, lambda: _task_batches(0))  # with windows, they are left behind and rebuilt
    assert "memories" not in without_memories(algo.state_dict())


def test_config_validation() -> None:
    with pytest.raises(ValueError, match=r"ERConfig\.memory_size"):
        ERConfig(memory_size=0)
