"""The training loader: windows inside episodes, shapes and ranges, one decode per episode,
worker processes."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import torch

from libero_bench.data.dataset import DemoDataset
from libero_bench.data.windows import TaskLoader, WindowDataset, batch_to_device, window_loader
from libero_data.errors import DatasetError, MissingFileError

pytestmark = pytest.mark.sim  # needs the generated tiny dataset

WINDOW = 10


def _lengths(root: Path) -> list[int]:
    rows = [json.loads(line) for line in (root / "meta" / "libero_episodes.jsonl").read_text().splitlines()]
    return [int(r["length"]) for r in rows]


def _embs() -> np.ndarray:
    return np.random.default_rng(0).standard_normal((2, 384)).astype(np.float32)


def test_tasks_and_episodes(tiny_dataset: Path) -> None:
    source = DemoDataset(tiny_dataset)
    assert [t.name for t in source.tasks] == ["open_the_middle_drawer_of_the_cabinet", "turn_on_the_stove"]
    assert [t.suite_index for t in source.tasks] == [0, 7]
    assert source.task("7").name == "turn_on_the_stove"
    assert source.task("open_the_middle_drawer_of_the_cabinet").episodes == (0,)
    assert source.image_size == 64 and source.sim_state_width > 0
    with pytest.raises(ValueError, match="no task 'put_the_bowl'"):
        source.task("put_the_bowl")


def test_windows_lie_inside_one_episode_and_match_the_data(tiny_dataset: Path) -> None:
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    source = DemoDataset(tiny_dataset)
    lengths = _lengths(tiny_dataset)
    data = WindowDataset(source, [0, 1], [0, 1], _embs(), WINDOW)
    assert len(data) == sum(n - WINDOW + 1 for n in lengths)
    assert data.index[0] == (0, 0) and data.index[-1] == (1, lengths[1] - WINDOW)

    reference = LeRobotDataset("libero-data/libero_goal", root=tiny_dataset)
    # the last window of episode 0 ends on its last frame; the next starts episode 1
    last = lengths[0] - WINDOW
    sample = data[last]
    rows = [reference[i] for i in range(last, last + WINDOW)]
    np.testing.assert_array_equal(sample["actions"].numpy(), np.stack([r["action"].numpy() for r in rows]))
    np.testing.assert_array_equal(
        sample["joint_states"].numpy(), np.stack([r["libero.joint_positions"].numpy() for r in rows])
    )
    np.testing.assert_array_equal(
        sample["gripper_states"].numpy(), np.stack([r["libero.gripper_state"].numpy() for r in rows])
    )
    decoded = sample["agentview"].float() / 255.0
    expected = torch.stack([r["observation.images.image"] for r in rows])
    assert torch.allclose(decoded, expected, atol=1.0 / 255 + 1e-6)
    wrist = torch.stack([r["observation.images.wrist_image"] for r in rows])
    assert torch.allclose(sample["wrist"].float() / 255.0, wrist, atol=1.0 / 255 + 1e-6)
    first_of_next = data[last + 1]
    assert int(first_of_next["task_id"]) == 1
    np.testing.assert_array_equal(
        first_of_next["actions"][0].numpy(), reference[lengths[0]]["action"].numpy()
    )
    np.testing.assert_array_equal(first_of_next["task_emb"].numpy(), _embs()[1])


def test_batches_are_float_images_and_each_episode_is_decoded_once(tiny_dataset: Path) -> None:
    source = DemoDataset(tiny_dataset)
    data = WindowDataset(source, [0, 1], [0, 1], _embs(), WINDOW)
    loader = TaskLoader(data, 16, "cpu", seed=0)
    seen = 0
    for epoch in range(2):
        loader.set_epoch(epoch)
        for batch in loader:
            b = batch["agentview"].shape[0]
            assert batch["agentview"].shape == (b, WINDOW, 3, 64, 64)
            assert batch["wrist"].shape == (b, WINDOW, 3, 64, 64)
            assert batch["agentview"].dtype == torch.float32
            assert float(batch["agentview"].min()) >= 0.0 and float(batch["agentview"].max()) <= 1.0
            assert batch["joint_states"].shape == (b, WINDOW, 7)
            assert batch["gripper_states"].shape == (b, WINDOW, 2)
            assert batch["actions"].shape == (b, WINDOW, 7)
            assert batch["task_emb"].shape == (b, 384)
            assert batch["task_id"].dtype == torch.int64
            seen += b
    assert seen == 2 * len(data)
    assert source.decode_count == 2  # two episodes, decoded once each over two epochs
    assert data.cached_bytes >= sum(_lengths(tiny_dataset)) * 2 * 3 * 64 * 64


def test_order_depends_only_on_the_seed(tiny_dataset: Path) -> None:
    source = DemoDataset(tiny_dataset)
    data = WindowDataset(source, [0], [0], _embs(), WINDOW)

    def first_actions(seed: int) -> torch.Tensor:
        return next(iter(window_loader(data, 8, shuffle=True, seed=seed)))["actions"]

    assert torch.equal(first_actions(5), first_actions(5))
    assert not torch.equal(first_actions(5), first_actions(6))


@pytest.mark.parametrize("context", [None, "spawn"])
def test_worker_processes(tiny_dataset: Path, context: str | None) -> None:
    """Fork workers share the decoded cache; spawn workers get it pickled. Nobody re-decodes."""
    source = DemoDataset(tiny_dataset)
    data = WindowDataset(source, [1], [0], _embs(), WINDOW)
    single = [b["actions"] for b in window_loader(data, 8, shuffle=True, seed=3)]
    workers = 2 if context is None else 1
    loader = window_loader(data, 8, shuffle=True, seed=3, workers=workers, multiprocessing_context=context)
    batches = [batch_to_device(b, "cpu") for b in loader]
    assert len(batches) == len(single)
    for got, want in zip(batches, single, strict=True):
        assert torch.equal(got["actions"], want)
        assert got["agentview"].dtype == torch.float32
    assert source.decode_count == 1


def test_resized_images(tiny_dataset: Path) -> None:
    source = DemoDataset(tiny_dataset)
    frames = source.load_episode(1, image_size=32)
    assert frames.agentview.shape[1:] == (3, 32, 32) and frames.agentview.dtype == torch.uint8
    assert len(frames) == _lengths(tiny_dataset)[1]


def test_not_a_dataset(tmp_path: Path) -> None:
    with pytest.raises(MissingFileError, match="does not exist"):
        DemoDataset(tmp_path / "missing")
    with pytest.raises(DatasetError, match="not a LeRobot dataset"):
        DemoDataset(tmp_path)
