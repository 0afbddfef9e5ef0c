"""Robustness kinds and their severity levels 1–5: the magnitudes each level stands for.

Every kind is one module of :mod:`libero_data.perturb.kinds`, which sets its magnitudes; this
module lists them. Scene kinds rewrite the task's BDDL (where objects start, which objects there
are, what the instruction says); the other kinds change what the simulated scene looks like or
where the arm starts, and leave the BDDL's scene as it is (:mod:`libero_data.perturb.apply`).
``KINDS``, ``SCENE_KINDS``, ``ENV_KINDS`` and ``MAGNITUDES`` are read from the kinds when first
asked for.

Every number here is part of a variant's identity: a variant records its kind, level, seed and
the values drawn from these ranges, so it is reproduced from its BDDL file alone.
"""

from __future__ import annotations

import functools
from typing import Any

LEVELS = (1, 2, 3, 4, 5)


@functools.cache
def _lists() -> dict[str, Any]:
    from libero_data.perturb.kinds import all_kinds

    kinds = all_kinds()
    return {
        "KINDS": tuple(k.name for k in kinds),
        "SCENE_KINDS": tuple(k.name for k in kinds if k.rewrites_task),
        "ENV_KINDS": tuple(k.name for k in kinds if not k.rewrites_task),
        "MAGNITUDES": {k.name: dict(k.magnitudes) for k in kinds},
    }


def __getattr__(name: str) -> Any:
    if name in ("KINDS", "SCENE_KINDS", "ENV_KINDS", "MAGNITUDES"):
        return _lists()[name]
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def magnitude(kind: str, level: int) -> dict[str, Any]:
    """The magnitudes of ``kind`` at ``level`` (checked)."""
    from libero_data.errors import InputError

    magnitudes = _lists()["MAGNITUDES"]
    if kind not in magnitudes:
        raise InputError(f"unknown robustness kind {kind!r}; known: {', '.join(magnitudes)}", field="kinds")
    if level not in LEVELS:
        raise InputError(f"the level must be 1..5, got {level}", field="level")
    return {name: values[level - 1] for name, values in magnitudes[kind].items()}


def level_table() -> str:
    """The documented magnitudes as a Markdown table (docs/procedural-and-robustness.md, cards)."""
    lines = ["| kind | parameter | 1 | 2 | 3 | 4 | 5 |", "|---|---|---|---|---|---|---|"]
    for kind, magnitudes in _lists()["MAGNITUDES"].items():
        for name, values in magnitudes.items():
            cells = [_cell(v) for v in values]
            lines.append(f"| {kind} | {name} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _cell(value: Any) -> str:
    if isinstance(value, bool):
        return "yes" if value else "–"
    if isinstance(value, tuple):
        return ", ".join(value) or "–"
    if value == 0 and not isinstance(value, float):
        return "–"
    return str(value)
