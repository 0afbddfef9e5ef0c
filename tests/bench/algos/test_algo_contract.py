"""Every algorithm with every policy, at smoke size: two tasks of training steps, acting."""

from __future__ import annotations

import math

import pytest
import torch
from bench_helpers import synthetic_batch

from libero_bench.algos import Algo, algo_class, algo_config_from_dict, algo_names, make_algo
from libero_bench.policies import make_policy, policy_names


def _steps(algo: Algo, policy: torch.nn.Module, batch: dict[str, torch.Tensor], n: int) -> dict[str, float]:
    optimiser = torch.optim.AdamW(policy.parameters(), lr=1e-3, weight_decay=1e-4)
    policy.train()
    terms: dict[str, torch.Tensor] = {}
    for _ in range(n):
        terms = algo.loss(batch)
        loss = sum(terms.values(), torch.zeros(()))
        optimiser.zero_grad()
        loss.backward()
        torch.nn.utils.clip_grad_norm_(policy.parameters(), 100.0)
        optimiser.step()
        algo.after_step()
    return {k: v.item() for k, v in terms.items()}


@pytest.mark.parametrize("policy_name", policy_names())
@pytest.mark.parametrize("algo_name", algo_names())
def test_two_tasks_of_training(algo_name: str, policy_name: str) -> None:
    torch.manual_seed(0)
    policy = make_policy(policy_name, "smoke", image_size=32)
    algo = make_algo(algo_name, "smoke")
    batches = [synthetic_batch(batch_size=2, window=3, seed=s, task_id=k) for k, s in ((0, 1), (1, 2))]

    algo.start_task(0, policy)
    terms = _steps(algo, policy, batches[0], 1)
    assert "bc" in terms and all(math.isfinite(v) for v in terms.values())
    algo.end_task(0, lambda: [batches[0]])
    for _ in range(min(algo.post_task_epochs, 1)):
        _steps(algo, policy, batches[0], 1)

    if not algo.needs_all_tasks:
        algo.start_task(1, policy)
        terms = _steps(algo, policy, batches[1], 1)
        assert all(math.isfinite(v) for v in terms.values())
        algo.end_task(1, lambda: [batches[1]])

    for k in (0, 1):
        algo.set_eval_task(k)
        action = policy.act(batches[k])
        assert action.shape == (2, 7) and torch.isfinite(action).all()
        algo.set_eval_task(None)
    for p in policy.parameters():
        assert torch.isfinite(p).all()

    # the algorithm's state survives a checkpoint round trip
    restored = algo_class(algo_name)(algo_config_from_dict(algo.config.to_dict()))
    restored.load_state_dict(algo.state_dict())
    restored.bind(policy)
    assert restored.task_index == algo.task_index
    assert restored.loss(batches[0]).keys() == algo.loss(batches[0]).keys()


def test_registry_and_flags() -> None:
    assert algo_names() == ["er", "ewc", "mtl", "packnet", "seql"]
    assert [n for n in algo_names() if algo_class(n).needs_all_tasks] == ["mtl"]
    assert make_algo("packnet").post_task_epochs == 50
    assert make_algo("seql").post_task_epochs == 0
    with pytest.raises(RuntimeError, match="no policy"):
        make_algo("seql").loss(synthetic_batch())
    with pytest.raises(ValueError, match="end_task"):
        algo = make_algo("seql")
        algo.start_task(0, make_policy("resnet_t", "smoke", image_size=32))
        algo.end_task(1, list)
