"""Datasets made before the libero.* columns (issue 75) are still read: the joints, the gripper,
the end-effector pose and the MuJoCo state under observation.*, the state as float64. The tiny
dataset is rewritten that way and read back by the training loader and the replay reader."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from libero_data.record.features import SIM_STATE, StoredColumns

#: Each libero.* column -> where a dataset made before kept it.
LEGACY_KEYS = {getattr(StoredColumns(), f): old for f, old in StoredColumns.legacy.items()}

pytestmark = pytest.mark.sim  # needs the generated tiny dataset


def _as_made_before(new: Path, old: Path) -> None:
    shutil.copytree(new, old)
    for path in sorted((old / "data").glob("*/*.parquet")):
        table = pq.read_table(path)
        columns = {}
        for name in table.column_names:
            column = table.column(name)
            if name == SIM_STATE:  # int64 bit patterns -> float64 values
                rows = np.stack(column.to_numpy(zero_copy_only=False)).view(np.float64)
                column = pa.array(list(rows), type=pa.list_(pa.float64(), rows.shape[1]))
            columns[LEGACY_KEYS.get(name, name)] = column
        pq.write_table(pa.table(columns), path)
    info_path = old / "meta" / "info.json"
    info = json.loads(info_path.read_text())
    features = {LEGACY_KEYS.get(k, k): v for k, v in info["features"].items()}
    features[LEGACY_KEYS[SIM_STATE]]["dtype"] = "float64"
    info["features"] = features
    info_path.write_text(json.dumps(info, indent=4))


def test_a_dataset_made_before_reads_as_a_new_one(tiny_dataset: Path, tmp_path: Path) -> None:
    from libero_bench.data.dataset import DemoDataset
    from libero_data.pipeline.resimulate import stored_episode

    old = tmp_path / "old"
    _as_made_before(tiny_dataset, old)
    assert "observation.sim_state" in json.loads((old / "meta" / "info.json").read_text())["features"]
    new_source, old_source = DemoDataset(tiny_dataset), DemoDataset(old)
    assert old_source.sim_state_width == new_source.sim_state_width
    a, b = new_source.load_episode(0), old_source.load_episode(0)
    np.testing.assert_array_equal(a.joint_states, b.joint_states)
    np.testing.assert_array_equal(a.gripper_states, b.gripper_states)
    np.testing.assert_array_equal(a.actions, b.actions)
    info_new = json.loads((tiny_dataset / "meta" / "info.json").read_text())
    info_old = json.loads((old / "meta" / "info.json").read_text())
    episode = {"episode_index": 0, "data/chunk_index": 0, "data/file_index": 0}
    actions_new, states_new = stored_episode(tiny_dataset, info_new, episode)
    actions_old, states_old = stored_episode(old, info_old, episode)
    np.testing.assert_array_equal(actions_new, actions_old)
    np.testing.assert_array_equal(states_new, states_old)  # the float64 states, bit for bit
    assert states_new.dtype == np.float64 and np.all(np.isfinite(states_new))
