"""The lifelong-learning protocol of the LIBERO paper: train task after task, evaluate in
simulation, keep the best checkpoint, re-evaluate earlier tasks, resume after interruption.

For each task ``tau`` of the run, in order (see :mod:`libero_bench.algos.base` for the hooks):

1. ``algo.start_task(tau, policy)``; a fresh AdamW and a cosine schedule from ``lr`` to
   ``lr_min`` over the preset's epochs (stepped once per epoch, as upstream LIBERO).
2. Epoch 0 measures the loss without training; epochs 1..E train. At every evaluated epoch
   (0, ``eval_every``, ...) the task is rolled out ``eval_rollouts`` times from fixed init
   states: ``curve[tau, e]``. The weights with the best success (the earliest on ties) are
   kept and loaded when the epochs are done (``keep_best``).
3. ``algo.end_task``. An algorithm with post-task epochs (PackNet) is evaluated on the task
   right after pruning (``pruned[tau]``, not part of the curve), then fine-tuned.
4. The checkpoint (policy + algorithm state + RNG) is saved, then every earlier task ``k``
   is evaluated with it: ``after[tau, k]``; ``after[tau, tau]`` is the best success.

MTL (``algo.needs_all_tasks``) trains once on all tasks' data, evaluates every task at each
evaluated epoch and keeps the checkpoint with the best mean success; ``after[tau, k]`` is
that checkpoint's success on ``k`` for every ``tau``.

A run's folder (:mod:`libero_bench.runs.folder`) holds all it writes. ``results.json`` is rewritten
after every task stage, the checkpoint before it; the same command again goes on after the last
finished stage with the same numbers (each task reseeds from the run seed and its position,
:func:`libero_data.seeding.run_seed`; loaders shuffle from the same seeds). The state after each
finished epoch, post-task epochs included (weights, optimiser, schedule, best weights so far,
results, random streams), is saved too, so an interrupted task goes on after its last finished
epoch with the same numbers. ``RunOptions.stop_after`` ends an invocation after the first tasks.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from libero_bench.rollouts.loop import RolloutResources
from libero_bench.runs.folder import AFTER, LEARNING, PRUNED, STARTS, STORED, RunFolder, RunResults
from libero_bench.runs.training_data import TRAINING_DATA, with_relative_paths, write_training_data
from libero_bench.train.checkpoints import (
    LEARN,
    POST_TASK,
    Training,
    load_checkpoint,
    load_epoch_state,
    load_initial_weights,
    save_checkpoint,
    seed_everything,
)
from libero_bench.train.fitting import loss_epoch, make_optimiser, task_loader, train_epoch
from libero_bench.train.observer import RunObserver
from libero_bench.train.plan import (
    RUNTIME_KEYS,
    RunOptions,
    RunPlan,
    RunRequest,
    check_device,
    check_out_folder,
    machines_worked,
    plan_run,
)
from libero_bench.train.presets import TrainPreset
from libero_bench.train.rounds import EvaluationRounds
from libero_data.errors import SettingsChanged
from libero_data.runtime.files import write_json
from libero_data.runtime.folder import changed_keys
from libero_data.seeding import END_TASK_LOADER, LOADER, TASK_START, WEIGHTS, run_seed

if TYPE_CHECKING:
    from libero_bench.algos import Algo
    from libero_bench.algos.base import DataloaderFactory
    from libero_bench.data.windows import TaskLoader
    from libero_bench.policies.base import Policy

__all__ = ["RunObserver", "RunOptions", "RunRequest", "Trainer", "plan_run", "run_lifelong"]

logger = logging.getLogger(__name__)


class Trainer:
    """Runs (or resumes) one lifelong run in ``out``; see the module docstring."""

    def __init__(
        self,
        plan: RunPlan,
        out: Path,
        options: RunOptions | None = None,
        observer: RunObserver | None = None,
    ) -> None:
        self.plan = plan
        self.preset = plan.preset
        self.folder = RunFolder(Path(out))
        self.options = options or RunOptions()
        self.rounds = EvaluationRounds(plan, self.folder, observer or RunObserver())
        self.device = check_device(self.options.device)
        self.K = len(plan.tasks)
        self.until = plan.tasks_this_time(self.options)
        self.eval_epochs = self.preset.eval_epochs()
        self._results: RunResults | None = None

    @property
    def observer(self) -> RunObserver:
        return self.rounds.observer

    @observer.setter
    def observer(self, observer: RunObserver) -> None:
        self.rounds.observer = observer

    # -- set-up ----------------------------------------------------------------------------------
    def prepare(self) -> RunResults:
        """Create the run folder (or check that it holds this run) and read its results."""
        if self._results is None:
            self._results = self._prepare_folder()
        return self._results

    def _prepare_folder(self) -> RunResults:
        root = self.folder.root
        config = self.plan.config(self.options, root)
        if self.folder.config.is_file():
            self.folder.refuse_pickles()  # whatever the settings: a pickled checkpoint is never opened
            saved = self.folder.read_config()
            if self.folder.results.is_file():
                self.folder.read_results()  # a damaged results.json is refused before anything is written
            preset = TrainPreset.upgrade(saved.get("preset", {}))
            named = with_relative_paths(saved, root)  # an older run named its data absolutely
            changed = changed_keys({**named, "preset": preset}, config, ignore=RUNTIME_KEYS)
            if changed:
                raise SettingsChanged(
                    f"{root} holds a run with a different {changed[0]!r}; resume it with the same settings "
                    "or choose a new run folder",
                    changed=changed,
                )
            runtime = dict(config["runtime"])
            runtime["machines"] = machines_worked(
                saved.get("runtime", {}).get("machines", []), runtime["machines"]
            )
            write_json(self.folder.config, {**saved, "runtime": runtime})
        else:
            check_out_folder(root)
            root.mkdir(parents=True, exist_ok=True)
            write_json(self.folder.config, config)
        if not (root / TRAINING_DATA).is_file():  # what evaluating it needs, should its data go
            write_training_data(root, config)
        if self.folder.results.is_file():
            results = self.folder.read_results()
        else:
            tasks = [{k: t[k] for k in ("position", "name", "language")} for t in config["tasks"]]
            results = RunResults.empty(tasks, self.eval_epochs)
            write_json(self.folder.results, results.to_dict())
        from libero_bench.rollouts.session import RolloutSession

        RolloutSession(self.folder.root).clear_partial_writes()  # an interrupted rollout write
        return results

    def _new_policy(self) -> Policy:
        from libero_bench.policies import build_policy, config_from_dict

        config = config_from_dict(self.plan.policy_config)
        return build_policy(config).to(self.device)

    def _new_algo(self) -> Algo:
        from libero_bench.algos import algo_config_from_dict, build_algo

        algo = build_algo(algo_config_from_dict(self.plan.algo_config))
        algo.task_data = self._end_task_data
        return algo

    def _end_task_data(self, tau: int) -> DataloaderFactory:
        """Task ``tau``'s data as ``end_task`` gets it (every task's for MTL)."""
        loader = self._loader(
            list(range(self.K)) if self.plan.needs_all_tasks else [tau],
            seed=run_seed(self.plan.seed, tau, END_TASK_LOADER),
        )
        return lambda: iter(loader)

    def _save_checkpoint(self, task: int, stage: str, policy: Policy, algo: Algo) -> None:
        save_checkpoint(
            self.folder.checkpoint(task),
            task=task,
            stage=stage,
            policy_config=self.plan.policy_config,
            policy=policy,
            algo=algo,
        )

    def _write_results(self, results: RunResults) -> None:
        write_json(self.folder.results, results.to_dict())

    def _loader(self, task_positions: Sequence[int], seed: int) -> TaskLoader:
        return task_loader(
            self.plan, task_positions, seed=seed, device=self.device, workers=self.options.loader_workers
        )

    def _fit_epoch(
        self, algo: Algo, policy: Policy, loader: TaskLoader, optimiser: Any, label: str
    ) -> dict[str, float]:
        """One epoch, timed and logged; without an optimiser (epoch 0) the loss without training."""
        started = time.perf_counter()
        self.observer.train_start(label, len(loader))
        if optimiser is None:
            terms = loss_epoch(policy, loader, self.observer.train_step)
        else:
            clip = self.preset.grad_clip
            terms = train_epoch(algo, policy, loader, optimiser, clip, label, self.observer.train_step)
        seconds = round(time.perf_counter() - started, 3)
        self.folder.append_timing(
            {"what": "epoch", "label": label, "batches": len(loader), "seconds": seconds}
        )
        logger.info("%s: loss %.4f", label, terms["total"])
        return terms

    # -- the protocol ------------------------------------------------------------------------------
    def run(self) -> RunResults:
        """Run or resume; returns the final results (also in ``results.json``)."""
        seed_everything(run_seed(self.plan.seed, 0, WEIGHTS))  # the initial weights depend on the seed only
        policy = self._new_policy()
        algo = self._new_algo()
        results = self.prepare()
        self.folder.work.mkdir(parents=True, exist_ok=True)
        # One environment per worker, all stepping together: a run resumed after an interruption
        # then batches its policy as the uninterrupted run did and its rollouts stay the same bit
        # for bit (tests/bench/test_bench_run.py). With halves taking turns the resumed run's
        # batches differed in the actions' last bits (docs/evaluation.md, "Which outcomes may differ").
        executor = self.options.executor
        with RolloutResources(executor, batch_size=executor.workers).open(self.folder.root) as environments:
            self.rounds.environments = environments
            try:
                if self.plan.needs_all_tasks:
                    self._run_multitask(results, policy, algo)
                else:
                    self._run_sequential(results, policy, algo)
            finally:
                self.rounds.environments = None
        if results.finished_tasks < self.K:
            return results  # stopped after the first tasks (``stop_after``): nothing to join yet
        if not results.complete:
            self.collect_rollouts(results)
            results.complete = True
            self._write_results(results)
        elif not (self.folder.rollouts / "meta" / "info.json").is_file():
            self.collect_rollouts(results)
        return results

    def _resume_point(self, results: RunResults, policy: Policy, algo: Algo, units: int) -> int:
        """Load the newest checkpoint; returns the first unit (task) not done."""
        done = results.finished_tasks
        if done >= units:
            return units
        if results.stage[done] == "trained" and self.folder.checkpoint(done).is_file():
            load_checkpoint(self.folder.checkpoint(done), policy, algo)
            logger.info("resuming %s at the evaluations after task %d", self.folder.root, done)
        elif done > 0:
            load_checkpoint(self.folder.checkpoint(done - 1), policy, algo)
            logger.info("resuming %s after task %d", self.folder.root, done - 1)
        elif self.plan.request.init_checkpoint is not None:
            self._initial_weights(policy)
        return done

    def _initial_weights(self, policy: Policy) -> None:
        request = self.plan.request
        assert request.init_checkpoint is not None
        load_initial_weights(request.init_checkpoint, policy, self.device, request.policy)

    def _run_sequential(self, results: RunResults, policy: Policy, algo: Algo) -> None:
        start = self._resume_point(results, policy, algo, self.K)
        for tau in range(start, self.until):
            task = self.plan.tasks[tau]
            self.observer.phase(f"task {tau + 1}/{self.K}: {task.language}")
            if results.stage[tau] != "trained":
                self._learn_task(results, policy, algo, tau)
            # every earlier task, with the checkpoint kept after this one
            if tau > 0:
                rates = self.rounds.evaluate(
                    results, algo, policy, list(range(tau)), phase=AFTER, learned_after=tau, epoch=None
                )
                for kind, values in rates.items():
                    results.after_of(kind)[tau][:tau] = values
            results.stage[tau] = "done"
            self._write_results(results)

    def _learn_task(self, results: RunResults, policy: Policy, algo: Algo, tau: int) -> None:
        # interrupted in its post-task epochs: the task's epochs, pruning and evaluation are done
        post = load_epoch_state(self.folder.epoch_state(tau), [tau], phase=POST_TASK)
        if post is None:
            seed_everything(run_seed(self.plan.seed, tau, TASK_START))
            algo.start_task(tau, policy)
        loader = self._loader([tau], seed=run_seed(self.plan.seed, tau, LOADER))
        if post is None:
            self._epochs(results, policy, algo, loader, [tau], learned_after=tau)
            for start in STARTS:  # the kept checkpoint's success on the task it learned
                results.after_of(start)[tau][tau] = results.kept_success(tau, start)
            algo.end_task(tau, self._end_task_data(tau))
            if algo.post_task_epochs > 0:  # the pruned network before fine-tuning (PackNet); not in the curve
                pruned = self.rounds.evaluate(
                    results, algo, policy, [tau], phase=PRUNED, learned_after=tau, epoch=None
                )
                for start, (rate,) in pruned.items():
                    results.pruned_of(start)[tau] = None if math.isnan(rate) else rate
        if algo.post_task_epochs > 0:
            results.post_losses[tau] = self._post_task(results, policy, algo, loader, tau, post)
        logger.info("task %d kept the weights of epoch %s", tau, results.best_epoch[tau])
        self._save_checkpoint(tau, "trained", policy, algo)
        self.folder.epoch_state(tau).unlink(missing_ok=True)
        results.stage[tau] = "trained"
        self._write_results(results)

    def _epochs(
        self,
        results: RunResults,
        policy: Policy,
        algo: Algo,
        loader: TaskLoader,
        positions: list[int],
        *,
        learned_after: int,
    ) -> int | None:
        """Epoch 0..E with evaluations; loads the best weights; returns the kept epoch."""
        p = self.preset
        optimiser, scheduler = make_optimiser(policy, p, p.epochs)
        training = Training(policy, algo, optimiser, scheduler)
        best_rate = -math.inf
        best_state: dict[str, Any] | None = None
        best_epoch: int | None = None
        losses: list[dict[str, float]] = []
        name = self.plan.tasks[positions[0]].name if len(positions) == 1 else "all tasks"
        state_path = self.folder.epoch_state(positions[0])
        first = 0
        saved = load_epoch_state(state_path, positions)
        if saved is not None:  # an interrupted task: go on after its last finished epoch
            first = saved["epoch"] + 1
            best_rate, best_epoch, best_state, losses = (
                saved[k] for k in ("best_rate", "best_epoch", "best_state", "losses")
            )
            training.restore(saved, results)
            logger.info("%s: resuming after epoch %d of %d", name, saved["epoch"], p.epochs)
        for epoch in range(first, p.epochs + 1):
            loader.set_epoch(epoch)
            label = f"{name}: epoch {epoch}/{p.epochs}"
            terms = self._fit_epoch(algo, policy, loader, optimiser if epoch > 0 else None, label)
            losses.append({"epoch": epoch, **terms})
            if epoch in self.eval_epochs:
                e = self.eval_epochs.index(epoch)
                rates = self.rounds.evaluate(
                    results, algo, policy, positions, phase=LEARNING, learned_after=learned_after, epoch=epoch
                )
                for start, values in rates.items():
                    for pos, rate in zip(positions, values, strict=True):
                        results.curve_of(start)[pos][e] = rate
                # Checkpoints are chosen on the stored starts (LIBERO's protocol); held-out
                # starts take no part in the choice, so their success stays an unbiased estimate.
                score = float(np.mean(rates[STORED]))
                if p.keep_best and score > best_rate:  # the earliest best, as upstream LIBERO
                    best_rate, best_epoch = score, epoch
                    best_state = {k: v.detach().clone() for k, v in policy.state_dict().items()}
            if scheduler is not None and epoch > 0:
                scheduler.step()
            training.save(
                state_path,
                LEARN,
                positions,
                epoch,
                results,
                losses=losses,
                best_rate=best_rate,
                best_epoch=best_epoch,
                best_state=best_state,
            )
        if not p.keep_best:
            best_epoch = p.epochs  # keep the last weights
        elif best_state is not None:
            policy.load_state_dict(best_state)
        for pos in positions:
            results.losses[pos] = losses
            results.best_epoch[pos] = best_epoch
        return best_epoch

    def _post_task(
        self,
        results: RunResults,
        policy: Policy,
        algo: Algo,
        loader: TaskLoader,
        tau: int,
        saved: dict[str, Any] | None,
    ) -> list[dict[str, float]]:
        """The post-task epochs (PackNet's fine-tuning after pruning), each saved as it ends."""
        epochs = algo.post_task_epochs
        self.observer.phase(f"task {tau + 1}/{self.K}: {epochs} post-task epochs")
        optimiser, scheduler = make_optimiser(policy, self.preset, epochs)
        losses: list[dict[str, float]] = saved["losses"] if saved is not None else []
        training = Training(policy, algo, optimiser, scheduler)
        if saved is not None:
            training.restore(saved, results)
            logger.info("%s: resuming after post-task epoch %d", self.plan.tasks[tau].name, saved["epoch"])
        for epoch in range(len(losses) + 1, epochs + 1):
            loader.set_epoch(self.preset.epochs + epoch)
            label = f"{self.plan.tasks[tau].name}: post-task epoch {epoch}/{epochs}"
            terms = self._fit_epoch(algo, policy, loader, optimiser, label)
            losses.append({"epoch": epoch, **terms})
            if scheduler is not None:
                scheduler.step()
            training.save(self.folder.epoch_state(tau), POST_TASK, [tau], epoch, results, losses=losses)
        return losses

    def _run_multitask(self, results: RunResults, policy: Policy, algo: Algo) -> None:
        everything = list(range(self.K))
        start = self._resume_point(results, policy, algo, 1)
        if start >= 1:
            return
        self.observer.phase(f"multitask: {self.K} tasks at once")
        if results.stage[0] != "trained":
            seed_everything(run_seed(self.plan.seed, 0, TASK_START))
            algo.start_task(0, policy)
            loader = self._loader(everything, seed=run_seed(self.plan.seed, 0, LOADER))
            best = self._epochs(results, policy, algo, loader, everything, learned_after=0)
            algo.end_task(0, self._end_task_data(0))
            self._save_checkpoint(0, "trained", policy, algo)
            self.folder.epoch_state(0).unlink(missing_ok=True)
            kept = self.eval_epochs.index(best) if best is not None else len(self.eval_epochs) - 1
            for tau in range(self.K):
                for k in range(self.K):
                    for kind in STARTS:
                        results.after_of(kind)[tau][k] = results.curve_of(kind)[k][kept]
        results.stage = ["done"] * self.K
        self._write_results(results)

    # -- the rollout dataset -------------------------------------------------------------------------
    def collect_rollouts(self, results: RunResults) -> None:
        """Join every rollout of ``results`` into ``RUN/rollouts`` (one LeRobot dataset)."""
        self.rounds.join_rollouts(results)


def run_lifelong(
    request: RunRequest,
    out: str | Path,
    options: RunOptions | None = None,
    observer: RunObserver | None = None,
) -> RunResults:
    """Plan and run (or resume) a lifelong run into ``out``."""
    plan = plan_run(request)
    return Trainer(plan, Path(out), options, observer).run()
