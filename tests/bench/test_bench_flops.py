"""Parameter and FLOP counting."""

from __future__ import annotations

import torch
from bench_helpers import synthetic_batch
from torch.utils.flop_counter import FlopCounterMode

from libero_bench.policies import make_policy
from libero_bench.policies.resnet_rnn.config import ResNetRNNConfig
from libero_bench.train.flops import count_parameters, forward_flops, policy_table


def test_count_parameters() -> None:
    policy = make_policy("resnet_t", "smoke", image_size=32)
    total = sum(p.numel() for p in policy.parameters())
    assert count_parameters(policy) == total
    policy.head.requires_grad_(False)
    head = sum(p.numel() for p in policy.head.parameters())
    assert count_parameters(policy, trainable_only=True) == total - head


def test_flops_grow_linearly_with_the_window_for_the_rnn() -> None:
    # everything but the once-per-window language projection is per frame
    policy = make_policy("resnet_rnn", "smoke", image_size=32)
    f2, f4, f6 = (forward_flops(policy, synthetic_batch(batch_size=1, window=t)) for t in (2, 4, 6))
    assert f2 > 0 and f6 - f4 == f4 - f2
    assert isinstance(policy.config, ResNetRNNConfig)
    language = 2 * policy.config.task_emb_dim * policy.config.text_embed_dim
    assert f2 - (f4 - f2) == language


def test_lstm_and_cpu_attention_are_counted() -> None:
    batch = synthetic_batch(batch_size=1, window=3)
    rnn = make_policy("resnet_rnn", "smoke", image_size=32).eval()
    plain = FlopCounterMode(display=False)
    with torch.no_grad(), plain:
        rnn(batch)
    cfg = rnn.config
    assert isinstance(cfg, ResNetRNNConfig)
    width = 2 * cfg.image_embed_dim + cfg.text_embed_dim + 9
    lstm = 3 * 2 * 4 * cfg.rnn_hidden_dim * (width + cfg.rnn_hidden_dim)  # one layer, 3 steps
    assert forward_flops(rnn, batch) == plain.get_total_flops() + lstm

    vit = make_policy("vit_t", "smoke", image_size=32).eval()
    plain = FlopCounterMode(display=False)
    with torch.no_grad(), plain:
        vit(batch)
    assert forward_flops(vit, batch) > plain.get_total_flops()


def test_policy_table_rows() -> None:
    rows = policy_table(("smoke",), window=2, image_size=32)
    assert [r["policy"] for r in rows] == ["resnet_rnn", "resnet_t", "vit_t"]
    for row in rows:
        assert row["size"] == "smoke" and row["parameters"] > 0 and row["flops"] > 0
        assert row["gflops"] == row["flops"] / 1e9
