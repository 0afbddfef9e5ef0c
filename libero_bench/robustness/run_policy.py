"""The robustness sweep's rollouts of a libero-bench run's policy (``libero_bench.robustness.cells``).

The policy is the run's final checkpoint (after the last task it learned; MTL: its one
checkpoint), in the algorithm's evaluation view of each source task (PackNet's masks). Each
variant gets the embedding of its own instruction from the run's language encoder (a reworded
instruction is part of the perturbation). Rollouts are written and joined into a LeRobot
dataset like a run's (``rollouts/``), and an interrupted sweep resumes: finished rollouts are
read back, not run again.
"""

from __future__ import annotations

import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

from libero_bench.robustness.cells import Cell, SweepRequest, heldout_seeds
from libero_bench.rollouts.loop import Execution
from libero_data.errors import RunError
from libero_data.pipeline.request import state_width

#: Kinds whose scenes may hold more or other bodies than their source task.
WIDER_KINDS = ("distractors", "swap")


def run_outcomes(
    run: Path,
    request: SweepRequest,
    cells: list[Cell],
    out: Path,
    execution: Execution,
    on_result: Callable[[Any], None] | None,
    on_total: Callable[[int], None] | None,
    keep_work: bool = False,
) -> tuple[dict[str, list[bool]], str, dict[str, tuple[int, ...]]]:
    """Outcomes (in rollout order) per cell name, the policy's name for the report and the
    held-out seeds per source task. Once the rollouts are joined in ``out/rollouts`` their shards
    are removed unless ``keep_work``."""
    from libero_bench.data.dataset import DemoDataset
    from libero_bench.data.language import encode_tasks
    from libero_bench.data.mixing import mixed_seeds
    from libero_bench.rollouts.actors import PolicyActor
    from libero_bench.runs.folder import RunFolder
    from libero_bench.runs.summary import load_run
    from libero_bench.train.checkpoints import kept_checkpoint, policy_from_checkpoint
    from libero_data.runtime.files import read_json, write_json

    summary = load_run(run)
    config = summary.config
    preset = config["preset"]
    names = [t["name"] for t in config["tasks"][: summary.tasks_done]]
    source = DemoDataset(config["data"])
    mixed = mixed_seeds(config)
    avoid = {}
    for name in names:
        starts = source.training_starts(source.task(name))
        avoid[name] = (set(starts[1]) if starts is not None else set()) | mixed.get(name, set())
    seeds = heldout_seeds(request, avoid)
    for name in seeds:
        if name not in names:
            raise RunError(f"run {run} has not learned task {name}; choose among {', '.join(names)}")
    live = [c for c in cells if not c.reason]
    languages = [t["language"] for t in config["tasks"]]
    embeddings = encode_tasks([*languages, *(c.language for c in live)], preset["language_encoder"])
    last = summary.tasks_done - 1
    folder = RunFolder(run)
    results_path = out / "results.json"
    saved = read_json(results_path, required=("rollouts",)) if results_path.is_file() else {}
    done = {r["key"]: r for r in saved.get("rollouts", [])}
    joined = bool(saved.get("complete")) and (out / "rollouts" / "meta" / "info.json").is_file()
    records = dict(done)
    # Distractors add objects and a swap may bring another body: the widest state sets the width.
    width = max([source.sim_state_width, *(state_width(c.bddl) for c in live if c.kind in WIDER_KINDS)])
    jobs_by_position = _jobs(
        live,
        names,
        embeddings[len(languages) :],
        seeds,
        request,
        done if joined else _stored(done, out),
        preset,
        width,
    )
    if on_total:
        on_total(len(done) + sum(len(j) for j in jobs_by_position.values()))
    by_key = {job.key: job for jobs in jobs_by_position.values() for job in jobs}

    def seen(result: Any) -> None:
        job = by_key[result.key]
        records[result.key] = {
            "key": result.key,
            "task": job.task_name,
            "rollout": int(job.tags["rollout"]),
            "env_seed": job.env_seed,
            "success": bool(result.success),
            "steps": int(result.steps),
        }
        write_json(results_path, {"rollouts": sorted(records.values(), key=lambda r: r["key"])})
        if on_result:
            on_result(result)

    device = execution.policy_device()
    with execution.open(out) as environments:
        for position, jobs in sorted(jobs_by_position.items()):
            policy, _algo = policy_from_checkpoint(config, kept_checkpoint(folder, config, last), position)
            actor = PolicyActor(policy.to(device))
            for _index, result in environments.run(actor, jobs):
                seen(result)
    if jobs_by_position or not joined:
        _join(run, out, records, live, config, request)
        write_json(
            results_path, {"rollouts": sorted(records.values(), key=lambda r: r["key"]), "complete": True}
        )
    if not keep_work:
        for work in (out / "shards", out / ".work"):
            shutil.rmtree(work, ignore_errors=True)
    outcomes: dict[str, list[bool]] = {}
    for record in sorted(records.values(), key=lambda r: (r["task"], r["rollout"])):
        outcomes.setdefault(record["task"], []).append(bool(record["success"]))
    return outcomes, f"{config['algo']} + {config['policy']} ({Path(run).name})", seeds


def _jobs(
    live: list[Cell],
    names: list[str],
    embeddings: Any,
    seeds: dict[str, tuple[int, ...]],
    request: SweepRequest,
    done: dict[str, Any],
    preset: dict[str, Any],
    width: int,
) -> dict[int, list[Any]]:
    """The rollouts still to run, grouped by the source task's position (its evaluation view)."""
    from libero_bench.rollouts.jobs import EvalTask, make_job
    from libero_bench.runs.folder import HELDOUT

    jobs_by_position: dict[int, list[Any]] = {}
    limits = request.step_limits()
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
            if key in done:
                continue
            jobs_by_position.setdefault(position, []).append(
                make_job(
                    task,
                    r,
                    key=key,
                    settle=request.settle,
                    max_steps=limits[cell.source],
                    image_size=int(preset["image_size"]),
                    sim_state_width=width,
                    shard_dir=f"shards/{key}",
                    rrd_path=f"rrd/{key}.rrd",
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


def _stored(done: dict[str, Any], out: Path) -> dict[str, Any]:
    """The finished rollouts whose shard is on disk (the others run again)."""
    return {k: r for k, r in done.items() if (out / "shards" / k / "episode.json").is_file()}


def _join(
    run: Path,
    out: Path,
    records: dict[str, Any],
    live: list[Cell],
    config: dict[str, Any],
    request: SweepRequest,
) -> None:
    """The sweep's rollouts as one LeRobot dataset in ``out/rollouts``."""
    from libero_bench.evaluation.rollout_dataset import build_rollout_dataset

    keys = sorted(records)
    bddl = {c.name: Path(c.bddl).read_text() for c in live}
    meta = {
        "run": str(run),
        "algo": config["algo"],
        "policy": config["policy"],
        "preset": "robustness",
        "seed": request.seed,
        "request": {"repo_id": "libero-bench/robustness", "suite": "robustness"},
        "tasks": [{"position": i, "name": c.name, "language": c.language} for i, c in enumerate(live)],
    }
    build_rollout_dataset(
        [out / "shards" / k for k in keys], out / "rollouts", run_meta=meta, bddl=bddl, work_dir=out / ".work"
    )
