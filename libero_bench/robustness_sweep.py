"""Running a robustness sweep (``libero-bench robustness``): the variants, the policy's
rollouts on them (a libero-bench run's or a LeRobot policy's), and the report
(:mod:`libero_bench.robustness` says what a sweep measures)."""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

from libero_bench.robustness import (
    VARIANTS,
    Cell,
    SweepRequest,
    heldout_seeds,
    make_cells,
    table,
    write_report,
)


def sweep(
    policy: str | Path,
    request: SweepRequest,
    out: str | Path,
    *,
    workers: int = 1,
    on_result: Callable[[Any], None] | None = None,
    on_total: Callable[[int], None] | None = None,
) -> dict[str, Any]:
    """Run the sweep for ``policy`` (a libero-bench run folder or a LeRobot policy folder)."""
    from libero_bench.run_files import RunFolder
    from libero_data.runtime.versions import versions

    out = Path(out).resolve()
    policy = Path(policy).resolve()
    cells = make_cells(request, out / VARIANTS)
    if RunFolder(policy).is_run():
        from libero_bench.robustness_run import run_outcomes

        outcomes, name = run_outcomes(policy, request, cells, out, workers, on_result, on_total)
    else:
        outcomes, name = _lerobot_outcomes(policy, request, cells, out, workers, on_result, on_total)
    summary = {
        "policy": str(policy),
        "policy_name": name,
        "request": dataclasses.asdict(request),
        "versions": versions(),
        "table": table(cells, outcomes, request.kinds, request.levels),
    }
    write_report(out, summary, request.levels)
    return summary


def _lerobot_outcomes(
    policy: Path,
    request: SweepRequest,
    cells: list[Cell],
    out: Path,
    workers: int,
    on_result: Callable[[Any], None] | None,
    on_total: Callable[[int], None] | None,
) -> tuple[dict[str, list[bool]], str]:
    """Outcomes per cell of a LeRobot policy (``libero-bench eval`` on the variants suite)."""
    from libero_bench.lerobot_policy import policy_config
    from libero_bench.policy_eval import EvalRequest, evaluate_policy, training_starts

    _, starts = training_starts(policy)
    seeds = heldout_seeds(request, {name: s[1] for name, s in starts.items()})
    by_name = {c.name: seeds[c.source] for c in cells if not c.reason}
    evaluate_policy(
        EvalRequest(
            str(policy),
            (str(out / VARIANTS),),
            stored=0,
            heldout=request.rollouts,
            max_steps=request.max_steps,
            settle=request.settle,
            render_quality=request.render_quality,
        ),
        out / "eval",
        workers=workers,
        on_result=on_result,
        on_total=on_total,
        heldout_seeds=by_name,
    )
    records = json.loads((out / "eval" / "results.json").read_text())["rollouts"]
    outcomes: dict[str, list[bool]] = {}
    for r in sorted(records, key=lambda r: (r["task"], r["rollout"])):
        outcomes.setdefault(r["task"], []).append(bool(r["success"]))
    return outcomes, f"{policy_config(policy).type} policy"
