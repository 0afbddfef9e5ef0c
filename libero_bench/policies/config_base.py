"""Base of the policy configs: frozen dataclasses, validated on construction, JSON-friendly.

This module does not import torch, so configs can be built, validated and saved cheaply.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, ClassVar, Self


@dataclass(frozen=True)
class PolicyConfig:
    """Fields shared by every policy: input sizes, the GMM action head and augmentation.

    ``paper()`` gives the sizes of the LIBERO paper (Liu et al. 2023, appendix) and the
    upstream ``libero/configs/policy`` files; ``smoke()`` gives a tiny model for tests and
    CPU smoke runs.
    """

    name: ClassVar[str] = ""
    smoke_overrides: ClassVar[dict[str, Any]] = {}

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

    # -- validation helpers -------------------------------------------------------------
    def _fail(self, field: str, message: str) -> None:
        value = getattr(self, field)
        raise ValueError(f"{type(self).__name__}.{field} {message}, got {value!r}")

    def _check_positive(self, *fields: str) -> None:
        for field in fields:
            value = getattr(self, field)
            if isinstance(value, bool) or not isinstance(value, int) or value <= 0:
                self._fail(field, "must be a positive integer")

    def _check_non_negative(self, *fields: str) -> None:
        for field in fields:
            value = getattr(self, field)
            if isinstance(value, bool) or not isinstance(value, int) or value < 0:
                self._fail(field, "must be a non-negative integer")

    def _check_dropout(self, *fields: str) -> None:
        for field in fields:
            value = getattr(self, field)
            if not isinstance(value, int | float) or not 0.0 <= value < 1.0:
                self._fail(field, "must be a probability in [0, 1)")

    # -- presets and serialisation ------------------------------------------------------
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
        """``paper`` or ``smoke``."""
        if size == "paper":
            return cls.paper(**overrides)
        if size == "smoke":
            return cls.smoke(**overrides)
        raise ValueError(f"unknown policy size {size!r}; known: paper, smoke")

    def to_dict(self) -> dict[str, Any]:
        """JSON-serialisable dict; ``type`` names the registry entry."""
        data: dict[str, Any] = {"type": self.name}
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            data[f.name] = list(value) if isinstance(value, tuple) else value
        return data

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Self:
        """Inverse of ``to_dict`` (the ``type`` key, if present, must match)."""
        data = dict(data)
        kind = data.pop("type", cls.name)
        if kind != cls.name:
            raise ValueError(f"config type {kind!r} does not match {cls.__name__} ({cls.name!r})")
        known = {f.name: f for f in dataclasses.fields(cls)}
        unknown = sorted(set(data) - set(known))
        if unknown:
            raise ValueError(f"{cls.__name__} has no field(s) {', '.join(unknown)}")
        for key, value in data.items():
            if isinstance(value, list):
                data[key] = tuple(value)
        return cls(**data)
