"""What a policy is: a libero-bench run folder, a LeRobot policy folder, or a policy served
elsewhere (``ws://HOST:PORT``); each opened as a batch actor, on a device, in one place.

:func:`policy_source` reads what names the policy (a folder's config, a server's metadata: an
unreadable one is one sentence before any rollout) and returns a :class:`PolicySource`, which
``libero-bench eval``, ``robustness`` and ``serve`` all use: its name for reports, the camera size
it reads, the observations it reads, task embeddings (a run's language encoder) and how to open
its actor (a run: in the evaluation view of one of its tasks).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from libero_bench.rollouts.actors import BatchActor

SERVER_SCHEMES = ("ws://", "wss://")
#: (training data, {task: (stored init indices, sampler seeds)}) of a policy's demonstrations.
TrainingStarts = tuple[str | None, dict[str, tuple[set[int], set[int]]]]
RUN, LEROBOT, SERVER = "run", "lerobot", "server"


def is_server(policy: str) -> bool:
    """Whether ``policy`` names a policy server (``ws://HOST:PORT``) rather than a folder."""
    return policy.startswith(SERVER_SCHEMES)


@dataclass(frozen=True)
class PolicySource:
    """A policy to roll out (see the module docstring). ``open(device, view)`` builds its actor;
    ``view`` is the run task whose evaluation view acts (None: the last it learned; ignored by
    the other kinds). ``tasks`` are the tasks a run learned, in order (empty otherwise)."""

    ref: str
    kind: str
    policy_type: str
    render_size: int
    inputs: dict[str, Any]
    open: Callable[[str, int | None], BatchActor] = field(repr=False)
    reads: tuple[str, ...] = ("agentview", "eye_in_hand", "state")
    embed: Callable[[Sequence[str]], np.ndarray] | None = field(default=None, repr=False)
    tasks: tuple[str, ...] = ()
    chunk_size: int = 1
    starts: Callable[[], TrainingStarts] = field(default=lambda: (None, {}), repr=False)

    def training_starts(self) -> TrainingStarts:
        """The data the policy was trained on (a reference) and, per task, where its demonstrations
        started (stored init indices, sampler seeds); ``(None, {})`` where it is not known."""
        return self.starts()

    def view_of(self, task: str) -> int | None:
        """The run task whose view acts on ``task``: the task itself where the run learned it."""
        return self.tasks.index(task) if task in self.tasks else None


def policy_source(
    policy: str, image_size: int | None = None, replan_steps: int = 5, request: str = "libero-bench"
) -> PolicySource:
    """``policy``: a run folder, a LeRobot folder (read now, loaded when rollouts start) or a
    server (reached now); for a server, the image size sent, the actions executed of each chunk
    and the request it is sent (``libero-bench`` or ``openpi``: libero_bench.rollouts.observations)."""
    if is_server(policy):
        return _server_source(policy, image_size, replan_steps, request)
    from libero_bench.runs.folder import RunFolder

    folder = Path(policy).resolve()
    if RunFolder(folder).is_run():
        return _run_source(folder)
    return _lerobot_source(folder)


def _server_source(url: str, image_size: int | None, replan_steps: int, request: str) -> PolicySource:
    from libero_bench.rollouts.remote import RemoteActor, connect

    connection, metadata = connect(url, timeout=30.0)
    connection.close()
    served = metadata.get("image_size")
    size = image_size or (int(served) if isinstance(served, int) else 224)
    render = int(served) if isinstance(served, int) else max(size, 256)
    horizon = metadata.get("action_horizon")
    return PolicySource(
        url,
        SERVER,
        str(metadata.get("policy_type", "served")),
        render,
        {"server": url, "image_size": size, "replan_steps": replan_steps},
        lambda _device, _view: RemoteActor(url, image_size=size, replan_steps=replan_steps, request=request),
        chunk_size=int(horizon) if isinstance(horizon, int) else 1,
    )


def _lerobot_source(folder: Path) -> PolicySource:
    from libero_bench.rollouts.lerobot_actor import LeRobotActor
    from libero_bench.rollouts.lerobot_inputs import lerobot_config, serve

    config = lerobot_config(folder)
    inputs = serve(config.input_features, f"the {config.type} policy at {folder}")
    cameras = {camera for camera, _h, _w in inputs.cameras.values()}
    return PolicySource(
        str(folder),
        LEROBOT,
        config.type,
        inputs.render_size,
        {k: list(v) for k, v in {**inputs.cameras, **inputs.states}.items()},
        lambda device, _view: LeRobotActor(folder, device),
        reads=(*sorted(cameras), *(key for key, _w in inputs.states.values())),
        chunk_size=int(getattr(config, "n_action_steps", None) or 1),
        starts=lambda: _lerobot_training_starts(folder),
    )


def _lerobot_training_starts(policy: Path) -> TrainingStarts:
    """From the dataset ``train_config.json`` names, where it is a libero-data dataset on disk."""
    from libero_bench.data.dataset import DemoDataset
    from libero_data.errors import LiberoDataError
    from libero_data.runtime.files import read_json

    path = policy / "train_config.json"
    if not path.is_file():
        return None, {}
    config = read_json(path)
    root = ((config.get("dataset") if isinstance(config, dict) else None) or {}).get("root")
    if not root or not Path(root).is_dir():
        return root, {}
    try:
        data = DemoDataset(root)
    except LiberoDataError:
        return root, {}
    found = {}
    for task in data.tasks:
        starts = data.training_starts(task)
        if starts is not None:
            found[task.name] = starts
    return root, found


def run_training_starts(config: dict[str, Any]) -> TrainingStarts:
    """Where a run's demonstrations started, per task: its dataset's and those of any dataset
    mixed in (the run's ``config.json``)."""
    from libero_bench.data.dataset import DemoDataset
    from libero_bench.data.mixing import mixed_seeds

    source = DemoDataset(config["data"])
    mixed = mixed_seeds(config)
    found: dict[str, tuple[set[int], set[int]]] = {}
    for task in config["tasks"]:
        name = task["name"]
        starts = source.training_starts(source.task(name))
        stored, seeds = starts if starts is not None else (set(), set())
        found[name] = (set(stored), set(seeds) | mixed.get(name, set()))
    return str(config["data"]), found


def _run_source(folder: Path) -> PolicySource:
    from libero_bench.rollouts.actors import PolicyActor
    from libero_bench.runs.saved_policy import load_run_policy

    checked = load_run_policy(folder)  # built and loaded once: a run that does not fit is one sentence now
    config = checked.config
    size = int(config["policy_config"]["image_size"])
    tasks = tuple(t["name"] for t in config["tasks"][: checked.last + 1])

    def open_actor(device: str, view: int | None) -> BatchActor:
        return PolicyActor(load_run_policy(folder, device, view).policy)

    return PolicySource(
        str(folder),
        RUN,
        checked.name,
        size,
        {"run": str(folder), "image_size": size, "language_encoder": config["preset"]["language_encoder"]},
        open_actor,
        reads=PolicyActor.reads,
        embed=lambda prompts: np.asarray(checked.embed(list(prompts)), dtype=np.float32),
        tasks=tasks,
        starts=lambda: run_training_starts(config),
    )


def check_policy(policy: str, image_size: int | None = None, replan_steps: int = 5) -> PolicySource:
    """One sentence, before anything is written or shown, where ``policy`` cannot be evaluated:
    a run folder with no finished task or a damaged or pickled checkpoint, a LeRobot folder with a
    bad config or weights, an unreachable server. The source, where it can."""
    return policy_source(policy, image_size, replan_steps)
