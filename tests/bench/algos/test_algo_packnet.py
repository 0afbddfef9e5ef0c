"""PackNet: frozen weights stay bit-identical and a task's mask gives back its outputs."""

from __future__ import annotations

import pytest
import torch
from bench_helpers import synthetic_batch

from libero_bench.algos.packnet import PackNet, PackNetConfig, prunable_names
from libero_bench.policies import make_policy
from libero_bench.policies.base import Policy


def _train(algo: PackNet, policy: Policy, batch: dict[str, torch.Tensor], steps: int) -> None:
    # weight decay and momentum would move frozen weights if PackNet did not restore them
    optimiser = torch.optim.AdamW(policy.parameters(), lr=1e-2, weight_decay=0.1)
    policy.train()
    for _ in range(steps):
        loss = sum(algo.loss(batch).values(), torch.zeros(()))
        optimiser.zero_grad()
        loss.backward()
        optimiser.step()
        algo.after_step()


def _outputs(policy: Policy, batch: dict[str, torch.Tensor]) -> tuple[torch.Tensor, torch.Tensor]:
    policy.eval()
    with torch.no_grad():
        return policy(batch).log_prob(batch["actions"]), policy.act(batch)


@pytest.mark.parametrize("policy_name", ["resnet_t", "vit_t", "resnet_rnn"])
def test_packnet_protects_earlier_tasks(policy_name: str) -> None:
    torch.manual_seed(0)
    policy = make_policy(policy_name, "smoke", image_size=32)
    algo = PackNet(PackNetConfig(post_prune_epochs=1))
    assert PackNetConfig().prune_fraction == 0.75
    batch0 = synthetic_batch(batch_size=2, window=3, seed=1)
    batch1 = synthetic_batch(batch_size=2, window=3, seed=2)

    algo.start_task(0, policy)
    _train(algo, policy, batch0, 3)
    algo.end_task(0, lambda: [batch0])
    params = dict(policy.named_parameters())
    for name, mask in algo.masks.items():
        n = mask.numel()
        assert int((mask == 1).sum()) == n - round(0.75 * n)  # 25 % kept
        assert (params[name][mask == 0] == 0).all()
    _train(algo, policy, batch0, 2)  # post-prune fine-tuning
    for name, mask in algo.masks.items():
        assert (params[name][mask == 0] == 0).all()
    after_task0 = {n: p.detach().clone() for n, p in policy.named_parameters()}
    buffers0 = {n: b.clone() for n, b in policy.named_buffers()}
    algo.set_eval_task(0)
    expected = _outputs(policy, batch0)
    algo.set_eval_task(None)

    algo.start_task(1, policy)
    _train(algo, policy, batch1, 3)
    algo.end_task(1, lambda: [batch1])
    _train(algo, policy, batch1, 2)

    changed = 0
    for name, p in policy.named_parameters():
        if name in algo.masks:
            mask = algo.masks[name]
            assert torch.equal(p[mask == 1], after_task0[name][mask == 1]), name
            changed += int((p[mask == 2] != after_task0[name][mask == 2]).sum())
        else:  # biases, norms, tokens: trained with the first task only
            assert torch.equal(p, after_task0[name]), name
    assert changed > 0  # the second task did learn something
    for name, b in policy.named_buffers():
        assert torch.equal(b, buffers0[name]), name

    algo.set_eval_task(0)
    log_prob, action = _outputs(policy, batch0)
    assert torch.equal(log_prob, expected[0]) and torch.equal(action, expected[1])
    algo.set_eval_task(None)
    assert not torch.equal(_outputs(policy, batch0)[0], expected[0])

    # a checkpointed PackNet evaluates the same way
    other = PackNet()
    other.load_state_dict(algo.state_dict())
    other.bind(policy)
    other.set_eval_task(0)
    assert torch.equal(_outputs(policy, batch0)[0], expected[0])
    other.set_eval_task(None)


def test_prunable_parameters_exclude_biases_and_norms() -> None:
    policy = make_policy("resnet_rnn", "smoke", image_size=32)
    names = prunable_names(policy)
    assert any(n.startswith("rnn.weight_ih") for n in names)
    assert any(n.endswith("conv1.weight") for n in names)
    assert not any(n.endswith("bias") or ".bn" in n for n in names)


def test_config_validation() -> None:
    with pytest.raises(ValueError, match=r"PackNetConfig\.prune_fraction"):
        PackNetConfig(prune_fraction=1.0)
