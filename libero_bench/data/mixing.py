"""Training data mixed from several datasets: a run's tasks plus their variants.

``libero-bench run --data BASE --mix VARIANTS --mix-weight 0.5`` trains each task of the run on
its own demonstrations in BASE and on the episodes the ``--mix`` datasets hold of it: episodes of
the task itself and of its variants (tasks named ``<task>__<kind>`` or ``<task>__<kind>_l<level>``,
as ``libero-data generate --variants-of`` names them). A mixed episode keeps the embedding of its
own instruction (a reworded instruction is part of a language variant) and counts as its source
task in the run (task id, replay memories, evaluation).

**Weights.** An epoch has as many windows as the run's own data of the task(s) it trains, so a
mixed run takes the same gradient steps as an unmixed one. A share ``weight`` of each epoch's
windows comes from the mixed episodes, the rest from the run's own; each part is drawn without
replacement (the mixed windows cycle through fresh permutations when there are fewer than asked),
and the order depends only on the seed and the epoch. ``weight`` 0 trains on the run's data alone
(the mixed episodes still count as training starts).

**Held-out starts.** A task's held-out evaluation placements skip the reset seeds of every one of
its training episodes, the mixed ones included; the stored init states they began from are
counted in ``config.json`` (``evaluation.training_starts``) as the run's own are.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from libero_data.errors import DatasetError, InputError

if TYPE_CHECKING:
    from libero_bench.data.dataset import DemoDataset, DemoTask
    from libero_bench.data.windows import WindowDataset

#: between a task's name and a variant's kind (``libero_data.procedural.variants``)
VARIANT_SEPARATOR = "__"
DEFAULT_WEIGHT = 0.5


def check_weight(weight: float) -> float:
    if not (math.isfinite(weight) and 0.0 <= weight < 1.0):
        raise InputError(
            f"the mix weight is the share of each epoch drawn from the mixed data, in [0, 1); got {weight}",
            field="mix_weight",
        )
    return float(weight)


def belongs_to(name: str, task: str) -> bool:
    """Whether a dataset task named ``name`` is ``task`` or one of its variants."""
    return name == task or name.startswith(task + VARIANT_SEPARATOR)


@dataclass(frozen=True)
class MixEpisode:
    """One mixed episode: which dataset (index into :attr:`MixPlan.sources`), which episode,
    its task's name there and its instruction."""

    dataset: int
    episode: int
    task: str
    language: str


@dataclass
class MixPlan:
    """The mixed data of a run: the datasets, each run task's mixed episodes, the weight, and
    one embedding per distinct instruction (:attr:`languages`, rows of :attr:`embs`)."""

    sources: list[DemoDataset]
    weight: float
    episodes: dict[int, list[MixEpisode]]  # run position -> its mixed episodes
    languages: list[str]
    embs: np.ndarray

    def of(self, positions: Iterable[int]) -> list[tuple[int, MixEpisode]]:
        """The mixed episodes of the tasks at ``positions``, with each one's run position."""
        return [(pos, e) for pos in positions for e in self.episodes.get(pos, [])]

    def starts(self, position: int) -> tuple[set[int], set[int]]:
        """Where the mixed episodes of a task began: stored init indices and sampler seeds (an
        episode without a record of it is refused when the plan is made)."""
        return _starts(self.sources, [(e.dataset, e.episode) for e in self.episodes.get(position, [])])

    def config(self, tasks: Sequence[DemoTask], root: Path) -> dict[str, Any]:
        """The ``mix`` entry of the config.json of the run in ``root`` (datasets named relative to it)."""
        out: dict[str, Any] = {
            "weight": self.weight,
            "datasets": [
                {
                    "data": os.path.relpath(s.root.resolve(), root.resolve()),
                    "repo_id": s.repo_id,
                    "episodes": len(s.episode_meta),
                }
                for s in self.sources
            ],
            "tasks": {},
        }
        for pos, task in enumerate(tasks):
            chosen = self.episodes.get(pos, [])
            out["tasks"][task.name] = {
                "variants": sorted({e.task for e in chosen}),
                "episodes": [[e.dataset, e.episode] for e in chosen],
            }
        return out


def plan_mix(
    roots: Sequence[Path], weight: float, tasks: Sequence[DemoTask], base: DemoDataset, encoder: str
) -> MixPlan:
    """Open the mix datasets and pick each run task's episodes there (see the module docstring)."""
    from libero_bench.data.dataset import DemoDataset
    from libero_bench.data.language import encode_tasks

    weight = check_weight(weight)
    sources = [DemoDataset(root) for root in roots]
    episodes: dict[int, list[MixEpisode]] = {}
    for d, source in enumerate(sources):
        if source.fps != base.fps:
            raise DatasetError(
                f"{source.root} is recorded at {source.fps:g} fps and {base.root} at {base.fps:g}; "
                "mix datasets of one control rate"
            )
        for demo_task in source.tasks:
            owners = [pos for pos, t in enumerate(tasks) if belongs_to(demo_task.name, t.name)]
            if not owners:
                continue
            if source.training_starts(demo_task) is None:
                raise DatasetError(
                    f"{source.root} does not record where the episodes of {demo_task.name} started, "
                    "so held-out evaluation starts could not avoid them; mix datasets made by libero-data"
                )
            pos = max(owners, key=lambda p: len(tasks[p].name))  # the longest name that matches
            episodes.setdefault(pos, []).extend(
                MixEpisode(d, int(i), demo_task.name, demo_task.language) for i in demo_task.episodes
            )
    if not episodes:
        names = ", ".join(t.name for t in tasks)
        raise InputError(
            f"{', '.join(str(r) for r in roots)} hold(s) no episodes of {names} or of their variants "
            f"(tasks named <task>{VARIANT_SEPARATOR}<kind>...)",
            field="mix",
        )
    languages = sorted({e.language for chosen in episodes.values() for e in chosen})
    # with the run's instructions first: an encoder by task identity gives a shared one its id
    own = [t.language for t in tasks]
    embs = encode_tasks([*own, *languages], encoder)[len(own) :]
    return MixPlan(sources, weight, episodes, languages, np.asarray(embs, dtype=np.float32))


class MixedWindows:
    """The run's own windows (``base``) followed by the mixed ones (``mixed``, one
    :class:`~libero_bench.data.windows.WindowDataset` per mix dataset): a map-style dataset whose
    epochs are drawn by :meth:`epoch_indices` (see the module docstring for the weighting)."""

    def __init__(self, base: WindowDataset, mixed: Sequence[WindowDataset], weight: float) -> None:
        self.base = base
        self.mixed = [m for m in mixed if len(m)]
        self.weight = check_weight(weight)
        self.window = base.window
        self._offsets = np.cumsum([len(base), *(len(m) for m in self.mixed)]).tolist()

    @property
    def mixed_len(self) -> int:
        return self._offsets[-1] - len(self.base)

    def __len__(self) -> int:
        return int(self._offsets[-1])

    def epoch_len(self) -> int:
        return len(self.base)

    def mixed_count(self) -> int:
        """How many of an epoch's windows come from the mixed episodes."""
        return round(self.weight * len(self.base)) if self.mixed_len else 0

    def epoch_indices(self, seed: int) -> list[int]:
        """One epoch: indices into this dataset (base first, then mixed), in training order."""
        rng = np.random.default_rng(seed)
        n_base = len(self.base)
        k = self.mixed_count()
        own = rng.permutation(n_base)[: n_base - k]
        parts = [rng.permutation(self.mixed_len) for _ in range(math.ceil(k / self.mixed_len))] if k else []
        mixed = np.concatenate(parts)[:k] + n_base if parts else np.zeros(0, dtype=np.int64)
        order = np.concatenate([own, mixed])
        return [int(i) for i in order[rng.permutation(order.size)]]

    def is_mixed(self, index: int) -> bool:
        return index >= len(self.base)

    def preload(self) -> None:
        self.base.preload()
        for m in self.mixed:
            m.preload()

    @property
    def cached_bytes(self) -> int:
        return self.base.cached_bytes + sum(m.cached_bytes for m in self.mixed)

    def __getitem__(self, i: int) -> dict[str, Any]:
        if i < len(self.base):
            return self.base[i]
        for part, end in zip(self.mixed, self._offsets[1:], strict=True):
            if i < end:
                return part[i - (end - len(part))]
        raise IndexError(i)


def mixed_windows(
    base: WindowDataset,
    mix: MixPlan,
    positions: Sequence[int],
    task_embs: np.ndarray,
    window: int,
    image_size: int | None,
) -> MixedWindows:
    """The run's windows of ``positions`` plus their mixed episodes' (embeddings: the run's
    task embeddings followed by the mix's own instructions')."""
    from libero_bench.data.windows import WindowDataset

    embs = np.concatenate([np.asarray(task_embs, dtype=np.float32), mix.embs])
    rows = {language: len(task_embs) + i for i, language in enumerate(mix.languages)}
    parts = []
    for d, source in enumerate(mix.sources):
        chosen = [(pos, e) for pos, e in mix.of(positions) if e.dataset == d]
        if chosen:
            parts.append(
                WindowDataset(
                    source,
                    [e.episode for _, e in chosen],
                    [pos for pos, _ in chosen],
                    embs,
                    window,
                    image_size,
                    emb_rows=[rows[e.language] for _, e in chosen],
                )
            )
    return MixedWindows(base, parts, mix.weight)


def mixed_seeds(config: dict[str, Any], root: Path | None = None) -> dict[str, set[int]]:
    """Per task of a run (its ``config.json``; its folder ``root``, which relative dataset paths
    start from), the sampler seeds its mixed episodes began from; empty for a run that mixed nothing."""
    from libero_bench.data.dataset import DemoDataset

    mix = config.get("mix")
    if not mix:
        return {}
    sources = [DemoDataset(Path(root or ".") / d["data"]) for d in mix["datasets"]]
    return {name: _starts(sources, entry["episodes"])[1] for name, entry in mix["tasks"].items()}


def _starts(sources: Sequence[DemoDataset], episodes: Sequence[Sequence[int]]) -> tuple[set[int], set[int]]:
    """Where mixed episodes, given as (dataset, episode) pairs, began: stored init indices and
    sampler seeds (:meth:`DemoDataset.starts_of`; every episode records it: plan_mix refuses a
    dataset that does not)."""
    stored: set[int] = set()
    seeds: set[int] = set()
    for d, source in enumerate(sources):
        found = source.starts_of(episode for k, episode in episodes if k == d)
        if found is not None:
            stored |= found[0]
            seeds |= found[1]
    return stored, seeds
