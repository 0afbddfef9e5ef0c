"""A perturbation of how a task's scene looks or where its arm starts: kind, level, seed and the
concrete values drawn for them (``libero_data.perturb.levels`` gives the ranges).

It travels inside the task's BDDL file as a comment line (``Problem.perturbation``), so a variant
is reproduced from that file alone, and ``LiberoEnv`` applies it whenever it builds the task.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from libero_data.errors import InputError
from libero_data.perturb.levels import magnitude


@dataclass(frozen=True)
class Perturbation:
    """One environment perturbation (a kind of :data:`ENV_KINDS` at a level, or a LIBERO-Plus task's
    camera, arm start and image noise: kind ``libero_plus``, level 0)."""

    kind: str
    level: int
    seed: int
    params: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        from libero_data.perturb.levels import ENV_KINDS
        from libero_data.perturb.plus_hooks import KIND as PLUS

        if self.kind == PLUS:  # a LIBERO-Plus task's record: their parameters, no level of ours
            return
        if self.kind not in ENV_KINDS:
            raise InputError(
                f"unknown perturbation kind {self.kind!r}; known: {', '.join(ENV_KINDS)}", field="kinds"
            )
        magnitude(self.kind, self.level)  # checks the level

    def to_json(self) -> str:
        """Canonical JSON (sorted keys, no spaces): the text ``Problem.perturbation`` holds."""
        data = {"kind": self.kind, "level": self.level, "seed": self.seed, "params": self.params}
        return json.dumps(data, sort_keys=True, separators=(",", ":"))

    @classmethod
    def from_json(cls, text: str) -> Perturbation | None:
        """The perturbation a BDDL comment holds ("" -> None)."""
        if not text:
            return None
        data = json.loads(text)
        return cls(
            str(data["kind"]), int(data["level"]), int(data.get("seed", 0)), dict(data.get("params", {}))
        )

    def describe(self) -> str:
        """One line for cards and reports: kind, level and the values drawn."""
        if not self.level:
            return f"{self.kind} ({_values(self.params)})"
        return f"{self.kind} level {self.level} ({_values(self.params)})"


def _values(params: dict[str, Any]) -> str:
    parts = []
    for key, value in sorted(params.items()):
        if isinstance(value, dict):
            if value:
                inner = "; ".join(f"{k} {_short(v)}" for k, v in sorted(value.items()))
                parts.append(f"{key}: {inner}")
        else:
            parts.append(f"{key} {_short(value)}")
    return ", ".join(parts)


def _short(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.3g}"
    if isinstance(value, list | tuple):
        return "(" + ", ".join(_short(v) for v in value) + ")"
    if isinstance(value, dict):
        if "pattern" in value:
            return f"{value['pattern']} {_short(value['colour_a'])}/{_short(value['colour_b'])}"
        return ", ".join(f"{k} {_short(v)}" for k, v in sorted(value.items()))
    return str(value)


def sample(kind: str, level: int, seed: int) -> Perturbation:
    """Draw the concrete values of a ``kind`` perturbation at ``level`` (signs, hues, textures)."""
    from libero_data.perturb.kinds import get_kind
    from libero_data.perturb.levels import ENV_KINDS

    m = magnitude(kind, level)
    rng = np.random.default_rng([seed, level, ENV_KINDS.index(kind) if kind in ENV_KINDS else 99])
    return Perturbation(kind, level, seed, get_kind(kind).sample(m, rng))
