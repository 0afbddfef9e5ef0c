"""What a policy is: a libero-bench run folder, a LeRobot policy folder, a policy served elsewhere
(``ws://HOST:PORT``), or any kind registered here; each opened as a batch actor, on a device.

:func:`policy_source` asks every registered kind, in its ``order``, whether a reference names one
of its policies, and the first that claims it reads what names the policy (a folder's config, a
server's metadata: an unreadable one is one sentence before any rollout) and returns a
:class:`PolicySource`, which ``libero-bench eval``, ``robustness`` and ``serve`` all use: its name
for reports, the camera size it reads, the observations it reads, task embeddings (a run's
language encoder), where its demonstrations started, and how to open its actor (a run: in the
evaluation view of one of its tasks). One module per kind (``run``, ``lerobot``, ``served``), each
registering a :class:`PolicyKind`; the package finds them.
"""

from __future__ import annotations

import functools
import importlib
import os
import pkgutil
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from libero_bench.rollouts.actors import BatchActor
from libero_data.config import Config
from libero_data.errors import InputError
from libero_data.registry import Registry

#: (training data, {task: (stored init indices, sampler seeds)}) of a policy's demonstrations.
TrainingStarts = tuple[str | None, dict[str, tuple[set[int], set[int]]]]
RUN, LEROBOT, SERVER = "run", "lerobot", "server"
SERVER_SCHEMES = ("ws://", "wss://")


def is_server(policy: str) -> bool:
    """Whether ``policy`` names a policy server (``ws://HOST:PORT``) rather than a folder."""
    return policy.startswith(SERVER_SCHEMES)


def shown_from(policy: str, folder: Path) -> str:
    """How a report in ``folder`` names ``policy``: a server by its address, a folder by its path
    relative to ``folder`` (a report moved or committed with its policy still finds it)."""
    if is_server(policy):
        return policy
    return os.path.relpath(Path(policy).resolve(), Path(folder).resolve())


@dataclass(frozen=True)
class SourceOptions(Config):
    """What an evaluation asks of a policy it reaches: for a server, the image size sent, the
    actions executed of each chunk and the request it is sent (``libero-bench`` or ``openpi``)."""

    image_size: int | None = None
    replan_steps: int = 5
    request: str = "libero-bench"


@dataclass(frozen=True)
class PolicySource:
    """A policy to roll out (see the package docstring). ``open(device, view)`` builds its actor;
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


@dataclass(frozen=True)
class PolicyKind:
    """One kind of policy: whether a reference names one (``claims``) and its source (``source``).
    Kinds are asked in ``order`` (a server's address or a run folder before a LeRobot folder,
    which any folder with a ``config.json`` could be mistaken for)."""

    name: str
    order: int
    claims: Callable[[str], bool]
    source: Callable[[str, SourceOptions], PolicySource]


POLICY_KINDS: Registry[PolicyKind] = Registry("policy kind")


def register_kind(kind: PolicyKind) -> PolicyKind:
    """Register a kind of policy (called by each module of this package)."""
    POLICY_KINDS.register(kind.name)(kind)
    return kind


@functools.cache
def policy_kinds() -> tuple[PolicyKind, ...]:
    """Every registered kind, in the order they are asked."""
    for module in pkgutil.iter_modules(__path__):
        importlib.import_module(f"{__name__}.{module.name}")
    return tuple(sorted((POLICY_KINDS.get(n) for n in POLICY_KINDS.names()), key=lambda k: k.order))


def policy_source(
    policy: str, image_size: int | None = None, replan_steps: int = 5, request: str = "libero-bench"
) -> PolicySource:
    """The source of ``policy`` (a run folder, a LeRobot folder, a server, ...: the first kind that
    claims it); for a server, the image size sent, the actions executed of each chunk and the
    request it is sent (``libero-bench`` or ``openpi``: libero_bench.rollouts.observations)."""
    options = SourceOptions(image_size, replan_steps, request)
    for kind in policy_kinds():
        if kind.claims(policy):
            return kind.source(policy, options)
    names = ", ".join(k.name for k in policy_kinds())
    raise InputError(f"{policy} is none of the policies libero-bench opens ({names})", field="policy")


def check_policy(policy: str, image_size: int | None = None, replan_steps: int = 5) -> PolicySource:
    """One sentence, before anything is written or shown, where ``policy`` cannot be evaluated:
    a run folder with no finished task or a damaged or pickled checkpoint, a LeRobot folder with a
    bad config or weights, an unreachable server. The source, where it can."""
    return policy_source(policy, image_size, replan_steps)
