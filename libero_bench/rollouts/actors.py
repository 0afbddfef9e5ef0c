"""What acts for a batch of environments: one policy, in one process, on one device.

A :class:`BatchActor` is told when an environment's slot begins an episode (:meth:`~BatchActor.begin`)
and, each control step, gets the observations of every running slot and returns one action for
each (:meth:`~BatchActor.act`). The slots whose queued actions have run out go through **one**
batched forward pass (:attr:`~BatchActor.forwards` counts them); a policy that predicts action
chunks (ACT, Diffusion Policy, the VLAs) fills a queue per slot and is asked again only when that
slot's queue is empty (:class:`ActionQueues`).

:class:`PolicyActor` is libero-bench's own policies (ResNet-RNN, ResNet-T, ViT-T): one action per
step, each slot with its own history (:meth:`libero_bench.policies.Policy.act_rows`).
"""

from __future__ import annotations

import os
from collections import deque
from collections.abc import Iterable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from libero_bench.policies.base import Policy

Observations = Mapping[int, Mapping[str, Any]]


@dataclass(frozen=True)
class Start:
    """What an actor learns when a slot begins an episode: the rollout's key (it seeds a sampling
    policy's noise), the task's instruction and, for libero-bench's policies, its embedding; the
    episode's number (its stored init state, -1 for another start) and the task's suite, which
    openpi's episode messages carry."""

    key: str
    language: str
    task_emb: np.ndarray | None = field(default=None, repr=False)
    episode: int = -1
    experiment: str = ""


class BatchActor:
    """Acts for many environments at once (see the module docstring). ``reads`` names the
    observations it reads; ``chunk_size`` is the actions one forward pass predicts (1: one per step)."""

    reads: tuple[str, ...] = ("agentview", "eye_in_hand", "state")
    chunk_size: int = 1

    def __init__(self) -> None:
        self.forwards = 0  # batched forward passes so far
        self.rows = 0  # observations they read, all together

    def begin(self, slot: int, start: Start) -> None:
        """``slot`` begins an episode (forget what it kept of the one before)."""
        raise NotImplementedError

    def act(self, observations: Observations) -> dict[int, np.ndarray]:
        """One 7-D action for every slot in ``observations`` (its latest observation)."""
        raise NotImplementedError

    def end(self, slot: int, success: bool | None = None) -> None:
        """``slot``'s episode ended (``success``: its outcome, where known)."""

    def looks(self, slot: int) -> bool:
        """Whether the policy will look at ``slot``'s next observation (a policy acting from a
        queued chunk does not: its environment need not draw the images)."""
        return True

    def ahead(self, slot: int) -> list[np.ndarray]:
        """The actions ``slot`` takes next without looking at an observation (the rest of a queued
        chunk), taken from its queue: its environment can run them in the same call as the action
        :meth:`act` just gave, and draw only after the last. None by default."""
        return []

    def act_chunks(self, observations: Observations) -> dict[int, np.ndarray]:
        """A fresh chunk ``(H, 7)`` for every slot in ``observations``: what a policy server answers
        a client that executes chunks (openpi's). One action per slot for a one-step policy."""
        return {slot: np.asarray(action)[None] for slot, action in self.act(observations).items()}

    def describe(self) -> dict[str, Any]:
        """What results record about how the policy ran."""
        return {}

    def close(self) -> None:
        """Release what the actor holds (connections, device memory)."""

    def counted(self, rows: int) -> None:
        """Count one batched forward pass over ``rows`` observations."""
        self.forwards += 1
        self.rows += rows


class ActionQueues:
    """Per-slot queues of actions from predicted chunks; a slot waits when its queue is empty."""

    def __init__(self, steps: int | None = None) -> None:
        self.steps = steps  # actions executed of each chunk (None: the whole chunk)
        self._queues: dict[int, deque[np.ndarray]] = {}

    def clear(self, slot: int) -> None:
        self._queues[slot] = deque()

    def drop(self, slot: int) -> None:
        self._queues.pop(slot, None)

    def waiting(self, slots: Iterable[int]) -> list[int]:
        """The slots (in order) that need a new chunk."""
        return sorted(s for s in slots if not self._queues.get(s))

    def fill(self, slot: int, chunk: np.ndarray) -> None:
        chunk = np.asarray(chunk, dtype=np.float64).reshape(-1, np.asarray(chunk).shape[-1])
        if chunk.shape[0] == 0:
            raise ValueError("the policy returned an empty action chunk")
        self._queues[slot] = deque(chunk[: self.steps] if self.steps else chunk)

    def pop(self, slot: int) -> np.ndarray:
        return self._queues[slot].popleft()

    def empty(self, slot: int) -> bool:
        """Whether the slot's queue is empty (its next observation goes to the policy)."""
        return not self._queues.get(slot)

    def take(self, slot: int) -> list[np.ndarray]:
        """Every action left in the slot's queue (the queue is then empty)."""
        rest = list(self._queues.get(slot, ()))
        self.clear(slot)
        return rest


def chunked_answers(
    actor: BatchActor, queues: ActionQueues, observations: Observations
) -> dict[int, np.ndarray]:
    """:meth:`BatchActor.act_chunks` of an actor that queues chunks: each slot's queue is emptied,
    so the call predicts anew, and the chunk comes back whole (its first action and the rest)."""
    for slot in observations:
        queues.clear(slot)
    first = actor.act(observations)
    return {s: np.stack([np.asarray(first[s]), *[np.asarray(a)[:7] for a in queues.take(s)]]) for s in first}


@contextmanager
def forward_threads(device: Any, threads: int | None = None) -> Iterator[None]:
    """torch's CPU threads for one batched forward pass: every core of this machine by default
    (the environments wait for the policy, so nothing else needs them), and back to what they
    were after it. Between passes the driver keeps one thread: with more, the per-step work
    (stacking, normalising) would wake idle torch threads that take CPU time from the workers'
    rendering and slow every rollout (benchmarks/RESULTS.md, Evaluation: one batched policy)."""
    import torch

    if getattr(device, "type", str(device)) != "cpu":
        yield
        return
    before = torch.get_num_threads()
    torch.set_num_threads(threads or len(os.sched_getaffinity(0)))
    try:
        yield
    finally:
        torch.set_num_threads(before)


def default_device() -> str:
    """cuda where available, then mps, else cpu."""
    import torch

    if torch.cuda.is_available():
        return "cuda"
    mps = getattr(torch.backends, "mps", None)
    if mps is not None and mps.is_available():
        return "mps"
    return "cpu"


def observation_rows(
    observations: Sequence[Mapping[str, Any]], embeddings: Sequence[np.ndarray]
) -> dict[str, Any]:
    """A policy batch (B rows, T = 1) from environment observations and task embeddings."""
    import torch

    from libero_bench.data.batch_keys import AGENTVIEW, GRIPPER_STATES, JOINT_STATES, TASK_EMB, WRIST

    def stack(key: str) -> np.ndarray:
        return np.stack([np.asarray(obs[key]) for obs in observations])

    def images(key: str) -> torch.Tensor:
        return (
            torch.from_numpy(np.ascontiguousarray(stack(key)))
            .permute(0, 3, 1, 2)
            .float()
            .div_(255.0)[:, None]
        )

    return {
        AGENTVIEW: images("agentview"),
        WRIST: images("eye_in_hand"),
        JOINT_STATES: torch.from_numpy(stack("joint_pos").astype(np.float32))[:, None],
        GRIPPER_STATES: torch.from_numpy(stack("gripper_state").astype(np.float32))[:, None],
        TASK_EMB: torch.from_numpy(np.stack([np.asarray(e, dtype=np.float32) for e in embeddings])),
    }


class PolicyActor(BatchActor):
    """A libero-bench policy (in eval mode, on its own device): every slot acts every step."""

    reads = ("agentview", "eye_in_hand", "joint_pos", "gripper_state")

    def __init__(self, policy: Policy) -> None:
        super().__init__()
        self.policy = policy
        self.device = next(policy.parameters()).device
        self._history: dict[int, Any] = {}
        self._embedding: dict[int, np.ndarray] = {}

    def begin(self, slot: int, start: Start) -> None:
        if start.task_emb is None:
            raise ValueError(f"rollout {start.key} has no task embedding; libero-bench policies need one")
        self._history[slot] = None
        self._embedding[slot] = np.asarray(start.task_emb, dtype=np.float32)

    def end(self, slot: int, success: bool | None = None) -> None:
        self._history.pop(slot, None)
        self._embedding.pop(slot, None)

    def act(self, observations: Observations) -> dict[int, np.ndarray]:
        slots = sorted(observations)
        if not slots:
            return {}
        batch = observation_rows([observations[s] for s in slots], [self._embedding[s] for s in slots])
        batch = {k: v.to(self.device) for k, v in batch.items()}
        with forward_threads(self.device):
            actions, history = self.policy.act_rows(batch, [self._history[s] for s in slots])
        self.counted(len(slots))
        self._history.update(zip(slots, history, strict=True))
        out = actions.detach().cpu().numpy()
        return {s: out[i] for i, s in enumerate(slots)}

    def describe(self) -> dict[str, Any]:
        return {"actor": "libero-bench", "device": str(self.device)}
