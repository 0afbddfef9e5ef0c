"""Robustness kinds and their severity levels 1–5: the magnitudes each level stands for.

Scene kinds change the task's BDDL (where objects start, which objects there are, what the
instruction says); the other kinds change what the simulated scene looks like or where the arm
starts, and leave the BDDL's scene as it is (``libero_data.perturb.apply``):

| kind | what a level sets |
|---|---|
| ``layout`` | the least distance each movable object is moved from its source place |
| ``distractors`` | how many objects the task is not about are added (as many as fit) |
| ``swap`` | how many objects are replaced by another of their kind (the moved one first) |
| ``language`` | how far the instruction is reworded (paraphrase, then politeness, context, synonyms, a trailing clause) |
| ``camera`` | agentview azimuth and elevation about the scene, distance to it, field of view |
| ``robot_init`` | the largest offset of each arm joint from the start configuration |
| ``lighting`` | light intensity (brighter or darker), colour tint, direction; shadows from level 3 |
| ``texture`` | table/floor/wall colour tints (1–2), installed textures (3–4), generated textures (5) |
| ``noise`` | Gaussian pixel noise, blur, JPEG quality of the images; Gaussian noise on the proprioception |

Every number here is part of a variant's identity: a variant records its kind, level, seed and
the values drawn from these ranges, so it is reproduced from its BDDL file alone.
"""

from __future__ import annotations

from typing import Any

#: Kinds that rewrite the task's BDDL scene or instruction.
SCENE_KINDS = ("layout", "distractors", "swap", "language")
#: Kinds that change how the scene looks or where the arm starts (a perturbation record).
ENV_KINDS = ("camera", "robot_init", "lighting", "texture", "noise")
KINDS = SCENE_KINDS + ENV_KINDS
LEVELS = (1, 2, 3, 4, 5)

#: Per kind, per parameter: the magnitude at levels 1..5 (units in the name).
MAGNITUDES: dict[str, dict[str, tuple[Any, ...]]] = {
    "layout": {"min_move_m": (0.06, 0.09, 0.12, 0.15, 0.18)},
    "distractors": {"count": (1, 2, 3, 4, 5)},
    "swap": {"objects": (1, 2, 3, 4, 5)},
    "language": {
        "paraphrase": (True, True, True, True, True),
        "politeness": (False, True, True, True, True),
        "context_sentence": (False, False, True, True, True),
        "synonyms": (False, False, False, True, True),
        "trailing_clause": (False, False, False, False, True),
    },
    "camera": {
        "azimuth_deg": (5.0, 10.0, 15.0, 22.5, 30.0),
        "elevation_deg": (2.5, 5.0, 7.5, 10.0, 12.5),
        "distance_change": (0.05, 0.10, 0.15, 0.20, 0.25),
        "fovy_change_deg": (2.0, 4.0, 6.0, 8.0, 10.0),
    },
    "robot_init": {"joint_offset_rad": (0.05, 0.10, 0.15, 0.20, 0.30)},
    "lighting": {
        "intensity_change": (0.15, 0.30, 0.45, 0.60, 0.75),
        "tint": (0.05, 0.10, 0.20, 0.30, 0.40),
        "direction_deg": (10.0, 20.0, 30.0, 45.0, 60.0),
        "shadows": (False, False, True, True, True),
    },
    "texture": {
        "tint": (0.15, 0.30, 0.0, 0.0, 0.0),
        "tinted": (("table",), ("table", "floor", "walls"), (), (), ()),
        "installed": ((), (), ("table",), ("table", "floor"), ()),
        "generated": ((), (), (), (), ("table", "floor", "walls")),
    },
    "noise": {
        "gaussian_sigma_255": (3.0, 6.0, 10.0, 15.0, 20.0),
        "blur_radius_px": (0.0, 0.4, 0.7, 1.0, 1.4),
        "jpeg_quality": (0, 85, 60, 40, 20),  # 0: no JPEG round trip
        "state_sigma": (0.002, 0.004, 0.008, 0.015, 0.025),
    },
}


def magnitude(kind: str, level: int) -> dict[str, Any]:
    """The magnitudes of ``kind`` at ``level`` (checked)."""
    from libero_data.errors import InputError

    if kind not in MAGNITUDES:
        raise InputError(f"unknown robustness kind {kind!r}; known: {', '.join(KINDS)}", field="kinds")
    if level not in LEVELS:
        raise InputError(f"the level must be 1..5, got {level}", field="level")
    return {name: values[level - 1] for name, values in MAGNITUDES[kind].items()}


def level_table() -> str:
    """The documented magnitudes as a Markdown table (README, cards)."""
    lines = ["| kind | parameter | 1 | 2 | 3 | 4 | 5 |", "|---|---|---|---|---|---|---|"]
    for kind in KINDS:
        for name, values in MAGNITUDES[kind].items():
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
