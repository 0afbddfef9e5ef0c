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

Everything a run writes lives in its folder (:mod:`libero_bench.run_files`). ``results.json``
is rewritten after every task stage, the checkpoint before it; running the same command
again continues after the last finished stage with the same numbers (every task reseeds
torch from the run seed and the task's position; loaders shuffle from the same seeds).
"""

from __future__ import annotations

import dataclasses
import logging
import math
import platform
import random
import shutil
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from libero_bench.data import DemoDataset, DemoTask
from libero_bench.presets import TrainPreset
from libero_bench.run_files import (
    AFTER,
    LEARNING,
    PRUNED,
    RUN_FORMAT,
    RunFolder,
    RunResults,
    rollout_key,
    write_json,
)
from libero_data.numerics import machine_fingerprint

if TYPE_CHECKING:
    import torch

    from libero_bench.algos import Algo
    from libero_bench.data import TaskLoader
    from libero_bench.evaluate import EvalTask, Evaluator, RolloutResult
    from libero_bench.policies import Policy

logger = logging.getLogger(__name__)

#: config.json keys that may change between a run and its resumption
RUNTIME_KEYS = ("runtime",)


class RunObserver:
    """Progress callbacks (the CLI draws bars from them); every method is optional."""

    def phase(self, text: str) -> None:
        """A new stage of the run starts (a task, a post-task fine-tuning ...)."""

    def train_start(self, label: str, batches: int) -> None:
        """An epoch of ``batches`` batches starts."""

    def train_step(self, loss: float) -> None:
        """One optimiser step (or loss batch at epoch 0) is done."""

    def eval_start(self, label: str, rollouts: int) -> None:
        """An evaluation round of ``rollouts`` rollouts starts."""

    def rollout_done(self, result: RolloutResult) -> None:
        """One rollout finished."""

    def eval_end(self, label: str, success: float) -> None:
        """An evaluation round finished with this success rate."""


@dataclass(frozen=True)
class RunRequest:
    """What to run (the parts that define the run's results)."""

    data: Path
    algo: str
    policy: str
    preset: TrainPreset
    tasks: tuple[str, ...] | None = None  # names or suite indices; None: every task of the dataset
    order: int | None = None  # an upstream task order (10-task selections)
    seed: int | None = None  # None: the preset's seed
    init_checkpoint: Path | None = None


@dataclass(frozen=True)
class RunOptions:
    """How to run it (free to change when resuming)."""

    device: str = "cpu"
    workers: int = 1  # rollout worker processes; 0 = in this process
    loader_workers: int = 0  # DataLoader worker processes
    executor: str = "local"  # rollouts in local processes or on Ray ("ray")
    ray_address: str | None = None  # a Ray cluster to join; None: start Ray here


# -- planning ------------------------------------------------------------------------------------
def select_tasks(source: DemoDataset, tasks: Sequence[str] | None, order: int | None) -> list[DemoTask]:
    """The run's tasks in training order: ``tasks`` (names or suite indices) or all of the
    dataset's, then permuted by upstream order ``order``."""
    from libero_data.tasks import task_orders

    if tasks:
        chosen = [source.task(t) for t in tasks]
        names = [t.name for t in chosen]
        if len(set(names)) != len(names):
            raise ValueError("--tasks lists a task twice")
    else:
        chosen = list(source.tasks)
    if order is not None:
        orders = task_orders()
        if not 0 <= order < len(orders):
            raise ValueError(f"task order must be in 0..{len(orders) - 1}, got {order}")
        permutation = orders[order]
        if len(chosen) != len(permutation):
            raise ValueError(
                f"upstream task orders are for 10 tasks, but the run has {len(chosen)}; "
                "choose 10 tasks or leave out --order"
            )
        chosen = [chosen[i] for i in permutation]
    return chosen


def _versions() -> dict[str, str]:
    from importlib import metadata

    out = {"python": platform.python_version()}
    for name in ("libero-data", "torch", "lerobot", "mujoco", "robosuite", "numpy"):
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            continue
    return out


def _algo_for(name: str, size: str, seed: int) -> Algo:
    from libero_bench.algos import ALGOS

    cls = ALGOS.get(name)
    config = cls.config_class() if size == "paper" else cls.config_class.smoke()
    if any(f.name == "seed" for f in dataclasses.fields(config)):
        config = dataclasses.replace(config, seed=seed)  # type: ignore[call-arg]
    return cls(config)


@dataclass
class RunPlan:
    """A resolved request: dataset, tasks, embeddings, configs."""

    request: RunRequest
    source: DemoDataset
    tasks: list[DemoTask]
    task_embs: np.ndarray
    preset: TrainPreset
    seed: int
    policy_config: dict[str, Any]
    algo_config: dict[str, Any]
    needs_all_tasks: bool

    def config(self, options: RunOptions) -> dict[str, Any]:
        req = self.request
        preset = self.preset
        demos = preset.demos_per_task
        return {
            "format": RUN_FORMAT,
            "data": str(self.source.root.resolve()),
            "dataset": {
                "repo_id": self.source.repo_id,
                "suite": self.source.suite,
                "episodes": len(self.source.episode_meta),
                "image_size": self.source.image_size,
            },
            "tasks": [
                {
                    "position": i,
                    "name": t.name,
                    "language": t.language,
                    "suite_index": t.suite_index,
                    "episodes": list(t.episodes[:demos] if demos else t.episodes),
                }
                for i, t in enumerate(self.tasks)
            ],
            "order": req.order,
            "algo": req.algo,
            "algo_config": self.algo_config,
            "policy": req.policy,
            "policy_config": self.policy_config,
            "preset": preset.to_dict(),
            "seed": self.seed,
            "init_checkpoint": str(req.init_checkpoint.resolve()) if req.init_checkpoint else None,
            "runtime": {
                "device": options.device,
                "workers": options.workers,
                "executor": options.executor,
                "versions": _versions(),
                # The numeric path of the machines that worked on the run (a resumed run adds its
                # own): rollouts replay bit for bit only on the same one (libero_data.numerics).
                "machines": [machine_fingerprint()],
            },
        }


def plan_run(request: RunRequest) -> RunPlan:
    """Check the request and resolve it (reads the dataset's metadata, embeds the tasks)."""
    from libero_bench.algos import ALGOS
    from libero_bench.language import encode_tasks
    from libero_bench.policies import POLICIES, policy_config

    if request.algo not in ALGOS:
        raise ValueError(f"unknown algorithm {request.algo!r}; known: {', '.join(ALGOS.names())}")
    if request.policy not in POLICIES:
        raise ValueError(f"unknown policy {request.policy!r}; known: {', '.join(POLICIES.names())}")
    if request.init_checkpoint is not None and not request.init_checkpoint.is_file():
        raise ValueError(f"--init-checkpoint {request.init_checkpoint} does not exist")
    source = DemoDataset(request.data)
    tasks = select_tasks(source, request.tasks, request.order)
    seed = request.preset.seed if request.seed is None else request.seed
    preset = request.preset.replace(seed=seed)
    embs = encode_tasks([t.language for t in tasks], preset.language_encoder)
    pconfig = policy_config(
        request.policy,
        preset.policy_size,
        image_size=preset.image_size,
        window=preset.window,
        task_emb_dim=int(embs.shape[1]),
    )
    algo = _algo_for(request.algo, preset.algo_size, seed)
    return RunPlan(
        request=request,
        source=source,
        tasks=tasks,
        task_embs=embs,
        preset=preset,
        seed=seed,
        policy_config=pconfig.to_dict(),
        algo_config=algo.config.to_dict(),
        needs_all_tasks=type(algo).needs_all_tasks,
    )


def _identity(config: Mapping[str, Any]) -> dict[str, Any]:
    return {k: v for k, v in config.items() if k not in RUNTIME_KEYS}


def _first_difference(a: Mapping[str, Any], b: Mapping[str, Any]) -> str:
    for key in sorted(set(a) | set(b)):
        if a.get(key) != b.get(key):
            return key
    return ""


def check_device(name: str) -> torch.device:
    """``cpu`` or ``cuda[:N]`` (``ValueError`` for anything else or a missing GPU)."""
    import torch

    try:
        device = torch.device(name)
    except RuntimeError:
        raise ValueError(f"--device must be cpu or cuda, got {name!r}") from None
    if device.type not in ("cpu", "cuda"):
        raise ValueError(f"--device must be cpu or cuda, got {name!r}")
    if device.type == "cuda" and not torch.cuda.is_available():
        raise ValueError("--device cuda was asked for, but CUDA is not available here")
    return device


def check_out_folder(out: Path) -> None:
    """``ValueError`` unless ``out`` is new, empty or a libero-bench run folder."""
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out} is a file, not a folder")
    if out.is_dir() and not RunFolder(out).config.is_file() and any(out.iterdir()):
        raise ValueError(f"{out} is not empty and is not a libero-bench run; choose a new --out folder")


# -- the trainer ------------------------------------------------------------------------------------
def _seed_everything(seed: int) -> None:
    import torch

    torch.manual_seed(seed)
    np.random.seed(seed % 2**32)
    random.seed(seed)


def _mix(*parts: int) -> int:
    """A deterministic 63-bit seed from integers."""
    value = 0x9E3779B97F4A7C15
    for p in parts:
        value = (value ^ (int(p) & 0xFFFFFFFFFFFFFFFF)) * 0xBF58476D1CE4E5B9 & 0xFFFFFFFFFFFFFFFF
        value ^= value >> 31
    return value & 0x7FFFFFFFFFFFFFFF


def _rng_state() -> dict[str, Any]:
    import torch

    return {"torch": torch.get_rng_state(), "numpy": np.random.get_state(), "python": random.getstate()}


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
        self.observer = observer or RunObserver()
        self.device = self._device(self.options.device)
        self.K = len(plan.tasks)
        self.eval_epochs = self.preset.eval_epochs()
        self._policy: Policy | None = None
        self._algo: Algo | None = None
        self._evaluator: Evaluator | None = None
        self._eval_tasks: list[EvalTask] | None = None
        self._results: RunResults | None = None

    @staticmethod
    def _device(name: str) -> torch.device:
        return check_device(name)

    # -- set-up ----------------------------------------------------------------------------------
    def prepare(self) -> RunResults:
        """Create the run folder (or check that it holds this run) and read its results."""
        if self._results is None:
            self._results = self._prepare_folder()
        return self._results

    def _prepare_folder(self) -> RunResults:
        config = self.plan.config(self.options)
        root = self.folder.root
        if self.folder.config.is_file():
            saved = self.folder.read_config()
            if _identity(saved) != _identity(config):
                key = _first_difference(_identity(saved), _identity(config))
                raise ValueError(
                    f"{root} holds a run with a different {key!r}; resume it with the same settings "
                    "or choose a new --out folder"
                )
            runtime = dict(config["runtime"])
            earlier = saved.get("runtime", {}).get("machines", [])
            keys = {m.get("numeric_key") for m in earlier}
            runtime["machines"] = earlier + [
                m for m in runtime["machines"] if m.get("numeric_key") not in keys
            ]
            write_json(self.folder.config, {**saved, "runtime": runtime})
        else:
            check_out_folder(root)
            root.mkdir(parents=True, exist_ok=True)
            write_json(self.folder.config, config)
        if self.folder.results.is_file():
            results = self.folder.read_results()
        else:
            tasks = [{k: t[k] for k in ("position", "name", "language")} for t in config["tasks"]]
            results = RunResults.empty(tasks, self.eval_epochs)
            write_json(self.folder.results, results.to_dict())
        # leftovers of an interrupted rollout write
        if self.folder.shards.is_dir():
            for leftover in self.folder.shards.glob("*.tmp-*"):
                shutil.rmtree(leftover, ignore_errors=True)
        return results

    def _eval_task_list(self) -> list[EvalTask]:
        if self._eval_tasks is None:
            self._eval_tasks = [
                resolve_eval_task(self.plan.source, t, i, self.plan.task_embs[i], self.folder.work)
                for i, t in enumerate(self.plan.tasks)
            ]
        return self._eval_tasks

    def _new_policy(self) -> Policy:
        from libero_bench.policies import POLICIES, config_from_dict

        config = config_from_dict(self.plan.policy_config)
        return POLICIES.get(config.name).from_config(config).to(self.device)

    def _new_algo(self) -> Algo:
        from libero_bench.algos import ALGOS, algo_config_from_dict

        config = algo_config_from_dict(self.plan.algo_config)
        return ALGOS.get(config.name)(config)

    def _load_init_checkpoint(self, policy: Policy) -> None:
        import torch

        path = self.plan.request.init_checkpoint
        if path is None:
            return
        data = torch.load(path, map_location=self.device, weights_only=False)
        state = data.get("policy", data) if isinstance(data, dict) else data
        try:
            policy.load_state_dict(state)
        except RuntimeError as exc:
            first = str(exc).strip().splitlines()[0]
            raise ValueError(
                f"--init-checkpoint {path} does not fit the {self.plan.request.policy} policy: {first}"
            ) from None
        logger.info("policy initialised from %s", path)

    def _save_checkpoint(self, task: int, stage: str, policy: Policy, algo: Algo) -> None:
        import torch

        path = self.folder.checkpoint(task)
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(path.name + ".tmp")
        torch.save(
            {
                "format": RUN_FORMAT,
                "task": task,
                "stage": stage,
                "policy_config": self.plan.policy_config,
                "policy": {k: v.detach().cpu() for k, v in policy.state_dict().items()},
                "algo": algo.state_dict(),
                "rng": _rng_state(),
            },
            tmp,
        )
        tmp.replace(path)

    def _load_checkpoint(self, task: int, policy: Policy, algo: Algo) -> None:
        import torch

        data = torch.load(self.folder.checkpoint(task), map_location="cpu", weights_only=False)
        policy.load_state_dict(data["policy"])
        algo.load_state_dict(data["algo"])
        algo.bind(policy)

    def _write_results(self, results: RunResults) -> None:
        write_json(self.folder.results, results.to_dict())

    # -- data --------------------------------------------------------------------------------------
    def _loader(self, task_positions: Sequence[int], seed: int, shuffle: bool = True) -> TaskLoader:
        from libero_bench.data import TaskLoader, WindowDataset

        demos = self.preset.demos_per_task
        episodes: list[int] = []
        ids: list[int] = []
        for pos in task_positions:
            task = self.plan.tasks[pos]
            chosen = task.episodes[:demos] if demos else task.episodes
            episodes.extend(chosen)
            ids.extend([pos] * len(chosen))
        dataset = WindowDataset(
            self.plan.source, episodes, ids, self.plan.task_embs, self.preset.window, self.preset.image_size
        )
        if len(dataset) == 0:
            names = ", ".join(self.plan.tasks[p].name for p in task_positions)
            raise ValueError(
                f"no training windows for {names}: every episode is shorter than {self.preset.window} frames"
            )
        return TaskLoader(
            dataset,
            self.preset.batch_size,
            self.device,
            seed=seed,
            shuffle=shuffle,
            workers=self.options.loader_workers,
        )

    # -- one epoch ---------------------------------------------------------------------------------
    def _train_epoch(
        self, algo: Algo, policy: Policy, loader: TaskLoader, optimiser: Any, label: str
    ) -> dict[str, float]:
        import torch

        policy.train()
        sums: dict[str, float] = {}
        batches = 0
        self.observer.train_start(label, len(loader))
        for batch in loader:
            terms = algo.loss(batch)
            total = torch.stack([t for t in terms.values()]).sum()
            optimiser.zero_grad(set_to_none=True)
            total.backward()
            torch.nn.utils.clip_grad_norm_(policy.parameters(), self.preset.grad_clip)
            optimiser.step()
            algo.after_step()
            for name, value in terms.items():
                sums[name] = sums.get(name, 0.0) + float(value.detach())
            loss = float(total.detach())
            if not math.isfinite(loss):
                raise FloatingPointError(f"{label}: the training loss is {loss}")
            sums["total"] = sums.get("total", 0.0) + loss
            batches += 1
            self.observer.train_step(loss)
        return {k: v / batches for k, v in sums.items()}

    def _loss_epoch(self, policy: Policy, loader: TaskLoader, label: str) -> dict[str, float]:
        """Epoch 0: the behaviour-cloning loss of the untouched policy (no updates)."""
        import torch

        from libero_bench.policies import eval_mode

        total = 0.0
        batches = 0
        self.observer.train_start(label, len(loader))
        with torch.no_grad(), eval_mode(policy):
            for batch in loader:
                loss = float(policy.loss(batch))
                total += loss
                batches += 1
                self.observer.train_step(loss)
        mean = total / batches
        return {"bc": mean, "total": mean}

    def _optimiser(self, policy: Policy, epochs: int) -> tuple[Any, Any]:
        import torch

        p = self.preset
        optimiser = torch.optim.AdamW(
            policy.parameters(), lr=p.lr, betas=p.betas, weight_decay=p.weight_decay
        )
        scheduler = None
        if p.scheduler == "cosine":
            scheduler = torch.optim.lr_scheduler.CosineAnnealingLR(
                optimiser, T_max=max(epochs, 1), eta_min=p.lr_min
            )
        return optimiser, scheduler

    # -- evaluation --------------------------------------------------------------------------------
    def _evaluate(
        self,
        results: RunResults,
        algo: Algo,
        policy: Policy,
        positions: Sequence[int],
        *,
        phase: str,
        learned_after: int,
        epoch: int | None,
    ) -> list[float]:
        """Roll out each task of ``positions``; returns their success rates."""
        import torch

        from libero_bench.algos import Algo as BaseAlgo
        from libero_bench.evaluate import make_job

        assert self._evaluator is not None
        p = self.preset
        tasks = self._eval_task_list()
        per_task_view = type(algo).set_eval_task is not BaseAlgo.set_eval_task
        groups = [[pos] for pos in positions] if per_task_view else [list(positions)]
        rates: dict[int, float] = {}
        where = f"epoch {epoch}" if phase == LEARNING else phase
        for group in groups:
            jobs = []
            for pos in group:
                for r in range(p.eval_rollouts):
                    key = rollout_key(learned_after, phase, pos, r, epoch)
                    jobs.append(
                        make_job(
                            tasks[pos],
                            r,
                            key=key,
                            settle=p.eval_settle,
                            max_steps=p.eval_max_steps,
                            image_size=p.image_size,
                            sim_state_width=self.plan.source.sim_state_width,
                            shard_dir=self.folder.shard(key),
                            rrd_path=self.folder.rrd_file(key),
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
                        )
                    )
            label = (
                f"{tasks[group[0]].name} ({where})" if len(group) == 1 else f"{len(group)} tasks ({where})"
            )
            if per_task_view:
                algo.set_eval_task(group[0])
            try:
                started = time.perf_counter()
                self.observer.eval_start(label, len(jobs))
                # rollouts must not move the training's random streams (in-process rollouts
                # build a policy, which draws initial weights), whatever the number of workers
                numpy_state = np.random.get_state()
                with torch.random.fork_rng(devices=[]):
                    outcomes = self._evaluator.run(policy, jobs, on_result=self.observer.rollout_done)
                np.random.set_state(numpy_state)
            finally:
                if per_task_view:
                    algo.set_eval_task(None)
            seconds = time.perf_counter() - started
            steps = sum(o.steps for o in outcomes)
            self.folder.append_timing(
                {
                    "what": "evaluate",
                    "label": label,
                    "rollouts": len(jobs),
                    "steps": steps,
                    "seconds": round(seconds, 3),
                }
            )
            by_key = {o.key: o for o in outcomes}
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
                        "init_index": job.init_index,
                        "env_seed": job.env_seed,
                        "success": o.success,
                        "steps": o.steps,
                    }
                )
            for pos in group:
                wins = [by_key[j.key].success for j in jobs if j.tags["task_position"] == pos]
                rates[pos] = float(np.mean(wins))
                self.observer.eval_end(f"{tasks[pos].name} ({where})", rates[pos])
                logger.info("%s (%s): success %.2f", tasks[pos].name, where, rates[pos])
        return [rates[pos] for pos in positions]

    # -- the protocol ------------------------------------------------------------------------------
    def run(self) -> RunResults:
        """Run or resume; returns the final results (also in ``results.json``)."""
        from libero_bench.evaluate import Evaluator

        results = self.prepare()
        _seed_everything(_mix(self.plan.seed, 0, 0))  # the initial weights depend on the seed only
        policy = self._new_policy()
        algo = self._new_algo()
        self._policy, self._algo = policy, algo
        self.folder.work.mkdir(parents=True, exist_ok=True)
        with Evaluator(
            self.options.workers,
            self.folder.work,
            executor=self.options.executor,
            ray_address=self.options.ray_address,
        ) as evaluator:
            self._evaluator = evaluator
            try:
                if self.plan.needs_all_tasks:
                    self._run_multitask(results, policy, algo)
                else:
                    self._run_sequential(results, policy, algo)
            finally:
                self._evaluator = None
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
            self._load_checkpoint(done, policy, algo)
            logger.info("resuming %s at the evaluations after task %d", self.folder.root, done)
        elif done > 0:
            self._load_checkpoint(done - 1, policy, algo)
            logger.info("resuming %s after task %d", self.folder.root, done - 1)
        else:
            self._load_init_checkpoint(policy)
        return done

    def _run_sequential(self, results: RunResults, policy: Policy, algo: Algo) -> None:
        start = self._resume_point(results, policy, algo, self.K)
        for tau in range(start, self.K):
            task = self.plan.tasks[tau]
            self.observer.phase(f"task {tau + 1}/{self.K}: {task.language}")
            if results.stage[tau] != "trained":
                self._learn_task(results, policy, algo, tau)
            # every earlier task, with the checkpoint kept after this one
            if tau > 0:
                rates = self._evaluate(
                    results, algo, policy, list(range(tau)), phase=AFTER, learned_after=tau, epoch=None
                )
                for k, rate in enumerate(rates):
                    results.after[tau][k] = rate
            results.stage[tau] = "done"
            self._write_results(results)

    def _learn_task(self, results: RunResults, policy: Policy, algo: Algo, tau: int) -> None:
        _seed_everything(_mix(self.plan.seed, tau, 1))
        algo.start_task(tau, policy)
        loader = self._loader([tau], seed=_mix(self.plan.seed, tau, 2))
        best = self._epochs(results, policy, algo, loader, [tau], learned_after=tau)
        results.after[tau][tau] = max(v for v in results.curve[tau] if not math.isnan(v))
        factory_loader = self._loader([tau], seed=_mix(self.plan.seed, tau, 3))
        algo.end_task(tau, lambda: iter(factory_loader))
        if algo.post_task_epochs > 0:
            # the pruned network before fine-tuning (PackNet); not part of the learning curve
            (rate,) = self._evaluate(
                results, algo, policy, [tau], phase=PRUNED, learned_after=tau, epoch=None
            )
            results.pruned[tau] = rate
            results.post_losses[tau] = self._post_task(policy, algo, loader, tau)
        logger.info("task %d kept the weights of epoch %s", tau, best)
        self._save_checkpoint(tau, "trained", policy, algo)
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
        optimiser, scheduler = self._optimiser(policy, p.epochs)
        best_rate = -math.inf
        best_state: dict[str, Any] | None = None
        best_epoch: int | None = None
        losses: list[dict[str, float]] = []
        name = self.plan.tasks[positions[0]].name if len(positions) == 1 else "all tasks"
        for epoch in range(p.epochs + 1):
            loader.set_epoch(epoch)
            started = time.perf_counter()
            label = f"{name}: epoch {epoch}/{p.epochs}"
            if epoch == 0:
                terms = self._loss_epoch(policy, loader, label)
            else:
                terms = self._train_epoch(algo, policy, loader, optimiser, label)
            losses.append({"epoch": epoch, **terms})
            self.folder.append_timing(
                {
                    "what": "epoch",
                    "label": label,
                    "batches": len(loader),
                    "seconds": round(time.perf_counter() - started, 3),
                }
            )
            logger.info("%s: loss %.4f", label, terms["total"])
            if epoch in self.eval_epochs:
                e = self.eval_epochs.index(epoch)
                rates = self._evaluate(
                    results, algo, policy, positions, phase=LEARNING, learned_after=learned_after, epoch=epoch
                )
                for pos, rate in zip(positions, rates, strict=True):
                    results.curve[pos][e] = rate
                score = float(np.mean(rates))
                if p.keep_best and score > best_rate:  # the earliest best, as upstream LIBERO
                    best_rate, best_epoch = score, epoch
                    best_state = {k: v.detach().clone() for k, v in policy.state_dict().items()}
            if scheduler is not None and epoch > 0:
                scheduler.step()
        if not p.keep_best:
            best_epoch = p.epochs  # keep the last weights
        elif best_state is not None:
            policy.load_state_dict(best_state)
        for pos in positions:
            results.losses[pos] = losses
            results.best_epoch[pos] = best_epoch
        return best_epoch

    def _post_task(self, policy: Policy, algo: Algo, loader: TaskLoader, tau: int) -> list[dict[str, float]]:
        epochs = algo.post_task_epochs
        self.observer.phase(f"task {tau + 1}/{self.K}: {epochs} post-task epochs")
        optimiser, scheduler = self._optimiser(policy, epochs)
        losses = []
        for epoch in range(1, epochs + 1):
            loader.set_epoch(self.preset.epochs + epoch)
            label = f"{self.plan.tasks[tau].name}: post-task epoch {epoch}/{epochs}"
            terms = self._train_epoch(algo, policy, loader, optimiser, label)
            losses.append({"epoch": epoch, **terms})
            if scheduler is not None:
                scheduler.step()
        return losses

    def _run_multitask(self, results: RunResults, policy: Policy, algo: Algo) -> None:
        everything = list(range(self.K))
        start = self._resume_point(results, policy, algo, 1)
        if start >= 1:
            return
        self.observer.phase(f"multitask: {self.K} tasks at once")
        if results.stage[0] != "trained":
            _seed_everything(_mix(self.plan.seed, 0, 1))
            algo.start_task(0, policy)
            loader = self._loader(everything, seed=_mix(self.plan.seed, 0, 2))
            best = self._epochs(results, policy, algo, loader, everything, learned_after=0)
            factory_loader = self._loader(everything, seed=_mix(self.plan.seed, 0, 3))
            algo.end_task(0, lambda: iter(factory_loader))
            self._save_checkpoint(0, "trained", policy, algo)
            kept = self.eval_epochs.index(best) if best is not None else len(self.eval_epochs) - 1
            for tau in range(self.K):
                for k in range(self.K):
                    results.after[tau][k] = results.curve[k][kept]
        results.stage = ["done"] * self.K
        self._write_results(results)

    # -- the rollout dataset -------------------------------------------------------------------------
    def collect_rollouts(self, results: RunResults) -> None:
        """Join every rollout of ``results`` into ``RUN/rollouts`` (one LeRobot dataset)."""
        from libero_bench.evaluate import build_rollout_dataset

        keys = sorted(r["key"] for r in results.rollouts)
        missing = [k for k in keys if not (self.folder.shard(k) / "episode.json").is_file()]
        if missing:
            raise ValueError(f"{self.folder.root}: rollout {missing[0]} is missing from {self.folder.shards}")
        bddl = {}
        for t in self._eval_task_list():
            bddl[t.name] = Path(t.env_ref).read_text()
        meta = {
            "run": self.folder.root.name,
            "algo": self.plan.request.algo,
            "policy": self.plan.request.policy,
            "preset": self.preset.name,
            "seed": self.plan.seed,
            "request": {"repo_id": "libero-bench/rollouts", "suite": self.plan.source.suite},
            "sim_state_width": self.plan.source.sim_state_width,
            "tasks": [
                {"name": t.name, "language": t.language, "index": t.suite_index, "position": i}
                for i, t in enumerate(self.plan.tasks)
            ],
        }
        started = time.perf_counter()
        count = build_rollout_dataset(
            [self.folder.shard(k) for k in keys],
            self.folder.rollouts,
            run_meta=meta,
            bddl=bddl,
            work_dir=self.folder.work,
        )
        self.folder.append_timing(
            {
                "what": "collect_rollouts",
                "episodes": count,
                "seconds": round(time.perf_counter() - started, 3),
            }
        )
        logger.info("rollout dataset: %d episodes in %s", count, self.folder.rollouts)


def resolve_eval_task(
    source: DemoDataset, task: DemoTask, position: int, task_emb: np.ndarray, work: Path
) -> EvalTask:
    """How to simulate a dataset task: LIBERO's BDDL and stored init states when the task is
    in the registry, else the BDDL stored with the dataset (objects placed from seeds)."""
    from libero_bench.evaluate import EvalTask
    from libero_data.tasks import TaskLookupError, get_suite

    bddl: Path | None = None
    inits: np.ndarray | None = None
    if task.suite:
        try:
            registered = get_suite(task.suite).task(task.name)
            bddl = registered.bddl_path
            try:
                inits = registered.init_states()
            except FileNotFoundError:
                inits = None
        except (TaskLookupError, FileNotFoundError):
            bddl = None
    if bddl is None:
        stored = source.root / "meta" / "bddl" / f"{task.name}.bddl"
        if not stored.is_file():
            raise ValueError(
                f"task {task.name} is not a known LIBERO task and {source.root} has no BDDL for it"
            )
        bddl = stored
    return EvalTask(
        name=task.name,
        language=task.language,
        position=position,
        env_ref=str(bddl),
        task_emb=np.asarray(task_emb, dtype=np.float32),
        init_states=inits,
    )


def run_lifelong(
    request: RunRequest,
    out: str | Path,
    options: RunOptions | None = None,
    observer: RunObserver | None = None,
) -> RunResults:
    """Plan and run (or resume) a lifelong run into ``out``."""
    plan = plan_run(request)
    return Trainer(plan, Path(out), options, observer).run()
