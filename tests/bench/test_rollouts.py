"""One policy, many environments, in simulation: one batched forward pass per control step across
the environments, and every rollout index starting from the same state whatever the batch size."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow.parquet as pq
import pytest
import torch

from libero_bench.policies import make_policy
from libero_bench.rollouts.actors import ActionQueues, BatchActor, Observations, PolicyActor, Start
from libero_bench.rollouts.jobs import EvalTask, RolloutJob, make_job
from libero_bench.rollouts.loop import RolloutResources
from libero_bench.runs.folder import HELDOUT, STORED
from libero_data.record.features import SIM_STATE
from libero_data.seeding import heldout_starts
from libero_data.tasks import get_task

pytestmark = pytest.mark.sim

TASK = "libero_object/0"
STEPS = 3
SIZE = 32


def jobs_of(root: Path, steps: int = STEPS) -> list[RolloutJob]:
    """Two rollouts from stored init states and two from held-out placements, ``steps`` steps each."""
    task = get_task(TASK)
    states = task.init_states()
    eval_task = EvalTask(
        name=task.name,
        language=task.language,
        position=0,
        env_ref=str(task.bddl_path),
        task_emb=np.zeros(384, dtype=np.float32),
        init_states=states,
        heldout=tuple(heldout_starts(task.name, 2)),
    )
    return [
        make_job(
            eval_task,
            r,
            key=f"{start}-{r}",
            settle=2,
            max_steps=steps,
            image_size=SIZE,
            sim_state_width=states.shape[1],
            shard_dir=f"shards/{start}-{r}",
            rrd_path=f"rrd/{start}-{r}.rrd",
            tags={"test": True},
            start=start,
        )
        for start in (STORED, HELDOUT)
        for r in range(2)
    ]


class CountingActor(PolicyActor):
    """Notes how many environments each call of ``act`` served."""

    def __init__(self, policy: Any) -> None:
        super().__init__(policy)
        self.widths: list[int] = []

    def act(self, observations: Observations) -> dict[int, np.ndarray]:
        self.widths.append(len(observations))
        return super().act(observations)


def frames(shard: Path, column: str) -> np.ndarray:
    (data,) = sorted((shard / "data").rglob("*.parquet"))
    return np.stack(pq.read_table(data).column(column).to_pylist())


def test_one_batched_pass_per_turn_and_the_same_starts_with_batch_sizes_1_and_3(tmp_path: Path) -> None:
    torch.manual_seed(0)
    policy = make_policy("resnet_t", "smoke", image_size=SIZE)
    counts = {}
    for batch in (1, 3):
        root = tmp_path / f"b{batch}"
        jobs = jobs_of(root)
        actor = CountingActor(policy)
        with RolloutResources(batch_size=batch).open(root) as environments:
            results = dict(environments.run(actor, jobs))
        assert sorted(results) == [0, 1, 2, 3] and all(r.steps == STEPS for r in results.values())
        # One call, one forward pass, per turn, over every running environment of the group.
        assert actor.forwards == len(actor.widths) and actor.rows == sum(actor.widths) == 4 * STEPS
        counts[batch] = actor.widths
    assert counts[1] == [1] * (4 * STEPS)
    # Three slots in one worker: halves {0, 2} and {1} take turns; when slots 0 and 2 are done,
    # the fourth rollout takes slot 0 and the halves' turns carry one slot each.
    assert counts[3] == [2, 1] * STEPS + [1] * STEPS
    for job in jobs_of(tmp_path):
        alone, batched = (tmp_path / f"b{b}" / job.shard_dir for b in (1, 3))
        # Rollout r starts from the same state, bit for bit, whatever the batch size.
        np.testing.assert_array_equal(frames(alone, SIM_STATE)[0], frames(batched, SIM_STATE)[0])
        # The actions agree up to the last bits a batched matrix product may change.
        np.testing.assert_allclose(frames(alone, "action")[0], frames(batched, "action")[0], atol=1e-4)


class ChunkActor(BatchActor):
    """Chunks of 5 actions, each a function of the observed state it answers: the same
    observations give the same actions, whatever turn or batch they come in."""

    chunk_size = 5

    def __init__(self) -> None:
        super().__init__()
        self.queues = ActionQueues()
        self.asked: dict[int, int] = {}  # slot -> observations looked at in its episode

    def begin(self, slot: int, start: Start) -> None:
        self.queues.clear(slot)
        self.asked[slot] = 0

    def end(self, slot: int, success: bool | None = None) -> None:
        self.queues.drop(slot)

    def act(self, observations: Observations) -> dict[int, np.ndarray]:
        waiting = self.queues.waiting(observations)
        for slot in waiting:
            state = np.asarray(observations[slot]["state"], dtype=np.float64)[:7]
            self.queues.fill(slot, np.stack([np.tanh(10 * state) * 0.3 * (k + 1) / 5 for k in range(5)]))
            self.asked[slot] += 1
        if waiting:
            self.counted(len(waiting))
        return {slot: self.queues.pop(slot) for slot in observations}

    def looks(self, slot: int) -> bool:
        return self.queues.empty(slot)

    def ahead(self, slot: int) -> list[np.ndarray]:
        return self.queues.take(slot)


def test_halves_taking_turns_and_chunks_stepped_in_one_call_change_no_rollout(tmp_path: Path) -> None:
    steps = 12  # chunks of 5: the policy looks after steps 5 and 10, at the start and nowhere else
    runs = {}
    for batch in (1, 2):  # one environment; two in halves that take turns in one worker
        root = tmp_path / f"b{batch}"
        jobs = jobs_of(root, steps)[:3]
        actor = ChunkActor()
        with RolloutResources(batch_size=batch).open(root) as environments:
            runs[batch] = dict(environments.run(actor, jobs))
        assert sorted(runs[batch]) == [0, 1, 2] and all(r.steps == steps for r in runs[batch].values())
        assert actor.rows == 3 * 3  # three looks per rollout: never asked at a queued step
    for job in jobs_of(tmp_path, steps)[:3]:
        alone, turns = (tmp_path / f"b{b}" / job.shard_dir for b in (1, 2))
        for column in (SIM_STATE, "action"):  # the same rollout, bit for bit
            np.testing.assert_array_equal(frames(alone, column), frames(turns, column))
        info = json.loads((turns / "episode.json").read_text())
        assert info["held_images"] == steps - 2  # drawn only where the policy looked (steps 5, 10)


def test_a_rollouts_videos_are_h264_and_read_back_through_lerobot(tmp_path: Path) -> None:
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    from libero_bench.rollouts.episodes import ROLLOUT_VIDEO

    job = jobs_of(tmp_path, 6)[0]
    with RolloutResources(batch_size=1).open(tmp_path) as environments:
        list(environments.run(ChunkActor(), [job]))
    shard = tmp_path / job.shard_dir
    features = json.loads((shard / "meta" / "info.json").read_text())["features"]
    videos = {k: v["info"] for k, v in features.items() if v["dtype"] == "video"}
    assert len(videos) == 2 and all(v["video.codec"] == ROLLOUT_VIDEO["vcodec"] for v in videos.values())
    dataset = LeRobotDataset("libero-data/shard", root=shard)
    assert len(dataset) == 6
    for key in videos:
        image = dataset[5][key]  # decoded at its timestamp: an upright picture, not a blank
        assert tuple(image.shape) == (3, SIZE, SIZE) and float(image.std()) > 0.01
