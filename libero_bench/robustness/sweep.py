"""Running a robustness sweep (``libero-bench robustness``): the variants, the policy's
rollouts on them (a libero-bench run's or a LeRobot policy's), and the report
(:mod:`libero_bench.robustness.cells` says what a sweep measures)."""

from __future__ import annotations

import dataclasses
import json
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

from libero_bench.robustness.cells import (
    VARIANTS,
    Cell,
    SweepRequest,
    heldout_seeds,
    make_cells,
    table,
    write_sweep_report,
)
from libero_bench.rollouts.loop import RolloutResources
from libero_bench.rollouts.policy_kinds import PolicySource


def sweep(
    policy: str | Path,
    request: SweepRequest,
    out: str | Path,
    *,
    execution: RolloutResources | None = None,
    on_result: Callable[[Any], None] | None = None,
    on_total: Callable[[int], None] | None = None,
    keep_work: bool = False,
) -> dict[str, Any]:
    """Run the sweep for ``policy`` (a libero-bench run folder, a LeRobot policy folder or a
    policy server, ``ws://HOST:PORT``); ``keep_work`` keeps the rollouts' shards once joined."""
    from libero_bench.rollouts.policy_kinds import RUN, check_policy, is_server, shown_from
    from libero_data.runtime.versions import versions

    execution = execution or RolloutResources()
    out = Path(out).resolve()
    ref = str(policy) if is_server(str(policy)) else str(Path(policy).resolve())
    source = check_policy(ref, request.image_size, request.replan_steps)  # before anything is written
    cells = make_cells(request, out / VARIANTS)
    if source.kind == RUN:
        from libero_bench.robustness.run_policy import run_outcomes

        outcomes, name, seeds = run_outcomes(
            Path(ref), request, cells, out, execution, on_result, on_total, keep_work
        )
    else:
        outcomes, name, seeds = _lerobot_outcomes(
            source, request, cells, out, execution, on_result, on_total, keep_work
        )
    shown = table(cells, outcomes, request.kinds, request.levels)
    for cell in shown["cells"]:  # named from the sweep's folder, so the folder can move
        cell["bddl"] = os.path.relpath(cell["bddl"], out)
    summary = {
        "policy": shown_from(ref, out),
        "policy_name": name,
        "request": dataclasses.asdict(request),
        "step_limits": request.step_limits(),
        "versions": versions(),
        "table": shown,
        # what a paired comparison of two sweeps needs (libero_bench.robustness.paired)
        "heldout_seeds": {name: list(s) for name, s in seeds.items()},
        "outcomes": {name: [bool(ok) for ok in oks] for name, oks in sorted(outcomes.items())},
    }
    write_sweep_report(out, summary, request.levels)
    return summary


def _lerobot_outcomes(
    source: PolicySource,
    request: SweepRequest,
    cells: list[Cell],
    out: Path,
    execution: RolloutResources,
    on_result: Callable[[Any], None] | None,
    on_total: Callable[[int], None] | None,
    keep_work: bool,
) -> tuple[dict[str, list[bool]], str, dict[str, tuple[int, ...]]]:
    """Outcomes per cell of a LeRobot policy or a served one (``libero-bench eval`` on the
    variants suite), its name and the held-out seeds per source task."""
    from libero_bench.evaluation.policy_eval import EvalRequest, evaluate_policy

    policy = source.ref
    _, starts = source.training_starts()
    seeds = heldout_seeds(request, {name: s[1] for name, s in starts.items()})
    by_name = {c.name: seeds[c.source] for c in cells if not c.reason}
    limits = request.step_limits()
    summary = evaluate_policy(
        EvalRequest(
            policy,
            (str(out / VARIANTS),),
            stored=0,
            heldout=request.rollouts,
            max_steps=request.max_steps,
            settle=request.settle,
            render_quality=request.render_quality,
            image_size=request.image_size,
            replan_steps=request.replan_steps,
        ),
        out / "eval",
        execution=execution,
        on_result=on_result,
        on_total=on_total,
        heldout_seeds=by_name,
        step_limits={c.name: limits[c.source] for c in cells if not c.reason},
        keep_work=keep_work,
        source=source,
    )
    records = json.loads((out / "eval" / "results.json").read_text())["rollouts"]
    outcomes: dict[str, list[bool]] = {}
    for r in sorted(records, key=lambda r: (r["task"], r["rollout"])):
        outcomes.setdefault(r["task"], []).append(bool(r["success"]))
    return outcomes, f"{summary['policy_type']} policy", seeds
