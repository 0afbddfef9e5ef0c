"""Online EWC: zero penalty at the anchor, quadratic growth away from it, Fisher averaging."""

from __future__ import annotations

import pytest
import torch
from bench_helpers import synthetic_batch

from libero_bench.algos.ewc import EWC, EWCConfig
from libero_bench.policies import make_policy
from libero_bench.policies.base import Policy


def _trained_ewc() -> tuple[EWC, Policy, dict[str, torch.Tensor]]:
    torch.manual_seed(0)
    policy = make_policy("resnet_t", "smoke", image_size=32)
    batch = synthetic_batch(batch_size=2, window=3)
    algo = EWC(EWCConfig())
    algo.start_task(0, policy)
    assert algo.loss(batch)["ewc"].item() == 0.0  # nothing to protect yet
    algo.end_task(0, lambda: [batch, synthetic_batch(batch_size=2, window=3, seed=5)])
    return algo, policy, batch


def test_penalty_is_zero_at_the_anchor_and_grows_away() -> None:
    algo, policy, batch = _trained_ewc()
    assert algo.config.penalty_weight == 5e4 and algo.config.gamma == 0.9
    assert algo.penalty().item() == 0.0
    assert all(torch.equal(algo.anchor[n], p) for n, p in policy.named_parameters())
    assert sum(f.sum().item() for f in algo.fisher.values()) > 0
    assert all(p.grad is None for p in policy.parameters())  # Fisher estimation leaves no grads

    direction = {n: torch.randn_like(p) for n, p in policy.named_parameters()}
    penalties = []
    for scale in (1e-3, 2e-3):
        with torch.no_grad():
            for n, p in policy.named_parameters():
                p.copy_(algo.anchor[n] + scale * direction[n])
        penalties.append(algo.penalty().item())
    assert penalties[0] > 0
    assert penalties[1] == pytest.approx(4 * penalties[0], rel=1e-3)  # quadratic
    algo.start_task(1, policy)
    terms = algo.loss(batch)
    assert terms["ewc"].item() == pytest.approx(5e4 * penalties[1], rel=1e-5)
    terms["ewc"].backward()
    assert any(p.grad is not None and p.grad.abs().sum() > 0 for p in policy.parameters())


def test_fisher_is_a_running_estimate() -> None:
    algo, policy, batch = _trained_ewc()
    first = {n: f.clone() for n, f in algo.fisher.items()}
    algo.start_task(1, policy)
    algo.end_task(1, lambda: [batch, synthetic_batch(batch_size=2, window=3, seed=5)])
    # same weights and data: the new estimate equals the first, so F = 0.9 F1 + F1
    for n, f in algo.fisher.items():
        torch.testing.assert_close(f, 1.9 * first[n])


def test_state_round_trip() -> None:
    algo, policy, _ = _trained_ewc()
    other = EWC()
    other.load_state_dict(algo.state_dict())
    other.bind(policy)
    assert other.penalty().item() == 0.0
    for n in algo.fisher:
        assert torch.equal(other.fisher[n], algo.fisher[n])


def test_config_validation() -> None:
    with pytest.raises(ValueError, match=r"EWCConfig\.gamma"):
        EWCConfig(gamma=1.5)
    with pytest.raises(ValueError, match=r"EWCConfig\.fisher_batches"):
        EWCConfig(fisher_batches=0)
