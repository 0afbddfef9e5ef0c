"""What a benchmark run is: the request, checked and resolved into a plan (tasks in training
order, their language embeddings, the policy's and algorithm's configs), and the run's
``config.json``."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from libero_bench.data.dataset import DemoDataset, DemoTask
from libero_bench.data.mixing import DEFAULT_WEIGHT, MixPlan, check_weight, plan_mix
from libero_bench.runs.folder import RUN_FORMAT, RunFolder
from libero_bench.train.presets import TrainPreset
from libero_data.config import Config
from libero_data.errors import FolderError, InputError, MissingFileError, UnknownNameError
from libero_data.numerics import machine_fingerprint
from libero_data.runtime.jobs import JobPlacement
from libero_data.sim.arm import ARM_INIT_NOISE

if TYPE_CHECKING:
    import torch

    from libero_bench.algos import Algo
    from libero_bench.rollouts.jobs import EvalTask

#: config.json keys that may change between a run and its resumption
RUNTIME_KEYS = ("runtime",)


@dataclass(frozen=True)
class RunRequest(Config):
    """What to run (the parts that define the run's results)."""

    data: Path
    algo: str
    policy: str
    preset: TrainPreset
    tasks: tuple[str, ...] | None = None  # names or suite indices; None: every task of the dataset
    order: int | None = None  # an upstream task order (10-task selections)
    seed: int | None = None  # None: the preset's seed
    init_checkpoint: Path | None = None
    mix: tuple[Path, ...] = ()  # datasets with more episodes of the tasks or their variants (mixing)
    mix_weight: float = DEFAULT_WEIGHT  # the share of each epoch drawn from them
    algo_settings: tuple[str, ...] = ()  # field=value of the algorithm's config (EWC's penalty_weight, ...)


@dataclass(frozen=True)
class RunOptions(Config):
    """How to run it (free to change when resuming)."""

    device: str = "cpu"
    executor: JobPlacement = field(
        default_factory=JobPlacement
    )  # where the evaluation rollouts step (libero_data.runtime.jobs)
    loader_workers: int = 0  # DataLoader worker processes (PyTorch's meaning: 0 is this process)
    threads: int = 1  # torch threads of the training process (last-bit differences follow it)
    # stop once this many tasks are learned and the earlier ones evaluated again (a sweep on a
    # sequence's first tasks); the same run without it goes on from there with the same numbers
    stop_after: int | None = None


def select_tasks(source: DemoDataset, tasks: Sequence[str] | None, order: int | None) -> list[DemoTask]:
    """The run's tasks in training order: ``tasks`` (names or suite indices) or all of the
    dataset's, then permuted by upstream order ``order``."""
    from libero_data.tasks import task_orders

    if tasks:
        chosen = [source.task(t) for t in tasks]
        names = [t.name for t in chosen]
        if len(set(names)) != len(names):
            raise InputError("the task list names a task twice", field="tasks")
    else:
        chosen = list(source.tasks)
    if order is not None:
        orders = task_orders()
        if not 0 <= order < len(orders):
            raise InputError(f"task order must be in 0..{len(orders) - 1}, got {order}", field="order")
        permutation = orders[order]
        if len(chosen) != len(permutation):
            raise InputError(
                f"upstream task orders are for 10 tasks, but the run has {len(chosen)}; "
                "choose 10 tasks or leave out the order",
                field="order",
            )
        chosen = [chosen[i] for i in permutation]
    return chosen


def _algo_for(name: str, size: str, seed: int, settings: tuple[str, ...] = ()) -> Algo:
    from libero_bench.algos import algo_config, build_algo

    config = algo_config(name, size).with_assignments(
        settings, what=f"{name} algorithm", field="algo_settings"
    )
    if any(f.name == "seed" for f in dataclasses.fields(config)):
        config = config.replace(seed=seed)
    return build_algo(config)


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
    mix: MixPlan | None = None

    def training_seeds(self, position: int) -> frozenset[int]:
        """The sampler seeds every training episode of the task at ``position`` began from (the
        mixed ones included): its held-out evaluation starts skip them."""
        seeds = set(_sampler_seeds(self.source, self.tasks[position]))
        if self.mix is not None:
            seeds |= self.mix.starts(position)[1]
        return frozenset(seeds)

    def tasks_this_time(self, options: RunOptions) -> int:
        """How many tasks an invocation learns before it returns: all unless ``options.stop_after``."""
        stop = options.stop_after
        if stop is None:
            return len(self.tasks)
        if self.needs_all_tasks:
            raise InputError(
                f"--stop-after applies to algorithms that learn task by task; {self.request.algo} learns "
                "every task at once",
                field="stop_after",
            )
        if stop < 1:
            raise InputError(f"--stop-after must be at least 1, got {stop}", field="stop_after")
        return min(stop, len(self.tasks))

    def rollouts_meta(self, run: str) -> dict[str, Any]:
        """What the run's rollout dataset says of itself (``run``: the run folder's name)."""
        return {
            "run": run,
            "algo": self.request.algo,
            "policy": self.request.policy,
            "preset": self.preset.name,
            "seed": self.seed,
            "request": {"repo_id": "libero-bench/rollouts", "suite": self.source.suite},
            "sim_state_width": self.source.sim_state_width,
            "tasks": [
                {"name": t.name, "language": t.language, "index": t.suite_index, "position": i}
                for i, t in enumerate(self.tasks)
            ],
        }

    def config(self, options: RunOptions, root: Path) -> dict[str, Any]:
        """The ``config.json`` of the run in ``root`` (everything but ``runtime`` must match to
        resume); the datasets and the initial checkpoint are named relative to ``root``."""
        from libero_bench.runs.training_data import relative
        from libero_data.runtime.versions import versions

        req = self.request
        demos = self.preset.demos_per_task
        return {
            "format": RUN_FORMAT,
            "data": relative(root, self.source.root),
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
            "preset": self.preset.to_dict(),
            "seed": self.seed,
            "init_checkpoint": relative(root, req.init_checkpoint) if req.init_checkpoint else None,
            "evaluation": {
                "stored_rollouts": self.preset.eval_rollouts,
                "heldout_rollouts": self.preset.eval_heldout,
                "heldout_seeds": "libero_data.seeding.heldout_starts(task name, n, avoid=its demonstrations' seeds)",
                # rad per arm joint on held-out starts, as LIBERO's stored init states (libero_data.sim.arm)
                "heldout_arm_noise": ARM_INIT_NOISE,
                "training_starts": start_overlap(self.source, self.tasks, self.preset, self.mix),
            },
            **({"mix": self.mix.config(self.tasks, root)} if self.mix is not None else {}),
            "runtime": {
                "device": options.device,
                "workers": options.executor.workers,
                "threads": options.threads,
                "executor": options.executor.kind,
                "versions": versions(python=True),
                # The numeric path of the machines that worked on the run (a resumed run adds its
                # own): rollouts replay bit for bit only on the same one (libero_data.numerics).
                "machines": [machine_fingerprint()],
            },
        }


def plan_run(request: RunRequest) -> RunPlan:
    """Check the request and resolve it (reads the dataset's metadata, embeds the tasks)."""
    from libero_bench.algos import algo_names
    from libero_bench.data.language import encode_tasks
    from libero_bench.policies import policy_config, policy_names

    if request.algo not in algo_names():
        raise UnknownNameError(f"unknown algorithm {request.algo!r}; known: {', '.join(algo_names())}")
    if request.policy not in policy_names():
        raise UnknownNameError(f"unknown policy {request.policy!r}; known: {', '.join(policy_names())}")
    if request.init_checkpoint is not None and not request.init_checkpoint.is_file():
        raise MissingFileError(f"the initial checkpoint {request.init_checkpoint} does not exist")
    check_weight(request.mix_weight)
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
        **({} if preset.augment is None else {"augment": bool(preset.augment)}),
    )
    algo = _algo_for(request.algo, preset.algo_size, seed, request.algo_settings)
    if request.init_checkpoint is not None:
        _check_initial_weights(request.init_checkpoint, pconfig, request.policy)
    mix = (
        plan_mix(request.mix, request.mix_weight, tasks, source, preset.language_encoder)
        if request.mix
        else None
    )
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
        mix=mix,
    )


def _check_initial_weights(path: Path, pconfig: Any, policy_name: str) -> None:
    """Weights that are a pickle, not safetensors or of another policy are refused here, before
    a run folder is made."""
    import torch

    from libero_bench.policies import build_policy
    from libero_bench.train.checkpoints import load_initial_weights

    load_initial_weights(path, build_policy(pconfig), torch.device("cpu"), policy_name)


def check_device(name: str) -> torch.device:
    """``cpu`` or ``cuda[:N]``; anything else, or a missing GPU, is an :class:`InputError`."""
    import torch

    try:
        device = torch.device(name)
    except RuntimeError:
        raise InputError(f"the device must be cpu or cuda, got {name!r}", field="device") from None
    if device.type not in ("cpu", "cuda"):
        raise InputError(f"the device must be cpu or cuda, got {name!r}", field="device")
    if device.type == "cuda" and not torch.cuda.is_available():
        raise InputError("the cuda device was asked for, but CUDA is not available here", field="device")
    return device


def check_out_folder(out: Path) -> None:
    """A run goes into a new or empty folder, or the folder of the same run (to resume it)."""
    if out.exists() and not out.is_dir():
        raise FolderError(f"{out} is a file, not a folder")
    if out.is_dir() and not RunFolder(out).config.is_file() and any(out.iterdir()):
        raise FolderError(f"{out} is not empty and is not a libero-bench run; choose a new run folder")


def resolve_eval_task(
    source: DemoDataset,
    task: DemoTask,
    position: int,
    task_emb: np.ndarray,
    heldout: int = 0,
    avoid: frozenset[int] | None = None,
) -> EvalTask:
    """How to simulate a dataset task: LIBERO's BDDL and stored init states when the task is
    in the registry, else the BDDL stored with the dataset (objects placed from seeds); and
    ``heldout`` held-out starts none of its demonstrations began from (the seeds in ``avoid``;
    default: those of its episodes in ``source``)."""
    from libero_bench.rollouts.jobs import EvalTask
    from libero_data.errors import LiberoDataError
    from libero_data.seeding import heldout_starts
    from libero_data.tasks import get_suite

    bddl: Path | None = None
    inits: np.ndarray | None = None
    if task.suite:
        try:
            registered = get_suite(task.suite).task(task.name)
        except LiberoDataError:  # not a shipped task, nor one of a suite folder still on disk
            registered = None
        if registered is not None:
            bddl = registered.bddl_path
            try:
                inits = registered.init_states()
            except MissingFileError:
                inits = None
    if bddl is None:
        stored = source.root / "meta" / "bddl" / f"{task.name}.bddl"
        if not stored.is_file():
            raise MissingFileError(
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
        heldout=tuple(
            heldout_starts(task.name, heldout, avoid=_sampler_seeds(source, task) if avoid is None else avoid)
        ),
        suite=task.suite,
    )


def _stored_inits(task: DemoTask) -> int:
    """How many stored init states the evaluation draws its stored starts from (0: none)."""
    from libero_data.errors import LiberoDataError
    from libero_data.tasks import get_suite

    try:
        return len(get_suite(task.suite).task(task.name).init_states()) if task.suite else 0
    except LiberoDataError:
        return 0


def _sampler_seeds(source: DemoDataset, task: DemoTask) -> frozenset[int]:
    starts = source.training_starts(task)
    return frozenset(starts[1]) if starts is not None else frozenset()


def start_overlap(
    source: DemoDataset, tasks: Sequence[DemoTask], preset: TrainPreset, mix: MixPlan | None = None
) -> dict[str, Any]:
    """How the run's training data began (mixed episodes included), against its evaluation
    starts: per task, the stored init states both use (the paper's evaluation then measures
    starts the policy was trained from), or that the dataset does not record where its episodes
    started."""
    out: dict[str, Any] = {}
    for position, task in enumerate(tasks):
        starts = source.training_starts(task)
        if starts is None:
            out[task.name] = {"recorded": False}
            continue
        stored, seeds = starts
        if mix is not None and mix.episodes.get(position):
            mixed_stored, mixed_seeds = mix.starts(position)
            stored, seeds = stored | mixed_stored, seeds | mixed_seeds
        available = _stored_inits(task)
        evaluated = {r % available for r in range(preset.eval_rollouts)} if available else set()
        out[task.name] = {
            "recorded": True,
            "demos_from_stored_inits": len(stored),
            "demos_from_sampler": len(seeds),
            "stored_eval_starts_trained_on": sorted(stored & evaluated),
        }
    return out


def machines_worked(earlier: list[dict[str, Any]], now: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """A resumed run's ``runtime.machines``: those that worked on it before, then this one unless
    it is listed. One machine is another when its numeric key (the simulation's bits) or its CPU
    differs: machines of one key replay the same rollouts, but torch's CPU kernels train a little
    differently on another make of processor."""

    def key(machine: dict[str, Any]) -> tuple[Any, ...]:
        return machine.get("numeric_key"), machine.get("cpu"), machine.get("cpu_vendor")

    seen = {key(m) for m in earlier}
    return earlier + [m for m in now if key(m) not in seen]
