"""Why a run's evaluation rollouts failed, from its rollouts dataset (no simulation).

For every failed rollout of a one-task run: the steps it took against its limit, how high the
goal's first object was lifted and where it ended (height against its start, horizontal
distance to the goal's second object), the object lifted highest, and whether the hand was
closed at the end; then counts of the kinds of failure.

    python -m benchmarks.quick_failures RUN_DIR [RUN_DIR ...] [--out FILE.md]

Kinds: *cut while carrying* (object held above 3 cm at the limit), *dropped* (lifted above 3 cm,
not held at the end), *knocked off* (ended more than 10 cm below its start), *never lifted*.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np

LIFTED = 0.03  # m above its start: the object was picked up
HELD = 0.01  # m: finger opening below which the hand is closed on something
FELL = -0.10  # m below its start: off the table


def _episodes(run: Path) -> tuple[list[dict[str, Any]], dict[int, tuple[np.ndarray, np.ndarray]]]:
    import pyarrow.parquet as pq

    rows = [
        json.loads(line)
        for line in (run / "rollouts" / "meta" / "libero_episodes.jsonl").read_text().splitlines()
    ]
    frames: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    from libero_data.record.features import StoredColumns, sim_states

    for path in sorted((run / "rollouts" / "data").glob("*/*.parquet")):
        names = pq.read_schema(path).names
        stored = StoredColumns.of(names)
        sim, gripper = stored.sim_state, stored.gripper
        table = pq.read_table(path, columns=["episode_index", sim, gripper])
        index = table.column("episode_index").to_numpy()
        states = sim_states(table.column(sim).to_pylist(), sim)
        grip = np.array(table.column(gripper).to_pylist())
        for e in np.unique(index):
            frames[int(e)] = (states[index == e], grip[index == e])
    return rows, frames


def _kind(final: float, highest: float, held: bool) -> str:
    """The kind of a failure from the object's final and highest lift (m) and the hand at the end."""
    if final < FELL:
        return "knocked off"
    if held and final > LIFTED:
        return "cut while carrying"
    return "dropped" if highest > LIFTED else "never lifted"


def failures(run: Path) -> tuple[str, list[dict[str, Any]]]:
    """The run's task and one row per failed rollout."""
    import mujoco

    from libero_data.sim import EnvConfig, LiberoEnv
    from libero_data.tasks import get_suite

    config = json.loads((run / "config.json").read_text())
    (entry,) = config["tasks"]
    task = get_suite(config["dataset"]["suite"]).task(int(entry["suite_index"]))
    objects = [arg for atom in task.problem.goal_atoms() for arg in atom.args]
    with LiberoEnv(task, EnvConfig(cameras=())) as env:
        model = env.sim.model._model
        free = {
            str(mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j)).removesuffix("_joint0"): 1
            + int(model.jnt_qposadr[j])  # flat state: (time, qpos, qvel)
            for j in range(model.njnt)
            if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE
        }
    rows, frames = _episodes(run)
    out = []
    for row in rows:
        if row["success"]:
            continue
        states, grip = frames[row["episode_index"]]
        lift = {name: states[:, a + 2] - states[0, a + 2] for name, a in free.items()}
        target = objects[0] if objects[0] in free else max(lift, key=lambda n: lift[n].max())
        highest = max(lift, key=lambda n: lift[n].max())
        held = float(np.abs(grip[-1]).max()) < HELD
        final = float(lift[target][-1])
        kind = _kind(final, float(lift[target].max()), held)
        item = {
            "rollout": row["key"],
            "start": row["start"],
            "steps": row["steps"],
            "limit": row.get("max_steps"),
            "object": target,
            "lifted_cm": round(100 * float(lift[target].max()), 1),
            "final_cm": round(100 * final, 1),
            "highest": f"{highest} ({100 * float(lift[highest].max()):.1f} cm)",
            "goal_objects_lifted_cm": ", ".join(
                f"{o} {100 * float(lift[o].max()):.1f}" for o in dict.fromkeys(objects) if o in free
            ),
            "held_at_end": held,
            "kind": kind,
        }
        if len(objects) > 1 and objects[1] in free:
            a, b = free[target], free[objects[1]]
            item[f"to_{objects[1]}_cm"] = round(
                100 * float(np.linalg.norm(states[-1, a : a + 2] - states[-1, b : b + 2])), 1
            )
        out.append(item)
    return task.id, out


def markdown(runs: list[Path]) -> str:
    lines = [
        "# Why the quick runs' rollouts failed",
        "",
        "Made by `python -m benchmarks.quick_failures` from each run's rollouts dataset.",
        "",
    ]
    for run in runs:
        task, rows = failures(run)
        kinds: dict[str, int] = {}
        for row in rows:
            kinds[row["kind"]] = kinds.get(row["kind"], 0) + 1
        summary = ", ".join(f"{n} {k}" for k, n in sorted(kinds.items(), key=lambda kv: -kv[1])) or "none"
        lines += [f"## {task} (`{run.name}`): {len(rows)} failed: {summary}", ""]
        if rows:
            keys = list(rows[0])
            lines += ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
            lines += ["| " + " | ".join(str(row.get(k, "")) for k in keys) + " |" for row in rows]
            lines.append("")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("runs", nargs="+", type=Path)
    parser.add_argument("--out", type=Path)
    args = parser.parse_args()
    text = markdown(args.runs)
    print(text)
    if args.out:
        args.out.write_text(text)


if __name__ == "__main__":
    main()
