"""Reading a run's checkpoints: the checkpoint a run kept after a task, its policy and
algorithm in the evaluation view of a task, and a run folder's policy ready to act
(:func:`load_run_policy`: what ``libero-bench eval``, ``robustness`` and ``serve`` open).
Writing them is the trainer's (:mod:`libero_bench.train.checkpoints`)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from libero_bench.runs.folder import RunFolder
from libero_bench.runs.state_files import load_state
from libero_data.errors import CheckpointError, InputError, RunError, first_line

if TYPE_CHECKING:
    from libero_bench.algos import Algo
    from libero_bench.policies.base import Policy

#: What :mod:`~libero_bench.runs.state_files` records a file to be.
CHECKPOINT, EPOCH_STATE = "libero-bench checkpoint", "libero-bench epoch state"


def read_checkpoint(path: Path) -> dict[str, Any]:
    """A run's checkpoint as written by :func:`save_checkpoint` (one sentence if it is not)."""
    data = load_state(path, kind=CHECKPOINT)
    missing = [
        k for k in ("policy", "algo") if not isinstance(data, dict) or not isinstance(data.get(k), dict)
    ]
    if missing:
        raise CheckpointError(f"the checkpoint {path} has no {' or '.join(missing)} state")
    return dict(data)


def load_into(path: Path, policy: Policy, algo: Algo, data: dict[str, Any]) -> None:
    """Load a checkpoint's state (``data``, read from ``path``) into a policy and algorithm."""
    try:
        policy.load_state_dict(data["policy"])
        algo.load_state_dict(data["algo"])
    except (RuntimeError, KeyError, TypeError, ValueError) as exc:
        first = first_line(exc)
        raise CheckpointError(
            f"the checkpoint {path} does not fit this run's policy or algorithm: {first}"
        ) from None
    algo.bind(policy)


def kept_checkpoint(folder: RunFolder, config: dict[str, Any], position: int) -> Path:
    """The checkpoint a run kept after the task at ``position`` (MTL: its one checkpoint)."""
    from libero_bench.algos import algo_class

    folder.refuse_pickles()
    index = 0 if algo_class(config["algo"]).needs_all_tasks else position
    path = folder.checkpoint(index)
    if not path.is_file():
        name = config["tasks"][position]["name"]
        raise RunError(f"{path} is missing: the run has no checkpoint after task {name}")
    return path


def policy_from_checkpoint(config: dict[str, Any], checkpoint: Path, position: int) -> tuple[Any, Any]:
    """(policy, algorithm) of a checkpoint, in the algorithm's evaluation view of the task."""
    from libero_bench.algos import algo_config_from_dict, build_algo
    from libero_bench.policies import build_policy, config_from_dict

    state = read_checkpoint(checkpoint)
    try:
        pconfig = config_from_dict(config["policy_config"])
        policy = build_policy(pconfig)
        acfg = algo_config_from_dict(config["algo_config"])
        algo = build_algo(acfg)
    except (KeyError, TypeError, ValueError) as exc:
        what = first_line(exc)
        raise RunError(
            f"the config.json of the run with {checkpoint} does not describe a policy and algorithm "
            f"libero-bench can build ({what})"
        ) from None
    load_into(checkpoint, policy, algo, state)
    algo.set_eval_task(position)
    return policy.eval(), algo


@dataclass(frozen=True)
class RunPolicy:
    """What a run folder holds to act with: its last checkpoint's policy (on a device, in eval
    mode), in the algorithm's view of the task at ``position``, and the run's config."""

    folder: Path
    config: dict[str, Any]
    policy: Any
    position: int  # the task whose evaluation view it is
    last: int  # the last task the run finished learning

    @property
    def name(self) -> str:
        return f"{self.config['algo']} + {self.config['policy']}"

    def embed(self, prompts: list[str]) -> Any:
        """Task embeddings of ``prompts`` from the run's language encoder."""
        from libero_bench.data.language import encode_tasks

        return encode_tasks(prompts, self.config["preset"]["language_encoder"])


def load_run_policy(run: str | Path, device: str = "cpu", view_task: int | None = None) -> RunPolicy:
    """The policy of a libero-bench run folder: its final checkpoint (after the last task it learned;
    MTL: its one checkpoint) in the evaluation view of the task at ``view_task`` (PackNet's masks;
    default: the last it learned). One sentence where the run has no finished task, its config or
    checkpoint does not fit, or the view names a task it has not learned."""
    from libero_bench.runs.folder import POLICY_FIELDS
    from libero_bench.runs.summary import load_run

    folder = RunFolder(Path(run).resolve())
    folder.read_config(needs=POLICY_FIELDS)
    summary = load_run(folder.root)
    last = summary.tasks_done - 1
    position = last if view_task is None else view_task
    if not 0 <= position <= last:
        raise InputError(
            f"run {folder.root} has learned tasks 0..{last}; no view of task {position}", field="view_task"
        )
    policy, _algo = policy_from_checkpoint(
        summary.config, kept_checkpoint(folder, summary.config, last), position
    )
    return RunPolicy(folder.root, summary.config, policy.to(device), position, last)
