"""Parameter and FLOP counts of the policies (``torch.utils.flop_counter``)."""

from __future__ import annotations

import logging
from collections.abc import Sequence
from typing import Any

import torch
from torch import nn
from torch.utils import flop_counter
from torch.utils.flop_counter import FlopCounterMode

from libero_bench.data.batch_keys import (
    ACTIONS,
    AGENTVIEW,
    GRIPPER_STATES,
    JOINT_STATES,
    TASK_EMB,
    TASK_ID,
    WRIST,
)
from libero_bench.policies import build_policy, policy_config, policy_names
from libero_bench.policies.base import Batch, Policy, eval_mode

logger = logging.getLogger(__name__)


def count_parameters(policy: nn.Module, trainable_only: bool = False) -> int:
    """Number of parameters (all, or only those with ``requires_grad``)."""
    return sum(p.numel() for p in policy.parameters() if p.requires_grad or not trainable_only)


def _sdpa_cpu_flops(query_shape: Any, key_shape: Any, value_shape: Any, *args: Any, **kwargs: Any) -> int:
    # FlopCounterMode knows the CUDA attention kernels but not the CPU one
    return int(flop_counter.sdpa_flop_count(query_shape, key_shape, value_shape))


def _lstm_flops(module: nn.LSTM, inputs: tuple[Any, ...]) -> int:
    x = inputs[0]
    steps = x.shape[0] * x.shape[1]  # batch * time, whatever the layout
    hidden, directions = module.hidden_size, 2 if module.bidirectional else 1
    total = 0
    for layer in range(module.num_layers):
        width = module.input_size if layer == 0 else hidden * directions
        total += directions * steps * 2 * 4 * hidden * (width + hidden)
    return total


def forward_flops(policy: Policy, batch: Batch) -> int:
    """FLOPs of one ``policy.forward(batch)`` in eval mode, without gradients (a multiply-add
    counts as 2 FLOPs, as ``FlopCounterMode`` counts them).

    Two gaps of ``FlopCounterMode`` are filled: attention on CPU (via the same formula it
    uses for the CUDA kernels) and LSTMs (counted analytically from their shapes, gates'
    matrix products only, when the counter recorded no RNN operator).
    """
    cpu_attention = getattr(torch.ops.aten, "_scaled_dot_product_flash_attention_for_cpu", None)
    mapping = {cpu_attention: _sdpa_cpu_flops} if cpu_attention is not None else {}
    counter = FlopCounterMode(display=False, custom_mapping=mapping)
    lstm_flops: list[int] = []
    hooks = [
        m.register_forward_hook(lambda mod, inp, out: lstm_flops.append(_lstm_flops(mod, inp)))
        for m in policy.modules()
        if isinstance(m, nn.LSTM)
    ]
    try:
        with torch.no_grad(), eval_mode(policy), counter:
            policy(batch)
    finally:
        for hook in hooks:
            hook.remove()
    counted_ops = {str(op) for ops in counter.get_flop_counts().values() for op in ops}
    rnn_counted = any("rnn" in op or "lstm" in op for op in counted_ops)
    return int(counter.get_total_flops()) + (0 if rnn_counted else sum(lstm_flops))


def synthetic_batch(
    batch_size: int = 1, window: int = 10, image_size: int = 128, task_emb_dim: int = 384, seed: int = 0
) -> dict[str, torch.Tensor]:
    """A random batch with the trainer's keys and shapes (for FLOP counts and tests)."""
    g = torch.Generator().manual_seed(seed)
    b, t, s = batch_size, window, image_size
    return {
        AGENTVIEW: torch.rand(b, t, 3, s, s, generator=g),
        WRIST: torch.rand(b, t, 3, s, s, generator=g),
        JOINT_STATES: torch.randn(b, t, 7, generator=g),
        GRIPPER_STATES: torch.randn(b, t, 2, generator=g) * 0.04,
        TASK_EMB: torch.randn(b, task_emb_dim, generator=g),
        ACTIONS: torch.rand(b, t, 7, generator=g) * 2 - 1,
        TASK_ID: torch.zeros(b, dtype=torch.long),
    }


def policy_table(
    sizes: Sequence[str] = ("paper",), window: int = 10, image_size: int = 128
) -> list[dict[str, Any]]:
    """Parameters and forward FLOPs of every registered policy, for a batch of one window of
    ``window`` frames at ``image_size`` x ``image_size`` (two cameras)."""
    rows: list[dict[str, Any]] = []
    for size in sizes:
        for name in policy_names():
            config = policy_config(name, size, image_size=image_size, window=window)
            torch.manual_seed(0)
            policy = build_policy(config)
            batch = synthetic_batch(1, window, image_size, config.task_emb_dim)
            flops = forward_flops(policy, batch)
            rows.append(
                {
                    "policy": name,
                    "size": size,
                    "parameters": count_parameters(policy),
                    "flops": flops,
                    "gflops": flops / 1e9,
                }
            )
            logger.debug(
                "%s (%s): %d parameters, %.2f GFLOPs", name, size, rows[-1]["parameters"], flops / 1e9
            )
    return rows
