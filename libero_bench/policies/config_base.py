"""Base of the policy configs (on the project's one config base, :class:`libero_data.config.Config`).

This module does not import torch, so configs can be built, validated and saved cheaply.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar, Self

from libero_bench.train.presets import POLICY_SIZES
from libero_data.config import Config
from libero_data.errors import InputError


@dataclass(frozen=True)
class PolicyConfig(Config):
    """Fields shared by every policy: input sizes, the GMM action head and augmentation.

    ``paper()`` gives the sizes of the LIBERO paper (Liu et al. 2023, appendix) and the
    upstream ``libero/configs/policy`` files; ``smoke()`` gives a tiny model for tests and
    CPU smoke runs; ``size("quick")`` a model between the two that trains on two CPU cores
    at 64x64 in 1.6-1.7 times the smoke model's time per sample (the ``quick`` preset).
    """

    name: ClassVar[str] = ""
    smoke_overrides: ClassVar[dict[str, Any]] = {}
    quick_overrides: ClassVar[dict[str, Any]] = {}

    image_size: int = 128
    task_emb_dim: int = 384
    action_dim: int = 7
    window: int = 10
    head_hidden_dim: int = 1024
    head_num_layers: int = 2
    num_modes: int = 5
    min_std: float = 1e-4
    augment: bool = True
    translation: int = 8
    color_jitter: float = 0.3

    def __post_init__(self) -> None:
        self._check_positive("image_size", "task_emb_dim", "action_dim", "window", "head_hidden_dim")
        self._check_positive("num_modes")
        self._check_non_negative("head_num_layers", "translation")
        if not self.min_std > 0:
            self._fail("min_std", "must be > 0")
        if not 0.0 <= self.color_jitter < 1.0:
            self._fail("color_jitter", "must be in [0, 1)")
        if not isinstance(self.augment, bool):
            self._fail("augment", "must be a bool")

    # -- sizes ----------------------------------------------------------------------------
    @classmethod
    def paper(cls, **overrides: Any) -> Self:
        """The paper's sizes (the dataclass defaults), with optional overrides."""
        return cls(**overrides)

    @classmethod
    def smoke(cls, **overrides: Any) -> Self:
        """A tiny model (a training step on CPU takes milliseconds), with optional overrides."""
        return cls(**{**cls.smoke_overrides, **overrides})

    @classmethod
    def size(cls, size: str, **overrides: Any) -> Self:
        """``paper``, ``quick`` or ``smoke``."""
        sizes = {"paper": {}, "quick": cls.quick_overrides, "smoke": cls.smoke_overrides}
        if size not in sizes:
            raise InputError(
                f"unknown policy size {size!r}; known: {', '.join(POLICY_SIZES)}", field="policy_size"
            )
        return cls(**{**sizes[size], **overrides})
