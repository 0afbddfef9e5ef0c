"""The scripted expert's pace from LIBERO's placement sampler starts, the kind of start a dataset
is generated from (the expert table, ``libero-data expert-report``, uses the stored init states).

    python -m benchmarks.expert_sampler_pace libero_goal/3 --starts 30

Physics only (no cameras). Each start is drawn from ``episode_seeds(SEED, task, i)``; prints, per
task, the successes and the successful episodes' lengths against the suite's standard limit.
To measure a pending expert change, run it from a worktree with the patch applied
(``PYTHONPATH=WORKTREE``).
"""

from __future__ import annotations

import argparse
import json
import os

import numpy as np


def measure(ref: str, starts: int, seed: int) -> dict[str, object]:
    """Successes and successful lengths of the expert over ``starts`` sampler starts of a task."""
    from libero_data.experts.expert import Expert
    from libero_data.provenance import expert_code
    from libero_data.seeding import episode_seeds
    from libero_data.sim import EnvConfig, LiberoEnv
    from libero_data.tasks import get_task
    from libero_data.tasks.horizons import standard_limit

    task = get_task(ref)
    lengths: list[int] = []
    with LiberoEnv(task, EnvConfig(cameras=())) as env:
        expert = Expert(env)
        for i in range(starts):
            reset_seed, expert_seed = episode_seeds(seed, task.id, i)
            episode = expert.run(None, reset_seed=reset_seed, seed=expert_seed)
            if episode.success:
                lengths.append(episode.length)
    limit = standard_limit(task.suite)
    return {
        "task": ref,
        "expert": expert_code(),
        "seed": seed,
        "starts": starts,
        "successes": len(lengths),
        "limit": limit,
        "within_limit": sum(n <= limit for n in lengths),
        "median": float(np.median(lengths)) if lengths else None,
        "longest": max(lengths, default=None),
        "lengths": sorted(lengths),
    }


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("tasks", nargs="+", help="task references, e.g. libero_goal/3")
    parser.add_argument("--starts", type=int, default=30, help="sampler starts per task (default 30)")
    parser.add_argument("--seed", type=int, default=1000, help="seed of the starts and styles (default 1000)")
    args = parser.parse_args()
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    for ref in args.tasks:
        print(json.dumps(measure(ref, args.starts, args.seed)), flush=True)


if __name__ == "__main__":
    main()
