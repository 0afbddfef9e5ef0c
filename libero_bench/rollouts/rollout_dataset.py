"""The rollout dataset of an evaluation or a run: its rollouts joined into one LeRobot dataset.

Each rollout was written as a one-episode shard by the job that ran it
(:mod:`libero_bench.rollouts.episodes`); :func:`build_rollout_dataset` joins them, in
rollout-key order, with the card below. ``datasets.load_dataset`` reads the result.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from libero_data.errors import RunError

#: The Hub card's YAML front matter of a rollout dataset (its ``{frames}`` filled in).
FRONT_MATTER = """---
license: mit
task_categories:
- robotics
tags:
- LeRobot
- LIBERO
- libero-bench
- policy-rollouts
dataset_info:
  splits:
  - name: train
    num_examples: {frames}
configs:
- config_name: default
  data_files: data/*/*.parquet
---
"""

ROLLOUT_CARD = (
    FRONT_MATTER
    + """
# Evaluation rollouts of a libero-bench run

Every evaluation rollout of the run `{run}` ({algo} + {policy}, preset `{preset}`, seed {seed}):
{episodes} episodes over {tasks} tasks, recorded like demonstrations (both cameras, 8-D state,
joint positions, gripper state, 7-D actions and the MuJoCo state of every frame; videos in H.264,
cheaper to write during an evaluation than the demonstrations' AV1).

`meta/libero_episodes.jsonl` tags each episode with its task (`task_name`, `task_position`),
the task learned last when it ran (`learned_after`, `learned_after_position`), the training
epoch (`epoch`; null for the evaluations after later tasks), the phase (`learning`, `after`,
`pruned`), the run seed, the init state (`init_index`, `env_seed`) and `success`.
Each episode has an MCAP log in `mcap/`; the run folder has a Rerun recording per rollout.
"""
)


EVAL_CARD = (
    FRONT_MATTER
    + """
# Rollouts of a policy evaluation

Every rollout of the evaluation `{run}`: the {policy_type} policy `{policy}` under the {protocol}
protocol, {episodes} over {tasks}, recorded like demonstrations (both cameras, 8-D state, joint
positions, gripper state, 7-D actions and the MuJoCo state of every frame; videos in H.264,
cheaper to write during an evaluation than the demonstrations' AV1). The evaluation's
`report.md` beside this folder gives the success rates with their intervals.

`meta/libero_episodes.jsonl` tags each episode with its task (`task_name`, `task_position`), the
kind of start (`start`: `stored` for LIBERO's stored init states, `heldout` for placements no
training demonstration began from, `standard` for the standard protocol's episode i from stored
init state i), the init state (`init_index`, `env_seed`) and `success`. Each episode has an MCAP
log in `mcap/`; the evaluation folder has a Rerun recording per rollout (`libero-bench replay
EVALUATION --task T`).
"""
)


def _run_card(run_meta: Mapping[str, Any], episodes: int, tasks: int, frames: int) -> str:
    return ROLLOUT_CARD.format(
        run=run_meta.get("run", ""),
        algo=run_meta.get("algo", ""),
        policy=run_meta.get("policy", ""),
        preset=run_meta.get("preset", ""),
        seed=run_meta.get("seed", ""),
        episodes=episodes,
        tasks=tasks,
        frames=frames,
    )


def _count(n: int, what: str) -> str:
    return f"{n} {what}" if n == 1 else f"{n} {what}s"


def build_rollout_dataset(
    shards: Sequence[Path],
    out: Path,
    *,
    run_meta: Mapping[str, Any],
    bddl: Mapping[str, str],
    work_dir: Path,
) -> int:
    """Join rollout shards (in the given order) into the LeRobot dataset ``out``; returns the
    number of episodes. Built beside ``out`` and swapped in, so ``out`` is always complete."""
    import shutil

    from libero_data.pipeline.publish import unstamp
    from libero_data.pipeline.snapshot import build_snapshot

    shards = [Path(s) for s in shards]
    if not shards:
        raise RunError("the run has no rollouts to collect")
    staging = work_dir / "rollouts-staging"
    frames = sum(int(json.loads((s / "episode.json").read_text())["length"]) for s in shards)
    if run_meta.get("kind") == "evaluation":
        card = EVAL_CARD.format(
            run=run_meta.get("run", ""),
            policy_type=run_meta.get("policy", ""),
            policy=run_meta.get("policy_ref", ""),
            protocol=run_meta.get("protocol", ""),
            episodes=_count(len(shards), "episode"),
            tasks=_count(len(bddl), "task"),
            frames=frames,
        )
    else:
        card = _run_card(run_meta, len(shards), len(bddl), frames)
    from libero_data.record.shard import quiet_datasets

    with quiet_datasets():
        build_snapshot(
            shards,
            staging,
            repo_id="libero-bench/rollouts",
            snapshot_id=f"rollouts-{len(shards)}",
            dataset_meta=dict(run_meta),
            bddl=dict(bddl),
            card=card,
        )
    unstamp(staging)  # built whole and swapped in: the publishing stamps have no use here
    old = work_dir / "rollouts-old"
    if old.exists():
        shutil.rmtree(old)
    if out.exists():
        out.rename(old)
    staging.rename(out)
    if old.exists():
        shutil.rmtree(old)
    return len(shards)
