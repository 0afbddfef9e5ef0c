"""Pre-norm transformer and the block-causal temporal transformer of the T policies."""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import Tensor, nn

from libero_bench.policies.modules.positional import SinusoidalPositionEncoding


class SelfAttention(nn.Module):
    """Multi-head self-attention with an explicit head size (LIBERO decouples it from dim)."""

    def __init__(self, dim: int, num_heads: int, head_dim: int, dropout: float = 0.0) -> None:
        super().__init__()
        self.num_heads = num_heads
        self.head_dim = head_dim
        self.qkv = nn.Linear(dim, 3 * num_heads * head_dim, bias=False)
        self.out = nn.Linear(num_heads * head_dim, dim)
        self.dropout = nn.Dropout(dropout)

    def forward(self, x: Tensor, mask: Tensor | None = None) -> Tensor:
        b, n, _ = x.shape
        qkv = self.qkv(x).view(b, n, 3, self.num_heads, self.head_dim).permute(2, 0, 3, 1, 4)
        y = F.scaled_dot_product_attention(qkv[0], qkv[1], qkv[2], attn_mask=mask)
        return self.dropout(self.out(y.transpose(1, 2).reshape(b, n, -1)))


class TransformerBlock(nn.Module):
    def __init__(self, dim: int, num_heads: int, head_dim: int, mlp_dim: int, dropout: float) -> None:
        super().__init__()
        self.norm1 = nn.LayerNorm(dim)
        self.attention = SelfAttention(dim, num_heads, head_dim, dropout)
        self.norm2 = nn.LayerNorm(dim)
        self.mlp = nn.Sequential(
            nn.Linear(dim, mlp_dim),
            nn.GELU(),
            nn.Dropout(dropout),
            nn.Linear(mlp_dim, dim),
            nn.Dropout(dropout),
        )

    def forward(self, x: Tensor, mask: Tensor | None = None) -> Tensor:
        x = x + self.attention(self.norm1(x), mask)
        return x + self.mlp(self.norm2(x))


class Transformer(nn.Module):
    """A stack of pre-norm blocks over (B, N, dim); ``mask`` (N, N) is True where allowed."""

    def __init__(
        self, dim: int, num_layers: int, num_heads: int, head_dim: int, mlp_dim: int, dropout: float = 0.0
    ) -> None:
        super().__init__()
        self.layers = nn.ModuleList(
            [TransformerBlock(dim, num_heads, head_dim, mlp_dim, dropout) for _ in range(num_layers)]
        )

    def forward(self, x: Tensor, mask: Tensor | None = None) -> Tensor:
        for layer in self.layers:
            x = layer(x, mask)
        return x


def block_causal_mask(steps: int, tokens_per_step: int, device: torch.device | None = None) -> Tensor:
    """(N, N) bool, N = steps * tokens: a token sees every token of its own and earlier steps."""
    step = torch.arange(steps * tokens_per_step, device=device) // tokens_per_step
    return step[:, None] >= step[None, :]


class TemporalTransformer(nn.Module):
    """Tokens (B, T, K, D) -> features (B, T, D): sinusoidal step positions, block-causal
    attention over all T * K tokens, and the output of each step's first token (the
    language/action token)."""

    def __init__(
        self,
        dim: int,
        num_layers: int,
        num_heads: int,
        head_dim: int,
        mlp_dim: int,
        dropout: float = 0.0,
        position_base: float = 10.0,
    ) -> None:
        super().__init__()
        self.positions = SinusoidalPositionEncoding(dim, position_base)
        self.transformer = Transformer(dim, num_layers, num_heads, head_dim, mlp_dim, dropout)

    def forward(self, tokens: Tensor) -> Tensor:
        b, t, k, d = tokens.shape
        x = tokens + self.positions(t)[None, :, None, :].to(tokens.dtype)
        mask = block_causal_mask(t, k, tokens.device)
        x = self.transformer(x.reshape(b, t * k, d), mask)
        return x.view(b, t, k, d)[:, :, 0]
