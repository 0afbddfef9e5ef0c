"""Building a complete dataset snapshot from finished episode shards.

The shards (one LeRobot dataset per episode, see :mod:`libero_data.record.shard`) are
joined with lerobot's own ``aggregate_datasets``, keeping one data and video file per
episode; the MCAP logs, our per-episode metadata, the tasks' BDDL files and the card are
added, and every entry is stamped with the snapshot's id for :mod:`publish`.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import shutil
from collections.abc import Mapping
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
    with contextlib.redirect_stderr(io.StringIO()):  # aggregate_datasets draws progress bars
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


def _link(src: Path, dst: Path) -> None:
    try:
        os.link(src, dst)
    except OSError:
        shutil.copy2(src, dst)
