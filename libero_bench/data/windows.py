"""Training batches: windows of consecutive frames over a dataset's episodes, and loaders.

A :class:`WindowDataset` turns the episodes of one or more tasks into training samples: every
window of ``T`` consecutive frames that lies inside one episode (starts ``0 .. length - T``),
with both cameras, joint and gripper states, actions, the task's language embedding and the
task's id in the run. Each episode is decoded once (:meth:`DemoDataset.load_episode
<libero_bench.data.dataset.DemoDataset.load_episode>`) and kept for the life of the dataset.

:class:`TaskLoader` gives device batches, one shuffled epoch per iteration; the order depends
only on the seed and the epoch number (:func:`libero_data.seeding.loader_epoch_seed`).
DataLoader workers share the decoded frames (fork, copy-on-write) and never decode; see
:mod:`libero_bench.data.dataset` for the memory this takes.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping, Sequence
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from libero_bench.data.batch_keys import (
    ACTIONS,
    AGENTVIEW,
    GRIPPER_STATES,
    IMAGE_KEYS,
    JOINT_STATES,
    TASK_EMB,
    TASK_ID,
    WRIST,
)
from libero_bench.data.dataset import DemoDataset, EpisodeFrames
from libero_data.errors import DatasetError
from libero_data.seeding import loader_epoch_seed

if TYPE_CHECKING:
    import torch
    from torch.utils.data import DataLoader


class EpochWindows(Protocol):
    """Windows whose epochs the dataset draws itself (:class:`libero_bench.data.mixing.MixedWindows`):
    ``epoch_len`` of them in the order ``epoch_indices(seed)``."""

    window: int

    def __len__(self) -> int: ...
    def __getitem__(self, i: int) -> dict[str, Any]: ...
    def preload(self) -> None: ...
    def epoch_len(self) -> int: ...
    def epoch_indices(self, seed: int) -> list[int]: ...


class WindowDataset:
    """Windows of ``window`` consecutive frames over some episodes (a map-style torch dataset).

    ``episodes[i]`` belongs to the run's task ``task_ids[i]`` whose embedding is
    ``task_embs[task_ids[i]]`` (or ``task_embs[emb_rows[i]]``: an episode of a reworded variant
    of the task, :mod:`libero_bench.data.mixing`). Sample ``j`` is the ``j``-th (episode, start) pair
    in episode order; images are uint8 here (see :func:`batch_to_device`).
    """

    def __init__(
        self,
        source: DemoDataset,
        episodes: Sequence[int],
        task_ids: Sequence[int],
        task_embs: np.ndarray,
        window: int,
        image_size: int | None = None,
        *,
        emb_rows: Sequence[int] | None = None,
    ) -> None:
        if len(episodes) != len(task_ids) or (emb_rows is not None and len(emb_rows) != len(task_ids)):
            raise ValueError("episodes, task_ids and emb_rows must have the same length")
        if window <= 0:
            raise ValueError(f"window must be positive, got {window}")
        self.source = source
        self.episodes = [int(e) for e in episodes]
        self.task_ids = [int(t) for t in task_ids]
        self.emb_rows = [int(r) for r in emb_rows] if emb_rows is not None else self.task_ids
        self.task_embs = np.asarray(task_embs, dtype=np.float32)
        self.window = window
        self.image_size = image_size or source.image_size
        self._frames: dict[int, EpisodeFrames] = {}
        index: list[tuple[int, int]] = []
        for slot, episode in enumerate(self.episodes):
            length = source.episode_length(episode)
            index.extend((slot, start) for start in range(length - window + 1))
        self.index = index

    def __len__(self) -> int:
        return len(self.index)

    def frames(self, slot: int) -> EpisodeFrames:
        """The decoded frames of ``episodes[slot]`` (decoded on first use, then cached)."""
        cached = self._frames.get(slot)
        if cached is None:
            cached = self.source.load_episode(self.episodes[slot], self.image_size)
            self._frames[slot] = cached
        return cached

    def preload(self) -> None:
        """Decode every episode now (once), e.g. before DataLoader workers fork."""
        for slot in range(len(self.episodes)):
            self.frames(slot)

    @property
    def cached_bytes(self) -> int:
        return sum(
            f.agentview.numel()
            + f.wrist.numel()
            + 4 * (f.joint_states.size + f.gripper_states.size + f.actions.size)
            for f in self._frames.values()
        )

    def __getitem__(self, i: int) -> dict[str, Any]:
        import torch

        slot, start = self.index[i]
        f = self.frames(slot)
        end = start + self.window
        task_id = self.task_ids[slot]
        return {
            AGENTVIEW: f.agentview[start:end],
            WRIST: f.wrist[start:end],
            JOINT_STATES: torch.from_numpy(f.joint_states[start:end]),
            GRIPPER_STATES: torch.from_numpy(f.gripper_states[start:end]),
            ACTIONS: torch.from_numpy(f.actions[start:end]),
            TASK_EMB: torch.from_numpy(self.task_embs[self.emb_rows[slot]]),
            TASK_ID: torch.tensor(task_id, dtype=torch.int64),
        }


def worker_init(_worker_id: int) -> None:
    """DataLoader worker set-up: one thread, and no video decoder inherited through fork."""
    import torch

    torch.set_num_threads(1)
    try:
        from lerobot.datasets.video_utils import _default_decoder_cache

        _default_decoder_cache.clear()
    except (ImportError, AttributeError):  # another lerobot version: nothing to clear
        pass


def window_loader(
    dataset: WindowDataset | EpochWindows,
    batch_size: int,
    *,
    shuffle: bool,
    seed: int,
    workers: int = 0,
    multiprocessing_context: str | None = None,
    order: Sequence[int] | None = None,
) -> DataLoader:
    """A DataLoader over ``dataset`` whose order depends only on ``seed`` (or is ``order``, the
    sample indices of one epoch, as :class:`~libero_bench.data.mixing.MixedWindows` draws them).

    The episodes are decoded here, in the calling process, before any worker starts.
    """
    import torch
    from torch.utils.data import DataLoader

    dataset.preload()
    generator = torch.Generator().manual_seed(seed)
    return DataLoader(
        dataset,  # type: ignore[arg-type]
        batch_size=batch_size,
        shuffle=shuffle if order is None else False,
        sampler=list(order) if order is not None else None,
        generator=generator,
        num_workers=workers,
        worker_init_fn=worker_init if workers else None,
        multiprocessing_context=multiprocessing_context if workers else None,
        persistent_workers=False,
        drop_last=False,
    )


def batch_to_device(batch: Mapping[str, torch.Tensor], device: torch.device | str) -> dict[str, torch.Tensor]:
    """Move a collated batch to ``device``; uint8 images become float32 in [0, 1] there."""
    import torch

    out: dict[str, torch.Tensor] = {}
    for key, value in batch.items():
        value = value.to(device, non_blocking=True)
        if key in IMAGE_KEYS and value.dtype == torch.uint8:
            value = value.float().div_(255.0)
        out[key] = value
    return out


class TaskLoader:
    """Iterable of device batches (float images) over a :class:`WindowDataset`; each
    iteration is one epoch, shuffled from ``seed`` and the epoch number."""

    def __init__(
        self,
        dataset: WindowDataset | EpochWindows,
        batch_size: int,
        device: torch.device | str,
        *,
        seed: int,
        shuffle: bool = True,
        workers: int = 0,
    ) -> None:
        if len(dataset) == 0:
            raise DatasetError(f"no training windows: every episode is shorter than {dataset.window} frames")
        self.dataset = dataset
        self.batch_size = batch_size
        self.device = device
        self.seed = seed
        self.shuffle = shuffle
        self.workers = workers
        self.epoch = 0
        dataset.preload()

    def __len__(self) -> int:
        epoch_len = getattr(self.dataset, "epoch_len", None)  # mixed data: the run's own windows
        return math.ceil((epoch_len() if epoch_len else len(self.dataset)) / self.batch_size)

    def set_epoch(self, epoch: int) -> None:
        self.epoch = epoch

    def __iter__(self) -> Iterator[dict[str, torch.Tensor]]:
        seed = loader_epoch_seed(self.seed, self.epoch)
        epoch_indices = getattr(self.dataset, "epoch_indices", None)
        loader = window_loader(
            self.dataset,
            self.batch_size,
            shuffle=self.shuffle,
            seed=seed,
            workers=self.workers,
            order=epoch_indices(seed) if epoch_indices else None,
        )
        for batch in loader:
            yield batch_to_device(batch, self.device)
