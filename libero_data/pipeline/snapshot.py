"""Building a complete dataset snapshot from finished episode shards.

The shards (one LeRobot dataset per episode, see :mod:`libero_data.record.shard`) are
joined with lerobot's own ``aggregate_datasets``, keeping one data and video file per
episode; the MCAP logs, our per-episode metadata, the tasks' BDDL files and the card are
added, and every entry is stamped with the snapshot's id for :mod:`publish`.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
import os
import shutil
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

from libero_data.cards.card import with_data_size
from libero_data.pipeline.publish import stamp
from libero_data.provenance import compact_row
from libero_data.record.shard import INFO_NAME, MCAP_NAME, SHARD_REPO

EPISODES_META = "libero_episodes.jsonl"
DATASET_META = "libero.json"


def build_snapshot(
    shards: list[Path],
    out: Path,
    *,
    repo_id: str,
    snapshot_id: str,
    dataset_meta: dict[str, Any],
    bddl: dict[str, str],
    card: str,
    files: Mapping[str, bytes] | None = None,
) -> list[dict[str, Any]]:
    """Write a snapshot of ``shards`` (in order) into ``out``; returns the episodes' metadata.
    ``files`` (the card's pictures) are written by their paths inside ``meta/``."""
    from lerobot.datasets.aggregate import aggregate_datasets

    if out.exists():
        shutil.rmtree(out)
    if not shards:
        raise RuntimeError("a snapshot needs at least one episode")
    # aggregate_datasets draws progress bars; it reads each shard's episode table in memory
    with contextlib.redirect_stderr(io.StringIO()), episodes_in_memory():
        aggregate_datasets(
            [SHARD_REPO] * len(shards),
            repo_id,
            roots=list(shards),
            aggr_root=out,
            concatenate_videos=False,
            concatenate_data=False,
        )
    # LeRobot aggregates the statistics over a set of feature names, whose order changes from
    # process to process (string hashing): the same content is written in one order.
    stats = out / "meta" / "stats.json"
    stats.write_text(json.dumps(json.loads(stats.read_text()), indent=4, sort_keys=True))
    (out / "mcap").mkdir()
    episodes = []
    for index, shard in enumerate(shards):
        info = json.loads((shard / INFO_NAME).read_text())
        info["episode_index"] = index
        episodes.append(info)
        _link(shard / MCAP_NAME, out / "mcap" / f"episode_{index:06d}.mcap")
    meta = out / "meta"
    rows = [compact_row(e) for e in episodes]
    (meta / EPISODES_META).write_text("".join(json.dumps(r, sort_keys=True) + "\n" for r in rows))
    (meta / DATASET_META).write_text(json.dumps(dataset_meta, indent=2, sort_keys=True) + "\n")
    (meta / "bddl").mkdir()
    for name, text in bddl.items():
        (meta / "bddl" / f"{name}.bddl").write_text(text)
    for relative, data in (files or {}).items():
        path = out / relative
        if path.parent != meta:  # only meta/ is published whole with the card
            raise ValueError(f"a dataset's card files belong in meta/, not {relative}")
        path.write_bytes(data)
    data_bytes = sum(p.stat().st_size for p in (out / "data").rglob("*.parquet"))
    (out / "README.md").write_text(with_data_size(card, data_bytes))
    stamp(out, snapshot_id)
    return episodes


@contextlib.contextmanager
def episodes_in_memory() -> Iterator[None]:
    """Within the block, LeRobot's dataset metadata reads a dataset's episode table straight
    into memory (:func:`read_episodes`) instead of through ``datasets.Dataset.from_parquet``.

    ``from_parquet`` converts every file into an Arrow cache under the user's
    ``~/.cache/huggingface/datasets`` (outside the folders a command is given, one more entry per
    shard and snapshot, never removed), for every shard at every snapshot. The table is the same:
    its rows and its features (tests/pipeline/test_snapshot.py).
    """
    from lerobot.datasets import dataset_metadata

    original = dataset_metadata.load_episodes
    dataset_metadata.load_episodes = read_episodes
    try:
        yield
    finally:
        dataset_metadata.load_episodes = original


def read_episodes(root: Path) -> Any:
    """A LeRobot dataset's episode table (``meta/episodes``) as LeRobot's ``load_episodes`` gives
    it (a ``datasets.Dataset`` without the per-episode statistics columns), read into memory."""
    import datasets
    import pyarrow as pa
    import pyarrow.parquet as pq
    from datasets.table import InMemoryTable
    from lerobot.datasets.utils import EPISODES_DIR

    paths = sorted((Path(root) / EPISODES_DIR).glob("*/*.parquet"))
    if not paths:
        raise FileNotFoundError(f"{Path(root) / EPISODES_DIR} holds no parquet file")
    table = pa.concat_tables([pq.read_table(path) for path in paths])
    # named by the files it was read from (``datasets`` would otherwise pickle the whole table to name it)
    files = "\n".join(f"{path}:{path.stat().st_size}:{path.stat().st_mtime_ns}" for path in paths)
    fingerprint = hashlib.sha256(files.encode()).hexdigest()[:16]
    episodes = datasets.Dataset(InMemoryTable(table), fingerprint=fingerprint)
    return episodes.select_columns([key for key in episodes.features if not key.startswith("stats/")])


def _link(src: Path, dst: Path) -> None:
    try:
        os.link(src, dst)
    except OSError:
        shutil.copy2(src, dst)
