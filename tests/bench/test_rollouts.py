"""One policy, many environments, in simulation: one batched forward pass per control step across
the environments, and every rollout index starting from the same state whatever the batch size."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pyarrow.parquet as pq
import pytest
import torch

from libero_bench.policies import make_policy
from libero_bench.rollouts.actors import Observations, PolicyActor
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


def jobs_of(root: Path) -> list[RolloutJob]:
    """Two rollouts from stored init states and two from held-out placements, STEPS steps each."""
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
            max_steps=STEPS,
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


def test_one_batched_pass_per_step_and_the_same_starts_with_batch_sizes_1_and_3(tmp_path: Path) -> None:
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
        # One call, one forward pass, per control step, over every environment then running.
        assert actor.forwards == len(actor.widths) and actor.rows == sum(actor.widths) == 4 * STEPS
        counts[batch] = actor.widths
    assert counts[1] == [1] * (4 * STEPS)
    assert counts[3] == [3] * STEPS + [1] * STEPS  # three run together; the fourth takes a freed slot
    for job in jobs_of(tmp_path):
        alone, batched = (tmp_path / f"b{b}" / job.shard_dir for b in (1, 3))
        # Rollout r starts from the same state, bit for bit, whatever the batch size.
        np.testing.assert_array_equal(frames(alone, SIM_STATE)[0], frames(batched, SIM_STATE)[0])
        # The actions agree up to the last bits a batched matrix product may change.
        np.testing.assert_allclose(frames(alone, "action")[0], frames(batched, "action")[0], atol=1e-4)
