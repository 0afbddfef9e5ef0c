"""Base of the policy configs (on the project's one config base, :class:`libero_data.config.Config`).

This module does not import torch, so configs can be built, validated and saved cheaply.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from libero_bench.sizes import Sized
from libero_data.config import Config
from libero_data.registry import Registry


@dataclass(frozen=True)
class PolicyConfig(Sized, Config):
    """Fields shared by every policy: input sizes, the GMM action head and augmentation.

    ``size("paper")`` gives the sizes of the LIBERO paper (Liu et al. 2023, appendix) and the
    upstream ``libero/configs/policy`` files; ``size("smoke")`` a tiny model for tests and CPU
    smoke runs; ``size("quick")`` a model between the two that trains on two CPU cores at 64x64
    in 1.6-1.7 times the smoke model's time per sample (the ``quick`` preset); each policy's
    ``sizes`` table (:mod:`libero_bench.sizes`) says what they change.
    """

    name: ClassVar[str] = ""
    #: where the torch model is, ``module:Class`` (imported by ``libero_bench.policies.build_policy``)
    model: ClassVar[str] = ""

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


#: Every policy's config, by name: each ``<policy>/config.py`` registers its own (no torch here).
POLICY_CONFIGS: Registry[type[PolicyConfig]] = Registry("policy")
