"""Which LIBERO-Plus tasks to run: those of a suite, of a LIBERO task, or named; the ones that lack
an asset counted apart; for CPU budgets a sample of N per category and suite, stratified by
difficulty where their ``task_classification.json`` gives it, the same for the same seed (every
policy, and the expert, run the same tasks)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from libero_data.errors import InputError
from libero_data.tasks.plus import BASES, CATEGORIES, PREFIX, PlusTaskInfo


def plus_plan(
    refs: Sequence[str],
    per_category: int | None = None,
    seed: int = 0,
    difficulty: dict[str, int] | None = None,
) -> dict[str, dict[str, Any]]:
    """Base suite -> ``{"run": [task indices], "not_run": {category: count}}`` for ``refs``."""
    from libero_data.tasks import get_suite
    from libero_data.tasks.plus_cache import plus_infos

    chosen: dict[str, list[PlusTaskInfo]] = {}
    for ref in refs:
        base, picked = _picked(ref, plus_infos)
        chosen.setdefault(base, [])
        known = {i.index for i in chosen[base]}
        chosen[base] += [i for i in picked if i.index not in known]
    plan: dict[str, dict[str, Any]] = {}
    for base, infos in chosen.items():
        tasks = get_suite(PREFIX + base).tasks
        runnable = [i for i in infos if not tasks[i.index].missing]
        not_run: dict[str, int] = {}
        for i in infos:
            if tasks[i.index].missing:
                not_run[i.category] = not_run.get(i.category, 0) + 1
        if per_category is not None:
            runnable = _sample(base, runnable, per_category, seed, difficulty or {})
        plan[base] = {"run": sorted(i.index for i in runnable), "not_run": not_run}
    return plan


def _picked(ref: str, infos_of: Callable[[str], tuple[PlusTaskInfo, ...]]) -> tuple[str, list[PlusTaskInfo]]:
    """The base suite a reference names and its LIBERO-Plus tasks."""
    from libero_data.tasks import get_suite

    name = ref.removeprefix(PREFIX)
    base, _, key = name.partition("/")
    if base not in BASES:
        raise InputError(
            f"LIBERO-Plus perturbs {', '.join(BASES)}; {ref!r} is not one of them or a task of one",
            field="tasks",
        )
    infos = list(infos_of(PREFIX + base))
    if not key:
        return base, infos
    if ref.startswith(PREFIX):
        task = get_suite(PREFIX + base).task(key)
        return base, [infos[task.index]]
    source = get_suite(base).task(key).name  # a LIBERO task: the LIBERO-Plus tasks made from it
    return base, [i for i in infos if i.parsed.base == source]


def _sample(
    base: str, infos: list[PlusTaskInfo], n: int, seed: int, difficulty: dict[str, int]
) -> list[PlusTaskInfo]:
    """``n`` tasks per category (all where fewer), levels of difficulty in turn where known."""
    out: list[PlusTaskInfo] = []
    for c, category in enumerate(CATEGORIES):
        rng = np.random.default_rng([seed, BASES.index(base), c])
        levels: dict[int, list[PlusTaskInfo]] = {}
        for i in sorted((i for i in infos if i.category == category), key=lambda i: i.index):
            levels.setdefault(difficulty.get(i.parsed.name, 0), []).append(i)
        queues = [[group[k] for k in rng.permutation(len(group))] for _level, group in sorted(levels.items())]
        picked: list[PlusTaskInfo] = []
        while len(picked) < n and any(queues):
            for queue in queues:
                if queue and len(picked) < n:
                    picked.append(queue.pop(0))
        out += picked
    return out


#: Where their checkout keeps the task classification (relative to their package folder).
CLASSIFICATION = "benchmark/task_classification.json"


def read_difficulty(path: str | Path | None = None) -> dict[str, int]:
    """Task name -> difficulty level 1-5 from their ``task_classification.json``: the file at
    ``path``, else the one in their checkout (``$LIBERO_DATA_PLUS``), else none (the wheel has
    none). Tasks without a level are left out."""
    import json

    from libero_data.runtime.files import read_json
    from libero_data.tasks.plus import plus_files

    if path is not None:
        data, where = read_json(Path(path)), str(path)
    else:
        files = plus_files()
        if not files.exists(CLASSIFICATION):
            return {}
        data, where = json.loads(files.read(CLASSIFICATION)), files.where(CLASSIFICATION)
    if not isinstance(data, dict):
        raise InputError(
            f"{where} is not LIBERO-Plus's task classification (a suite -> tasks object)",
            field="plus_classification",
        )
    levels: dict[str, int] = {}
    for entries in data.values():
        for entry in entries if isinstance(entries, list) else []:
            if isinstance(entry, dict) and isinstance(entry.get("difficulty_level"), int):
                levels[str(entry.get("name"))] = int(entry["difficulty_level"])
    return levels
