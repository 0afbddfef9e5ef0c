"""Hand-made run folders for the tests of reports and comparisons (no training, no simulation)."""

from __future__ import annotations

from pathlib import Path

from libero_bench.runs.folder import RUN_FORMAT, RunResults, rollout_key

TASKS = ["pick_up_the_ketchup", "pick_up_the_milk"]


def fake_run(
    root: Path,
    *,
    algo: str,
    seed: int,
    learn: list[list[int]],
    after: list[int],
    heldout: list[list[int]] | None = None,
) -> Path:
    """A finished 2-task run: ``learn[k]`` the outcomes of task k at its one evaluated epoch
    (stored starts), ``after`` task 0's outcomes after task 1, ``heldout[k]`` held-out outcomes."""
    from libero_data.runtime.files import write_json as write

    results = RunResults.empty([{"position": i, "name": n, "language": n} for i, n in enumerate(TASKS)], [5])
    results.best_epoch = [5, 5]
    results.stage = ["done", "done"]
    results.complete = True
    rollouts = []

    def add(k: int, phase: str, learned_after: int, outcomes: list[int], start: str) -> float:
        for r, ok in enumerate(outcomes):
            epoch = 5 if phase == "learning" else None
            rollouts.append(
                {
                    "key": rollout_key(learned_after, phase, k, r, epoch, start),
                    "task": TASKS[k],
                    "task_position": k,
                    "learned_after": learned_after,
                    "phase": phase,
                    "epoch": epoch,
                    "rollout": r,
                    "start": start,
                    "init_index": r if start == "stored" else -1,
                    "env_seed": r if start == "stored" else 1000 + r,
                    "success": bool(ok),
                    "steps": 10,
                }
            )
        return sum(outcomes) / len(outcomes)

    for k in range(2):
        results.curve[k][0] = add(k, "learning", k, learn[k], "stored")
        results.after[k][k] = results.curve[k][0]
        if heldout is not None:
            results.curve_heldout[k][0] = add(k, "learning", k, heldout[k], "heldout")
            results.after_heldout[k][k] = results.curve_heldout[k][0]
    results.after[1][0] = add(0, "after", 1, after, "stored")
    if heldout is not None:
        results.after_heldout[1][0] = add(0, "after", 1, heldout[0][::-1], "heldout")
    results.rollouts = rollouts
    config = {
        "format": RUN_FORMAT,
        "algo": algo,
        "policy": "resnet_t",
        "preset": {"name": "quick"},
        "seed": seed,
        "tasks": [{"position": i, "name": n, "language": n} for i, n in enumerate(TASKS)],
        "evaluation": {
            "training_starts": {
                TASKS[0]: {"recorded": True, "stored_eval_starts_trained_on": []},
                TASKS[1]: {"recorded": True, "stored_eval_starts_trained_on": [0, 1, 2]},
            }
        },
    }
    root.mkdir(parents=True)
    write(root / "config.json", config)
    write(root / "results.json", results.to_dict())
    return root
