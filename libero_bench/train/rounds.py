"""Evaluation rounds of a run: which rollouts a round runs, running them, and what it records.

A round rolls the current policy out on some of the run's tasks (``eval_rollouts`` each from
LIBERO's stored init states and ``eval_heldout`` from held-out placements) in one phase: while learning a task (``learning``, at an epoch), after PackNet's
pruning (``pruned``), or with the checkpoint kept after a later task (``after``). Every rollout
is stored (:mod:`libero_bench.rollouts.episodes`) and listed in ``results.rollouts``; the round returns
each task's success rate from each kind of start.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from libero_bench.rollouts.jobs import make_job
from libero_bench.runs.folder import HELDOUT, LEARNING, STARTS, STORED, RunFolder, RunResults, rollout_key
from libero_bench.train.plan import RunPlan, resolve_eval_task

if TYPE_CHECKING:
    from libero_bench.algos import Algo
    from libero_bench.policies.base import Policy
    from libero_bench.rollouts.jobs import EvalTask, RolloutJob, RolloutResult
    from libero_bench.rollouts.loop import EnvironmentSlots
    from libero_bench.train.observer import RunObserver

logger = logging.getLogger(__name__)


def run_round(
    environments: EnvironmentSlots,
    policy: Policy,
    jobs: Sequence[RolloutJob],
    on_result: Callable[[RolloutResult], None] | None = None,
) -> list[RolloutResult]:
    """Roll a libero-bench policy (its current weights) out on ``jobs`` in the run's open
    environments; the results in the order of ``jobs``."""
    from libero_bench.rollouts.actors import PolicyActor
    from libero_bench.rollouts.session import roll_out

    found = {job.key: result for job, result in roll_out(environments, PolicyActor(policy), jobs, on_result)}
    return [found[job.key] for job in jobs]


class EvaluationRounds:
    """The evaluation rounds of one run (its plan, folder and progress observer)."""

    def __init__(self, plan: RunPlan, folder: RunFolder, observer: RunObserver) -> None:
        self.plan = plan
        self.folder = folder
        self.observer = observer
        self.environments: EnvironmentSlots | None = None  # set while the run's environments are open
        self._eval_tasks: list[EvalTask] | None = None

    def eval_tasks(self) -> list[EvalTask]:
        """How each task of the run is simulated (resolved once)."""
        if self._eval_tasks is None:
            plan = self.plan
            self._eval_tasks = [
                resolve_eval_task(
                    plan.source,
                    t,
                    i,
                    plan.task_embs[i],
                    heldout=plan.preset.eval_heldout,
                    avoid=plan.training_seeds(i),
                )
                for i, t in enumerate(plan.tasks)
            ]
        return self._eval_tasks

    def join_rollouts(self, results: RunResults) -> None:
        """Join every rollout of ``results`` into ``RUN/rollouts`` (one LeRobot dataset)."""
        from libero_bench.rollouts.session import RolloutSession

        session = RolloutSession(self.folder.root)
        session.records = {r["key"]: r for r in results.rollouts}
        started = time.perf_counter()
        count = session.join(
            self.plan.rollouts_meta(self.folder.root.name),
            {t.name: Path(t.env_ref).read_text() for t in self.eval_tasks()},
        )
        self.folder.append_timing(
            {
                "what": "collect_rollouts",
                "episodes": count,
                "seconds": round(time.perf_counter() - started, 3),
            }
        )
        logger.info("rollout dataset: %d episodes in %s", count, self.folder.rollouts)

    def jobs(
        self, group: Sequence[int], *, phase: str, learned_after: int, epoch: int | None
    ) -> list[RolloutJob]:
        """The rollouts of a round on the tasks at ``group``."""
        p = self.plan.preset
        rollout = p.rollout_settings()
        tasks = self.eval_tasks()
        jobs = []
        counts = {STORED: p.eval_rollouts, HELDOUT: p.eval_heldout}
        for pos, start in ((pos, start) for pos in group for start in STARTS):
            for r in range(counts[start]):
                key = rollout_key(learned_after, phase, pos, r, epoch, start)
                jobs.append(
                    make_job(
                        tasks[pos],
                        r,
                        key=key,
                        settle=rollout.settle,
                        max_steps=rollout.max_steps,
                        image_size=p.image_size,
                        sim_state_width=self.plan.source.sim_state_width,
                        shard_dir=self.folder.shard(key).relative_to(self.folder.root),
                        rrd_path=self.folder.rrd_file(key).relative_to(self.folder.root),
                        tags={
                            "task_position": pos,
                            "learned_after": self.plan.tasks[learned_after].name,
                            "learned_after_position": learned_after,
                            "epoch": epoch,
                            "phase": phase,
                            "run_seed": self.plan.seed,
                            "algo": self.plan.request.algo,
                            "policy": self.plan.request.policy,
                        },
                        start=start,
                        render_quality=rollout.render_quality,
                    )
                )
        return jobs

    def roll_out(self, policy: Policy, jobs: list[RolloutJob], label: str) -> dict[str, RolloutResult]:
        """Run a round's rollouts without moving the training's random streams (in-process
        rollouts build a policy, which draws initial weights), whatever the number of workers."""
        import torch

        assert self.environments is not None, "the run's environments are not open"
        started = time.perf_counter()
        self.observer.eval_start(label, len(jobs))
        numpy_state = np.random.get_state()
        with torch.random.fork_rng(devices=[]):
            outcomes = run_round(self.environments, policy, jobs, on_result=self.observer.rollout_done)
        np.random.set_state(numpy_state)
        self.folder.append_timing(
            {
                "what": "evaluate",
                "label": label,
                **self.environments.describe(),
                "rollouts": len(jobs),
                "steps": sum(o.steps for o in outcomes),
                "seconds": round(time.perf_counter() - started, 3),
            }
        )
        return {o.key: o for o in outcomes}

    def evaluate(
        self,
        results: RunResults,
        algo: Algo,
        policy: Policy,
        positions: Sequence[int],
        *,
        phase: str,
        learned_after: int,
        epoch: int | None,
    ) -> dict[str, list[float]]:
        """Roll out each task of ``positions``; records every rollout in ``results`` and
        returns the tasks' success rates by kind of start (NaN where it ran none). An
        algorithm with a per-task view (PackNet's masks) is evaluated task by task."""
        from libero_bench.algos import Algo as BaseAlgo

        names = [t.name for t in self.eval_tasks()]
        per_task_view = type(algo).set_eval_task is not BaseAlgo.set_eval_task
        groups = [[pos] for pos in positions] if per_task_view else [list(positions)]
        rates: dict[str, dict[int, float]] = {start: {} for start in STARTS}
        where = f"epoch {epoch}" if phase == LEARNING else phase
        for group in groups:
            jobs = self.jobs(group, phase=phase, learned_after=learned_after, epoch=epoch)
            label = f"{names[group[0]]} ({where})" if len(group) == 1 else f"{len(group)} tasks ({where})"
            if per_task_view:
                algo.set_eval_task(group[0])
            try:
                by_key = self.roll_out(policy, jobs, label)
            finally:
                if per_task_view:
                    algo.set_eval_task(None)
            _record(results, jobs, by_key, phase=phase, learned_after=learned_after, epoch=epoch)
            for pos, start in ((pos, start) for pos in group for start in STARTS):
                wins = [
                    by_key[j.key].success for j in jobs if j.tags["task_position"] == pos and j.start == start
                ]
                rates[start][pos] = float(np.mean(wins)) if wins else float("nan")
                if wins:
                    text = f"{names[pos]} ({where}, {start} starts)"
                    self.observer.eval_end(text, rates[start][pos])
                    logger.info("%s: success %.2f of %d", text, rates[start][pos], len(wins))
        return {start: [rates[start][pos] for pos in positions] for start in STARTS}


def _record(
    results: RunResults,
    jobs: list[RolloutJob],
    by_key: dict[str, RolloutResult],
    *,
    phase: str,
    learned_after: int,
    epoch: int | None,
) -> None:
    """List a round's rollouts in ``results`` (replacing those of an interrupted try)."""
    results.rollouts = [r for r in results.rollouts if r["key"] not in by_key]
    for job in jobs:
        o = by_key[job.key]
        results.rollouts.append(
            {
                "key": job.key,
                "task": job.task_name,
                "task_position": job.tags["task_position"],
                "learned_after": learned_after,
                "phase": phase,
                "epoch": epoch,
                "rollout": job.tags["rollout"],
                "start": job.start,
                "init_index": job.init_index,
                "env_seed": job.env_seed,
                "success": o.success,
                "steps": o.steps,
            }
        )
