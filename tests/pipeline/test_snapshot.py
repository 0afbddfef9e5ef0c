"""A snapshot reads its shards' episode tables in memory: the same tables LeRobot reads, and
nothing written into ``datasets``' cache under the user's home."""

from __future__ import annotations

from pathlib import Path

import pytest


def _files(folder: Path) -> list[Path]:
    return sorted(p for p in folder.rglob("*") if p.is_file()) if folder.exists() else []


def test_episode_tables_read_in_memory_are_lerobots(tiny_dataset: Path) -> None:
    from lerobot.datasets.io_utils import load_episodes

    from libero_data.pipeline.snapshot import read_episodes

    theirs, ours = load_episodes(tiny_dataset), read_episodes(tiny_dataset)
    assert ours.features == theirs.features and list(ours.features) == list(theirs.features)
    assert ours.to_dict() == theirs.to_dict() and ours.num_rows == 2


def test_aggregating_writes_nothing_into_the_datasets_cache(
    tiny_dataset: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import datasets.config
    from lerobot.datasets.aggregate import aggregate_datasets
    from lerobot.datasets.dataset_metadata import LeRobotDatasetMetadata

    from libero_data.pipeline.snapshot import episodes_in_memory

    cache = tmp_path / "hf-datasets-cache"
    monkeypatch.setattr(datasets.config, "HF_DATASETS_CACHE", cache)
    with episodes_in_memory():
        aggregate_datasets(
            ["a", "b"],
            "joined",
            roots=[tiny_dataset, tiny_dataset],
            aggr_root=tmp_path / "joined",
            concatenate_videos=False,
            concatenate_data=False,
        )
        assert LeRobotDatasetMetadata("joined", root=tmp_path / "joined").episodes.num_rows == 4
    assert _files(cache) == []
    # what LeRobot does without it: an Arrow cache of the table under the cache folder
    LeRobotDatasetMetadata("again", root=tiny_dataset)
    assert _files(cache) != []
