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
from libero_data.perturb.levels import ENV_KINDS, magnitude


@dataclass(frozen=True)
class Perturbation:
    """One environment perturbation (a kind of :data:`ENV_KINDS` at a level)."""

    kind: str
    level: int
    seed: int
    params: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
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
    m = magnitude(kind, level)
    rng = np.random.default_rng([seed, level, ENV_KINDS.index(kind) if kind in ENV_KINDS else 99])
    sign = lambda: float(rng.choice((-1.0, 1.0)))  # noqa: E731
    params: dict[str, Any]
    if kind == "camera":
        params = {
            "azimuth_deg": sign() * m["azimuth_deg"],
            "elevation_deg": sign() * m["elevation_deg"],
            "distance_scale": 1.0 + sign() * m["distance_change"],
            "fovy_change_deg": sign() * m["fovy_change_deg"],
        }
    elif kind == "lighting":
        hue = float(rng.uniform(0.0, 1.0))
        params = {
            "intensity": 1.0 + sign() * m["intensity_change"],
            "tint_rgb": _tint(hue, m["tint"]),
            "direction_deg": sign() * m["direction_deg"],
            "shadows": bool(m["shadows"]),
        }
    elif kind == "texture":
        params = {
            "tints": {
                part: _tint(float(rng.uniform()), m["tint"], brightness=sign() * m["tint"])
                for part in m["tinted"]
            },
            "installed": {part: _installed(rng) for part in m["installed"]},
            "generated": {part: _pattern(rng) for part in m["generated"]},
        }
    elif kind == "robot_init":
        params = {"joint_offset_rad": float(m["joint_offset_rad"])}
    else:  # noise
        params = {k: (float(v) if isinstance(v, float) else int(v)) for k, v in m.items()}
    return Perturbation(kind, level, seed, params)


def _installed(rng: np.random.Generator) -> str:
    """An installed texture image, by ``<package>/<file>`` (so a variant names what it shows)."""
    from libero_data.perturb.textures import installed_textures

    names = list(installed_textures())
    if not names:
        raise InputError("no installed texture images found (LIBERO's assets or robosuite's)", field="kinds")
    return names[int(rng.integers(len(names)))]


def _tint(hue: float, strength: float, brightness: float = 0.0) -> list[float]:
    """An RGB multiplier: white moved ``strength`` toward the colour of ``hue``, scaled by 1 + brightness."""
    import colorsys

    r, g, b = colorsys.hsv_to_rgb(hue, 1.0, 1.0)
    return [round((1.0 - strength + strength * c) * (1.0 + brightness), 4) for c in (r, g, b)]


def _pattern(rng: np.random.Generator) -> dict[str, Any]:
    """A generated texture: a pattern, two colours and a scale."""
    return {
        "pattern": str(rng.choice(["checker", "stripes", "noise", "gradient"])),
        "colour_a": [round(float(v), 3) for v in rng.uniform(0.05, 0.95, 3)],
        "colour_b": [round(float(v), 3) for v in rng.uniform(0.05, 0.95, 3)],
        "cells": int(rng.integers(4, 17)),
    }
