"""The robustness sweep's rollouts of a libero-bench run's policy (``libero_bench.robustness.cells``).

The policy is the run's final checkpoint (after the last task it learned; MTL: its one
checkpoint), in the algorithm's evaluation view of each source task (PackNet's masks). Each
variant gets the embedding of its own instruction from the run's language encoder (a reworded
instruction is part of the perturbation). Rollouts are written and joined into a LeRobot
dataset like a run's (``rollouts/``) by a :class:`~libero_bench.rollouts.session.RolloutSession`,
and an interrupted sweep resumes: finished rollouts are read back, not run again.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from libero_bench.robustness.cells import Cell, SweepRequest, heldout_seeds
from libero_bench.rollouts.loop import RolloutResources
from libero_data.errors import RunError
from libero_data.pipeline.request import state_width

#: Kinds whose scenes may hold more or other bodies than their source task.
WIDER_KINDS = ("distractors", "swap")


def run_outcomes(
    run: Path,
    request: SweepRequest,
    cells: list[Cell],
    out: Path,
    execution: RolloutResources,
    on_result: Callable[[Any], None] | None,
    on_total: Callable[[int], None] | None,
    keep_work: bool = False,
) -> tuple[dict[str, list[bool]], str, dict[str, tuple[int, ...]]]:
    """Outcomes (in rollout order) per cell name, the policy's name for the report and the
    held-out seeds per source task. Once the rollouts are joined in ``out/rollouts`` their shards
    are removed unless ``keep_work``."""
    from libero_bench.rollouts.actors import PolicyActor
    from libero_bench.rollouts.policy_kinds import policy_source
    from libero_bench.rollouts.session import RolloutSession
    from libero_bench.runs.saved_policy import load_run_policy
    from libero_bench.runs.training_data import run_training_data

    source = policy_source(str(run))
    names = list(source.tasks)
    config = load_run_policy(run).config
    _, starts = source.training_starts()
    seeds = heldout_seeds(request, {name: starts.get(name, (set(), set()))[1] for name in names})
    for name in seeds:
        if name not in names:
            raise RunError(f"run {run} has not learned task {name}; choose among {', '.join(names)}")
    live = [c for c in cells if not c.reason]
    assert source.embed is not None
    embeddings = source.embed([c.language for c in live])
    session = RolloutSession(out).load()
    # Distractors add objects and a swap may bring another body: the widest state sets the width.
    width = max(
        [
            run_training_data(run, config).sim_state_width,
            *(state_width(c.bddl) for c in live if c.kind in WIDER_KINDS),
        ]
    )
    jobs_by_position = _jobs(
        live, names, embeddings, seeds, request, session, int(config["preset"]["image_size"]), width
    )
    left = {position: session.left(jobs) for position, jobs in jobs_by_position.items()}
    if on_total:
        on_total(len(session.records) + sum(len(j) for j in left.values()))
    groups = [
        (lambda device, p=position: PolicyActor(load_run_policy(run, device, p).policy), jobs)
        for position, jobs in sorted(left.items())
    ]
    ran = session.run(execution, groups, _record, on_result)
    if ran is not None or not session.joined:
        session.join(_meta(run, live, config, request), {c.name: Path(c.bddl).read_text() for c in live})
        session.save(complete=True)
    session.clean(keep_work)
    outcomes: dict[str, list[bool]] = {}
    for record in sorted(session.records.values(), key=lambda r: (r["task"], r["rollout"])):
        outcomes.setdefault(record["task"], []).append(bool(record["success"]))
    return outcomes, f"{source.policy_type} ({Path(run).name})", seeds


def _record(job: Any, result: Any) -> dict[str, Any]:
    from libero_bench.rollouts.session import rollout_record

    return rollout_record(job, result, kind=job.tags["kind"], level=job.tags["level"])


def _jobs(
    live: list[Cell],
    names: list[str],
    embeddings: Any,
    seeds: dict[str, tuple[int, ...]],
    request: SweepRequest,
    session: Any,
    image_size: int,
    width: int,
) -> dict[int, list[Any]]:
    """Every rollout of the sweep, grouped by the source task's position (its evaluation view)."""
    from libero_bench.rollouts.jobs import EvalTask, make_job
    from libero_bench.runs.folder import HELDOUT

    jobs_by_position: dict[int, list[Any]] = {}
    limits = request.step_limits()
    folder = session.folder
    for i, cell in enumerate(live):
        position = names.index(cell.source)
        task = EvalTask(
            name=cell.name,
            language=cell.language,
            position=position,
            env_ref=cell.bddl,
            task_emb=embeddings[i],
            heldout=seeds[cell.source],
        )
        for r in range(request.rollouts):
            key = f"{cell.name}-h{r:03d}"
            jobs_by_position.setdefault(position, []).append(
                make_job(
                    task,
                    r,
                    key=key,
                    settle=request.settle,
                    max_steps=limits[cell.source],
                    image_size=image_size,
                    sim_state_width=width,
                    shard_dir=folder.shard(key).relative_to(folder.root),
                    rrd_path=folder.rrd_file(key).relative_to(folder.root),
                    tags={
                        "source": cell.source,
                        "kind": cell.kind,
                        "level": cell.level,
                        "phase": "robustness",
                    },
                    start=HELDOUT,
                    render_quality=request.render_quality,
                )
            )
    return jobs_by_position


def _meta(run: Path, live: list[Cell], config: dict[str, Any], request: SweepRequest) -> dict[str, Any]:
    """What the sweep's rollout dataset says of itself."""
    return {
        "run": Path(run).name,
        "algo": config["algo"],
        "policy": config["policy"],
        "preset": "robustness",
        "seed": request.seed,
        "request": {"repo_id": "libero-bench/robustness", "suite": "robustness"},
        "tasks": [{"position": i, "name": c.name, "language": c.language} for i, c in enumerate(live)],
    }
