"""Roll a run's kept checkpoints out again from the run's own evaluation starts, under several
conditions (image quality, arm noise), for paired comparisons start by start."""

from __future__ import annotations

import tempfile
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any


def reroll(
    run: Path,
    conditions: Mapping[str, Mapping[str, Any]],
    *,
    workers: int,
    starts: Sequence[str] = ("stored", "heldout"),
    data: Path | None = None,
) -> dict[Any, Any]:
    """Outcomes per (condition, start kind): {(task, rollout): (success, init index, seed)}.

    ``conditions`` maps a name to :func:`libero_bench.rollouts.jobs.make_job` keywords
    (``render_quality``, ``arm_noise``). ``data`` replaces the run's dataset (held-out seeds
    skip that dataset's demonstration seeds). Also returns ``recorded`` (the run's own final
    outcomes) and ``seconds`` per condition.
    """
    from libero_bench.analysis.compare import final_outcomes
    from libero_bench.data.dataset import DemoDataset
    from libero_bench.data.language import encode_tasks
    from libero_bench.rollouts.jobs import make_job
    from libero_bench.rollouts.loop import RolloutResources
    from libero_bench.runs.folder import HELDOUT, STORED, RunFolder
    from libero_bench.runs.saved_policy import kept_checkpoint, policy_from_checkpoint
    from libero_bench.runs.summary import load_run
    from libero_bench.runs.training_data import resolve
    from libero_bench.train.plan import resolve_eval_task
    from libero_bench.train.rounds import run_round
    from libero_data.runtime.jobs import JobPlacement

    summary = load_run(run)
    config = summary.config
    preset = config["preset"]
    source = DemoDataset(data or resolve(Path(run), config["data"]))
    embs = encode_tasks([t["language"] for t in config["tasks"]], preset["language_encoder"])
    out: dict[Any, Any] = {
        "run": str(run),
        "recorded": {s: final_outcomes(summary, s) for s in (STORED, HELDOUT)},
    }
    counts = {STORED: preset["eval_rollouts"], HELDOUT: preset["eval_heldout"]}
    folder = RunFolder(run)
    seconds: dict[str, float] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for position in range(summary.tasks_done):
            task = source.task(config["tasks"][position]["name"])
            eval_task = resolve_eval_task(
                source, task, position, embs[position], heldout=preset["eval_heldout"]
            )
            policy, _algo = policy_from_checkpoint(
                config, kept_checkpoint(folder, config, position), position
            )
            for i, (name, settings) in enumerate(conditions.items()):
                jobs = []
                for start in starts:
                    for r in range(counts[start]):
                        key = f"{i}-{position}-{start}-{r:03d}"
                        jobs.append(
                            make_job(
                                eval_task,
                                r,
                                key=key,
                                settle=preset["eval_settle"],
                                max_steps=preset["eval_max_steps"],
                                image_size=preset["image_size"],
                                sim_state_width=source.sim_state_width,
                                shard_dir=f"shards/{key}",
                                rrd_path=f"rrd/{key}.rrd",
                                tags={"condition": name},
                                start=start,
                                **settings,
                            )
                        )
                started = time.perf_counter()
                with RolloutResources(JobPlacement("local", workers)).open(
                    Path(tmp) / f"{i}-{position}"
                ) as environments:
                    results = run_round(environments, policy, jobs)
                seconds[name] = seconds.get(name, 0.0) + time.perf_counter() - started
                for job, result in zip(jobs, results, strict=True):
                    tags = job.tags
                    out.setdefault((name, job.start), {})[(eval_task.name, int(tags["rollout"]))] = (
                        bool(result.success),
                        int(tags["init_index"]),
                        int(tags["env_seed"]),
                    )
    out["seconds"] = seconds
    return out
