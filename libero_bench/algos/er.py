"""ER: experience replay from a small memory of past tasks' training windows.

The memory holds at most ``memory_size`` windows in total (1000 in the paper), split evenly
across the tasks learned so far: after task k each past task keeps ``memory_size // (k+1)``
windows, a uniform random sample of its data (reservoir sampling over one pass of the
task's batches; older tasks shrink to a random subset of what they kept). Every training
step on a later task draws a replay batch of past windows, concatenates it to the current
batch and takes the behaviour-cloning loss over both, as LIBERO does.

Images are stored as uint8 (they come from 8-bit frames; the rounding is below 1/510) so
1000 windows of two 128x128 cameras fit in about 1 GB.

The memory is a function of the data and the random stream: each update records the stream as
it was before (``fills``), so a state saved without the memory (:func:`without_memories`: 2 MB
instead of 120 MB at 64x64) is rebuilt exactly, on first use, from one pass over each past
task's data, given ``task_data`` (the trainer sets it: task number -> the loader ``end_task`` got).
"""

from __future__ import annotations

import copy
import logging
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from libero_bench.algos.base import ALGO_CONFIGS, Algo, AlgoConfig, Batch, DataloaderFactory
from libero_bench.data.batch_keys import IMAGE_KEYS

if TYPE_CHECKING:
    import torch
    from torch import Tensor


logger = logging.getLogger(__name__)

Memory = dict[str, "Tensor"]


def _encode(key: str, value: Tensor, quantise: bool) -> Tensor:
    import torch

    value = value.detach().cpu()
    if quantise and key in IMAGE_KEYS and value.is_floating_point():
        return (value.clamp(0, 1) * 255.0).round().to(torch.uint8)
    return value.clone()


def _decode(key: str, value: Tensor) -> Tensor:
    import torch

    if key in IMAGE_KEYS and value.dtype == torch.uint8:
        return value.float() / 255.0
    return value


@ALGO_CONFIGS.register("er")
@dataclass(frozen=True)
class ERConfig(AlgoConfig):
    name: ClassVar[str] = "er"
    algorithm: ClassVar[str] = "libero_bench.algos.er:ER"
    sizes: ClassVar[dict[str, dict[str, Any]]] = {"smoke": {"memory_size": 64}}

    memory_size: int = 1000
    replay_batch_size: int | None = None  # None: the size of the current batch
    quantise_images: bool = True
    seed: int = 0

    def __post_init__(self) -> None:
        if self.memory_size <= 0:
            self._fail("memory_size", "must be positive")
        if self.replay_batch_size is not None and self.replay_batch_size <= 0:
            self._fail("replay_batch_size", "must be positive or None")


class ER(Algo):
    config_class = ERConfig
    config: ERConfig

    def __init__(self, config: ERConfig | None = None) -> None:
        super().__init__(config)
        self._memories: dict[int, Memory] = {}
        self.rng = np.random.default_rng(self.config.seed)
        #: per memory update: the task and the random stream before it (what rebuilds the memory)
        self.fills: list[dict[str, Any]] = []
        self._rebuild = False

    @property
    def memories(self) -> dict[int, Memory]:
        """Past tasks' windows, by task number (rebuilt from the data if loaded without them)."""
        if self._rebuild:
            self._rebuild_memories()
        return self._memories

    @memories.setter
    def memories(self, value: dict[int, Memory]) -> None:
        self._memories = value
        self._rebuild = False

    def _rebuild_memories(self) -> None:
        """Replay every recorded update from its random stream, then put the stream back."""
        if self.task_data is None:
            raise RuntimeError("ER: a state saved without its memory needs task_data to rebuild it")
        import random

        import torch

        now = self.rng.bit_generator.state
        streams = torch.get_rng_state(), np.random.get_state(), random.getstate()  # a pass may draw on them
        self._memories, self._rebuild = {}, False
        for fill in self.fills:
            self.rng.bit_generator.state = copy.deepcopy(fill["rng"])
            self._update(int(fill["task"]), self.task_data(int(fill["task"])))
        self.rng.bit_generator.state = now
        torch.set_rng_state(streams[0])
        np.random.set_state(streams[1])
        random.setstate(streams[2])
        logger.info(
            "ER memory rebuilt from the data: %d windows over %d tasks",
            self.memory_count(),
            len(self._memories),
        )

    # -- memory ---------------------------------------------------------------------------
    def memory_count(self) -> int:
        """Windows held over all past tasks."""
        return sum(_length(m) for m in self.memories.values())

    def _fill(self, dataloader_factory: DataloaderFactory, capacity: int) -> Memory:
        """Reservoir-sample ``capacity`` windows from one pass over the batches."""
        import torch

        slots: list[dict[str, Tensor]] = []
        seen = 0
        quantise = self.config.quantise_images
        for batch in dataloader_factory():
            for row in range(_length(batch)):
                if seen < capacity:
                    slots.append({k: _encode(k, v[row], quantise) for k, v in batch.items()})
                else:
                    j = int(self.rng.integers(0, seen + 1))
                    if j < capacity:
                        slots[j] = {k: _encode(k, v[row], quantise) for k, v in batch.items()}
                seen += 1
        if not slots:
            raise ValueError("ER.end_task: the dataloader gave no windows")
        return {k: torch.stack([slot[k] for slot in slots]) for k in slots[0]}

    def end_task(self, task_index: int, dataloader_factory: DataloaderFactory) -> None:
        super().end_task(task_index, dataloader_factory)
        if self._rebuild:  # loaded without its windows: the past tasks' first
            self._rebuild_memories()
        self.fills.append({"task": task_index, "rng": copy.deepcopy(self.rng.bit_generator.state)})
        self._update(task_index, dataloader_factory)

    def _update(self, task_index: int, dataloader_factory: DataloaderFactory) -> None:
        """Shrink the past tasks' memories to an even share and fill the new task's."""
        import torch

        share = self.config.memory_size // (len(self._memories) + 1)
        if share == 0:
            logger.warning("ER memory of %d cannot hold task %d", self.config.memory_size, task_index)
            return
        for past, memory in self._memories.items():
            n = _length(memory)
            if n > share:
                keep = torch.from_numpy(np.sort(self.rng.choice(n, size=share, replace=False)))
                self._memories[past] = {k: v[keep] for k, v in memory.items()}
        self._memories[task_index] = self._fill(dataloader_factory, share)
        logger.info("ER memory: %d windows over %d tasks", self.memory_count(), len(self._memories))

    def replay_batch(self, size: int, device: torch.device) -> dict[str, Tensor]:
        """``size`` windows drawn uniformly (with replacement) from the whole memory."""
        import torch

        memories = list(self.memories.values())
        lengths = np.array([_length(m) for m in memories])
        picks = self.rng.integers(0, lengths.sum(), size=size)
        offsets = np.concatenate([[0], np.cumsum(lengths)])
        parts: list[dict[str, Tensor]] = []
        for i, memory in enumerate(memories):
            rows = picks[(picks >= offsets[i]) & (picks < offsets[i + 1])] - offsets[i]
            if rows.size:
                index = torch.from_numpy(rows)
                parts.append({k: v[index] for k, v in memory.items()})
        keys = parts[0].keys()
        return {k: _decode(k, torch.cat([p[k] for p in parts])).to(device) for k in keys}

    # -- training ---------------------------------------------------------------------------
    def loss(self, batch: Batch) -> dict[str, Tensor]:
        import torch

        if not self.memories:
            return super().loss(batch)
        current = dict(batch)
        size = self.config.replay_batch_size or _length(current)
        device = next(iter(current.values())).device
        replay = self.replay_batch(size, device)
        missing = [k for k in replay if k not in current] + [k for k in current if k not in replay]
        if missing:
            raise ValueError(
                f"ER: current and replayed batches differ in key(s) {', '.join(sorted(set(missing)))}"
            )
        merged = {k: torch.cat([current[k], replay[k].to(current[k].dtype)]) for k in current}
        return {"bc": self.policy.loss(merged)}

    # -- checkpoints ------------------------------------------------------------------------
    def state_dict(self) -> dict[str, Any]:
        return {
            **super().state_dict(),
            "memories": {k: dict(m) for k, m in self.memories.items()},
            "fills": copy.deepcopy(self.fills),
            "rng": self.rng.bit_generator.state,
        }

    def load_state_dict(self, state: Mapping[str, Any]) -> None:
        super().load_state_dict(state)
        self.fills = copy.deepcopy(list(state.get("fills", [])))
        self.rng = np.random.default_rng()
        self.rng.bit_generator.state = state["rng"]
        if "memories" in state:
            self.memories = {int(k): dict(m) for k, m in state["memories"].items()}
        elif self.fills:  # saved without its windows: rebuilt from the data when first needed
            self._memories, self._rebuild = {}, True
        else:  # carried before any memory update (its first task): the memory is empty
            self.memories = {}


def without_memories(state: Mapping[str, Any]) -> dict[str, Any]:
    """An ER state (``ER.state_dict()``) without the memory's windows: the updates it records
    rebuild them from the data (:attr:`ER.task_data`). An empty memory (a run carried in its first
    task) has nothing to leave behind and is kept as it is."""
    if not state.get("memories"):
        return dict(state)
    if not state.get("fills"):
        raise ValueError(
            "this ER state records no memory updates (an older run): its memory cannot be rebuilt"
        )
    return {k: v for k, v in state.items() if k != "memories"}


def _length(memory: Mapping[str, Tensor]) -> int:
    return int(next(iter(memory.values())).shape[0]) if memory else 0
