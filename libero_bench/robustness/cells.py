"""A robustness sweep: a trained policy evaluated on tasks perturbed along kinds × levels.

For each source task, kind and level (1–5, ``libero_data.perturb.levels``) a variant is made
(``libero_data.procedural.variants.make_variant``) and written as a task of a suite folder
(``variants/``); level 0 is the source task itself. Every cell is rolled out from the same
held-out placements of its source task (LIBERO's sampler, seeds no demonstration started from),
so a kind that leaves the scene as it is (camera, lighting, texture, noise, robot start,
language) is compared with the unperturbed task start for start. The policy is a libero-bench
run's checkpoint (its final one, in the algorithm's view of each task) or a LeRobot policy
folder (``libero_bench.evaluation.policy_eval``). Every rollout is kept, as in every evaluation; the
report gives each cell's success with n and its Wilson interval, and the drop from level 0.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from libero_bench.runs.intervals import Rate
from libero_data.errors import InputError
from libero_data.rollout import RolloutSettings
from libero_data.tasks.horizons import SUITE, limit_text

#: The sweep's files, inside its folder.
VARIANTS = "variants"
REPORT = "robustness"


@dataclass(frozen=True)
class SweepRequest(RolloutSettings):
    """What to sweep: source tasks, kinds and levels, rollouts per cell, and the shared rollout
    settings (``max_steps``: steps, or each source task's suite limit; ``settle``;
    ``render_quality``: :class:`~libero_data.rollout.RolloutSettings`)."""

    tasks: tuple[str, ...]
    kinds: tuple[str, ...]
    levels: tuple[int, ...] = (1, 2, 3, 4, 5)
    rollouts: int = 10  # per cell, from held-out placements (the same at every level)
    seed: int = 0
    image_size: int | None = (
        None  # a served policy: the camera size sent (libero_bench.evaluation.policy_eval)
    )
    replan_steps: int = 5  # a served policy: actions executed of each chunk

    def __post_init__(self) -> None:
        from libero_data.perturb.levels import KINDS, LEVELS

        super().__post_init__()
        if not self.tasks:
            raise InputError("no tasks to perturb", field="tasks")
        for kind in self.kinds:
            if kind not in KINDS:
                raise InputError(
                    f"unknown robustness kind {kind!r}; known: {', '.join(KINDS)}", field="kinds"
                )
        if not self.kinds:
            raise InputError("no robustness kinds chosen", field="kinds")
        if not self.levels or any(level not in LEVELS for level in self.levels):
            raise InputError(f"levels must be among 1..5, got {self.levels}", field="levels")
        if self.rollouts <= 0:
            raise InputError("rollouts per cell must be positive", field="rollouts")

    def step_limits(self) -> dict[str, int]:
        """Per source task name: the steps its rollouts (and its variants') may take."""
        from libero_data.tasks import get_task

        return {task.name: self.steps_for(task.suite) for task in map(get_task, self.tasks)}


@dataclass(frozen=True)
class Cell:
    """One evaluated task: a source task's variant (level 0: the source itself)."""

    source: str  # the source task's name
    kind: str  # "" at level 0
    level: int
    name: str  # the task's name in the variants suite
    language: str
    bddl: str
    reason: str = ""  # why no variant of this level exists ("" when it does)


def make_cells(request: SweepRequest, folder: Path) -> list[Cell]:
    """Write the variants (and sources) as a suite folder; the cells in order."""
    from libero_data.bddl import write
    from libero_data.perturb.levels import KINDS
    from libero_data.procedural.variants import make_variant
    from libero_data.runtime.files import write_json, write_text
    from libero_data.scenes.sampler import SamplingError
    from libero_data.seeding import variant_level_rng
    from libero_data.tasks import get_task

    cells: list[Cell] = []
    for ref in request.tasks:
        task = get_task(ref)
        source = dataclasses.replace(task.problem, language=task.language.lower())
        entries: list[tuple[int, str, Any, str]] = [(0, "", source, "")]
        for kind in request.kinds:
            for level in request.levels:
                # Seeded by the kind's place among all kinds, not among those asked for: a sweep of some
                # kinds draws the same variants as those cells of a full sweep with the same seed.
                rng = variant_level_rng(request.seed, task.index, KINDS.index(kind), level)
                try:
                    problem = make_variant(
                        task.problem, task.id, kind, rng, language=task.language, level=level
                    )
                    entries.append((level, kind, problem, ""))
                except SamplingError as exc:
                    entries.append((level, kind, None, str(exc)))
        for level, kind, problem, why in entries:
            name = task.name if level == 0 else f"{task.name}__{kind}_l{level}"
            bddl = folder / "tasks" / f"{name}.bddl"
            if problem is not None:
                write_text(bddl, write(problem))
            language = problem.language if problem is not None else ""
            cells.append(Cell(task.name, kind, level, name, language, str(bddl), why))
    manifest = {
        "name": folder.name,
        "tasks": [
            {"name": c.name, "language": c.language, "bddl": f"tasks/{c.name}.bddl"}
            for c in cells
            if not c.reason
        ],
    }
    write_json(folder / "suite.json", manifest)
    return cells


def heldout_seeds(request: SweepRequest, avoid: dict[str, set[int]]) -> dict[str, tuple[int, ...]]:
    """Per source task: its held-out placements (skipping ``avoid[name]``, the training seeds)."""
    from libero_data.seeding import heldout_starts
    from libero_data.tasks import get_task

    out = {}
    for ref in request.tasks:
        name = get_task(ref).name
        out[name] = tuple(heldout_starts(name, request.rollouts, avoid=avoid.get(name, set())))
    return out


def table(
    cells: list[Cell], outcomes: dict[str, list[bool]], kinds: tuple[str, ...], levels: tuple[int, ...]
) -> dict[str, Any]:
    """Success per kind × level (all source tasks pooled) and per cell, with the drop from level 0."""

    def pooled(chosen: list[Cell]) -> Rate:
        wins = [ok for c in chosen for ok in outcomes.get(c.name, [])]
        return Rate(sum(wins), len(wins))

    base = pooled([c for c in cells if c.level == 0])
    grid: dict[str, dict[str, Any]] = {}
    for kind in kinds:
        row: dict[str, Any] = {"0": base.to_dict()}
        for level in levels:
            rate = pooled([c for c in cells if c.kind == kind and c.level == level])
            entry = rate.to_dict()
            if rate.n and base.n:
                entry["drop"] = base.rate - rate.rate
            row[str(level)] = entry
        grid[kind] = row
    per_cell = [
        {
            **dataclasses.asdict(c),
            "result": Rate(sum(outcomes.get(c.name, [])), len(outcomes.get(c.name, []))).to_dict(),
        }
        for c in cells
    ]
    return {"unperturbed": base.to_dict(), "grid": grid, "cells": per_cell}


def sweep_markdown(summary: dict[str, Any], levels: tuple[int, ...]) -> str:
    def cell(entry: dict[str, Any]) -> str:
        if not entry.get("n"):
            return "–"
        drop = f" (−{entry['drop']:.0%})" if entry.get("drop", 0) > 0 else ""
        return f"{entry['rate']:.0%} [{entry['low']:.0%}, {entry['high']:.0%}]{drop}"

    base = summary["table"]["unperturbed"]
    lines = [
        f"# Robustness of `{summary['policy']}`",
        "",
        f"Success per kind and level, pooled over {len(summary['request']['tasks'])} task(s), "
        f"{summary['request']['rollouts']} held-out placements per task and cell (the same at every level), "
        "with 95% Wilson intervals and the drop from the unperturbed tasks (level 0: "
        f"{cell(base)}, {base['successes']}/{base['n']}). Step limit: {_limits(summary)}; "
        f"`{summary['request']['render_quality']}` images; "
        f"variants drawn with seed {summary['request']['seed']}.",
        "",
        "| kind | " + " | ".join(f"level {level}" for level in levels) + " |",
        "|---|" + "---:|" * len(levels),
    ]
    grid = summary["table"]["grid"]
    for kind in [k for k in summary["request"]["kinds"] if k in grid]:  # the order asked (JSON sorts keys)
        lines.append(f"| {kind} | " + " | ".join(cell(grid[kind][str(level)]) for level in levels) + " |")
    missing = [c for c in summary["table"]["cells"] if c["reason"]]
    if missing:
        lines.append("")
    lines += [
        f"- no {c['kind']} variant of level {c['level']} for {c['source']}: {c['reason']}" for c in missing
    ]
    return "\n".join(lines) + "\n"


def heatmap(summary: dict[str, Any], levels: tuple[int, ...], path: Path) -> Path:
    """Kind × level (0 = unperturbed) success, each cell with its interval."""
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    grid = summary["table"]["grid"]
    kinds = list(grid)
    columns = ["0", *(str(level) for level in levels)]
    values = np.array(
        [[grid[k][c].get("rate", np.nan) if grid[k][c].get("n") else np.nan for c in columns] for k in kinds],
        dtype=float,
    )
    fig, ax = plt.subplots(figsize=(1.3 + 1.15 * len(columns), 0.9 + 0.62 * len(kinds)), dpi=120)
    image = ax.imshow(values, vmin=0.0, vmax=1.0, cmap="RdYlGn", aspect="auto")
    for i, kind in enumerate(kinds):
        for j, column in enumerate(columns):
            entry = grid[kind][column]
            if entry.get("n"):
                text = f"{entry['rate']:.0%}\n[{entry['low']:.0%}, {entry['high']:.0%}]"
                ax.text(j, i, text, ha="center", va="center", fontsize=7)
    ax.set_xticks(range(len(columns)), ["none", *(f"level {c}" for c in columns[1:])])
    ax.set_yticks(range(len(kinds)), kinds)
    ax.set_title(f"success under perturbation ({summary['policy_name']})", fontsize=9)
    fig.colorbar(image, ax=ax, fraction=0.03, label="success")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path


def write_sweep_report(folder: Path, summary: dict[str, Any], levels: tuple[int, ...]) -> list[Path]:
    from libero_data.runtime.files import write_json, write_text

    paths = [
        write_json(folder / f"{REPORT}.json", summary),
        write_text(folder / f"{REPORT}.md", sweep_markdown(summary, levels)),
        heatmap(summary, levels, folder / f"{REPORT}.png"),
    ]
    return paths


def _limits(summary: dict[str, Any]) -> str:
    """The step limit as a report states it: the number, or each source task's (a variant takes
    its source's)."""
    limits = summary.get("step_limits") or {}
    if summary["request"]["max_steps"] != SUITE or not limits:
        return limit_text(summary["request"]["max_steps"])
    return "each task's suite limit (LeRobot's), " + ", ".join(
        f"{n} for {name}" for name, n in limits.items()
    )
