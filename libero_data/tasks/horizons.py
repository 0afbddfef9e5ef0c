"""How many steps an evaluation rollout of a task may take before it is cut.

A policy imitates the pace of its demonstrations, so a rollout needs about as many steps as
the longest demonstration of its task, plus room for a correction. LIBERO's paper gives every
task 600 steps; the evaluations the field reports today (LeRobot's LIBERO environment, openpi's
LIBERO example) give each suite a little more than the longest human demonstration in it:

=============== ======================== ===================
suite           longest human demo       limit (LeRobot)
=============== ======================== ===================
libero_spatial  193                      280 (openpi: 220)
libero_object   254                      280
libero_goal     270                      300
libero_10       505                      520
libero_90       373                      400
=============== ======================== ===================

A step limit is written as an integer (the same for every task) or ``"suite"``: each task gets
its suite's limit from this table; a task outside the five suites (a procedural one) gets
:data:`OTHER_LIMIT`, LeRobot's default for a suite it does not know.

A task's *standard limit* (:func:`standard_limit`) is openpi's limit of the LIBERO suite it comes
from (:func:`base_suite`): what the field's evaluations give a policy, so the longest
demonstration a policy copying its data's pace can afford. The expert report and every card count
success within it, and ``generate`` keeps no longer episode by default.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING

from libero_data.errors import InputError

if TYPE_CHECKING:
    from libero_data.tasks.task import Suite

__all__ = [
    "HUMAN_LONGEST",
    "OPENPI_LIMITS",
    "OTHER_LIMIT",
    "SUITE",
    "SUITE_LIMITS",
    "StepLimit",
    "base_suite",
    "check_step_limit",
    "is_step_limit",
    "limit_text",
    "parse_step_limit",
    "standard_limit",
    "step_limit",
]

#: Steps of the longest of LIBERO's human demonstrations, per suite (as openpi's and LeRobot's
#: LIBERO code state them).
HUMAN_LONGEST: dict[str, int] = {
    "libero_spatial": 193,
    "libero_object": 254,
    "libero_goal": 270,
    "libero_10": 505,
    "libero_90": 373,
}

#: Per-suite evaluation step limits of LeRobot's LIBERO environment (``TASK_SUITE_MAX_STEPS``
#: in ``lerobot/envs/libero.py``, lerobot 0.6.1).
SUITE_LIMITS: dict[str, int] = {
    "libero_spatial": 280,
    "libero_object": 280,
    "libero_goal": 300,
    "libero_10": 520,
    "libero_90": 400,
}

#: The step limits of openpi's LIBERO client (``examples/libero/main.py``), counted after its 10
#: waiting steps: the standard protocol's (libero_bench.rollouts.protocol).
OPENPI_LIMITS: dict[str, int] = {
    "libero_spatial": 220,
    "libero_object": 280,
    "libero_goal": 300,
    "libero_10": 520,
    "libero_90": 400,
}

#: The limit of a task outside the five suites (LeRobot's default).
OTHER_LIMIT = 500

SUITE = "suite"

#: A positive number of steps, or ``"suite"``.
StepLimit = int | str


def is_step_limit(value: object) -> bool:
    """Whether ``value`` is a step limit: a positive int (not a bool) or ``"suite"``."""
    if isinstance(value, str):
        return value == SUITE
    return isinstance(value, int) and not isinstance(value, bool) and value > 0


def check_step_limit(value: object, *, field: str = "max_steps") -> StepLimit:
    """``value`` if it is a step limit; otherwise :class:`InputError` naming ``field``."""
    if is_step_limit(value):
        return value  # type: ignore[return-value]
    raise InputError(f"a step limit is a positive number of steps or {SUITE!r}, got {value!r}", field=field)


def parse_step_limit(text: str, *, field: str = "max_steps") -> StepLimit:
    """A step limit from a command line or config value: ``"suite"`` or digits."""
    text = text.strip()
    if text.isdigit():
        return check_step_limit(int(text), field=field)
    return check_step_limit(text, field=field)


def step_limit(limit: StepLimit, suite: str, limits: Mapping[str, int] = SUITE_LIMITS) -> int:
    """The steps a rollout of a task of ``suite`` may take under ``limit``: a number, or the
    suite's entry in ``limits`` (a LIBERO-PRO or LIBERO-Plus suite takes its base suite's)."""
    limit = check_step_limit(limit)
    if isinstance(limit, int):
        return limit
    return limits.get(base_suite(suite) or suite, OTHER_LIMIT)


#: How many suite folders of variants of variants :func:`base_suite` follows (a loop ends there).
_MOST_HOPS = 8


def base_suite(suite: str | Suite, task: str | None = None) -> str | None:
    """The LIBERO suite (one of the five) whose limits a task of ``suite`` takes, or None.

    One of the five suites is its own; a LIBERO-PRO suite (``libero_goal_swap``) and a LIBERO-Plus
    suite (``plus/libero_goal``) take the suite they perturb; ``libero_100`` the part that holds the
    task named ``task``; a suite folder of robustness variants (its ``suite.json`` names the suite
    it was made from: ``variants_of``) takes that suite's base. A procedural suite (new tasks in
    LIBERO's scenes), a folder without a manifest and any other name have none.
    """
    from libero_data.tasks.task import Suite

    folder = suite.path if isinstance(suite, Suite) else None
    name = suite.name if isinstance(suite, Suite) else str(suite)
    for _ in range(_MOST_HOPS):
        if folder is None:
            found = _named_base(name, task)
            if found is not None or not Path(name).is_dir():
                return found
            folder = Path(name)
        source = _variants_of(folder)
        if source is None:
            return None
        name, folder = source, None
    return None


def _named_base(name: str, task: str | None) -> str | None:
    """The base of a suite known by name (the five, LIBERO-PRO's, LIBERO-Plus's, libero_100's parts)."""
    from libero_data.tasks.plus import plus_base
    from libero_data.tasks.suites import composite_part, pro_suite

    if name in OPENPI_LIMITS:
        return name
    pro = pro_suite(name)
    if pro is not None:
        return pro.base
    return plus_base(name) or (composite_part(name, task) if task is not None else None)


def _variants_of(folder: Path) -> str | None:
    """The suite a suite folder's variants were made from (its manifest's generator settings)."""
    from libero_data.runtime.files import read_json
    from libero_data.tasks.task import SUITE_MANIFEST

    manifest = Path(folder) / SUITE_MANIFEST
    if not manifest.is_file():
        return None
    generator = read_json(manifest, required=("tasks",)).get("generator") or {}
    source = (generator.get("settings") or {}).get("variants_of")
    return str(source) if source else None  # none: procedural tasks, made in no suite


def standard_limit(suite: str | Suite, task: str | None = None) -> int:
    """A task's standard step limit: openpi's limit of its base suite (:func:`base_suite`),
    counted after the 10 waiting steps; :data:`OTHER_LIMIT` for a task without one."""
    base = base_suite(suite, task)
    return OPENPI_LIMITS[base] if base is not None else OTHER_LIMIT


def limit_text(limit: object) -> str:
    """How a report states a step limit: ``"300 steps"`` or what ``"suite"`` means."""
    if limit == SUITE:
        return (
            "each task's suite limit (LeRobot's LIBERO limits: "
            + ", ".join(f"{suite} {n}" for suite, n in SUITE_LIMITS.items())
            + f"; other tasks {OTHER_LIMIT})"
        )
    return f"{limit} steps"
