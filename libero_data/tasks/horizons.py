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
"""

from __future__ import annotations

from collections.abc import Mapping

from libero_data.errors import InputError

__all__ = [
    "HUMAN_LONGEST",
    "OPENPI_LIMITS",
    "OTHER_LIMIT",
    "SUITE",
    "SUITE_LIMITS",
    "StepLimit",
    "check_step_limit",
    "is_step_limit",
    "limit_text",
    "parse_step_limit",
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
    from libero_data.tasks.plus import plus_base
    from libero_data.tasks.suites import pro_suite

    limit = check_step_limit(limit)
    if isinstance(limit, int):
        return limit
    pro = pro_suite(suite)
    base = pro.base if pro is not None else plus_base(suite) or suite
    return limits.get(base, OTHER_LIMIT)


def limit_text(limit: object) -> str:
    """How a report states a step limit: ``"300 steps"`` or what ``"suite"`` means."""
    if limit == SUITE:
        return (
            "each task's suite limit (LeRobot's LIBERO limits: "
            + ", ".join(f"{suite} {n}" for suite, n in SUITE_LIMITS.items())
            + f"; other tasks {OTHER_LIMIT})"
        )
    return f"{limit} steps"
