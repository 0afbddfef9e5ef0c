"""Issue 74's proof by learning, in one table: each quick run's success under the standard protocol
(openpi's LIBERO loop, the suite's own step limit, stored init states 0-19) and in its own
evaluation (20 stored and 20 held-out starts, cut at the same limit), and the paired comparison
of the runs trained on the expert's earlier and today's demonstrations of the same task.

    python -m benchmarks.pace_report WORK_DIR --out benchmarks/results/pace

Reads ``WORK_DIR/standard/<run>/results.json`` (``libero-bench eval --protocol standard``) and
``WORK_DIR/runs/<run>/results.json`` (``libero-bench run``), as ``benchmarks/pace.sh`` makes them;
writes ``pace.md`` and ``pace.json`` into ``--out``.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from libero_data.runtime.files import write_text
from libero_data.stats import mcnemar_exact, wilson_interval

#: Today's demonstrations with 10 steps recorded after the goal (``generate --after-goal 10``).
TAIL = "today, 10 steps after the goal"
#: The expert at a deft pace (c5aa85a6618c: libero_goal/3 and /5 faster), 10 steps after the goal.
DEFT = "deft pace, 10 steps after the goal"
#: (run, task, limit, demonstrations) in the order the table lists them.
RUNS = (
    ("before-goal-3", "libero_goal/3", 300, "before"),
    ("after-goal-3", "libero_goal/3", 300, "today"),
    ("tail-goal-3", "libero_goal/3", 300, TAIL),
    ("before-spatial-7", "libero_spatial/7", 220, "before"),
    ("after-spatial-7", "libero_spatial/7", 220, "today"),
    ("tail-spatial-7", "libero_spatial/7", 220, TAIL),
    ("tail-spatial-8", "libero_spatial/8", 220, TAIL),
    ("tail-goal-1", "libero_goal/1", 300, TAIL),
    ("tail-long-0", "libero_10/0", 520, TAIL),
    ("deft-goal-3", "libero_goal/3", 300, DEFT),
)
#: Runs compared start for start: the same task on two kinds of demonstrations.
PAIRS = (
    ("before-goal-3", "after-goal-3"),
    ("before-spatial-7", "after-spatial-7"),
    ("after-goal-3", "tail-goal-3"),
    ("after-spatial-7", "tail-spatial-7"),
    ("tail-goal-3", "deft-goal-3"),
)


def standard_outcomes(folder: Path) -> dict[int, bool]:
    """{stored init index: success} of a standard-protocol evaluation."""
    rollouts = json.loads((folder / "results.json").read_text())["rollouts"]
    return {int(r["init_index"]): bool(r["success"]) for r in rollouts}


#: A failure "stops" when its gripper moved less than this (m) over its last STILL_STEPS steps.
STILL_METRES, STILL_STEPS = 0.03, 60


def how_failures_end(folder: Path) -> dict[str, int] | None:
    """Of a standard evaluation's failed rollouts (its rollout dataset, kept in WORK only): how many,
    how many stopped (the gripper within STILL_METRES over the last STILL_STEPS steps), and how many
    of those hold the gripper closed (their last 20 gripper actions close on average). Written to
    ``failures_end.json`` beside the evaluation (``pace.sh carry-out`` carries it, not the rollouts)
    and read from there where the rollouts are not here; None where neither is."""
    import numpy as np
    import pyarrow.parquet as pq

    rollouts, summary = folder / "rollouts", folder / "failures_end.json"
    files = sorted((rollouts / "data").glob("*/*.parquet"))
    if not files:
        return json.loads(summary.read_text()) if summary.is_file() else None
    columns = ["action", "libero.eef_pose", "episode_index"]
    table = pq.ParquetDataset(files).read(columns=columns).to_pydict()
    episodes = np.asarray(table["episode_index"])
    actions, poses = np.asarray(table["action"]), np.asarray(table["libero.eef_pose"])
    rows = [
        json.loads(line) for line in (rollouts / "meta" / "libero_episodes.jsonl").read_text().splitlines()
    ]
    failed = [r for r in rows if not r["success"]]
    stopped = closed = 0
    for row in failed:
        mine = episodes == row["episode_index"]
        path, gripper = poses[mine, :3], actions[mine, -1]
        if len(path) >= STILL_STEPS and np.linalg.norm(path[-1] - path[-STILL_STEPS]) < STILL_METRES:
            stopped += 1
            closed += bool(gripper[-20:].mean() > 0)
    ends = {"failures": len(failed), "stopped": stopped, "stopped_closed": closed}
    write_text(summary, json.dumps(ends) + "\n")
    return ends


RELEASE_OFFSETS = ("-3", "-1", "0", "1", "2", "5")


def release_row(folder: Path) -> list[str] | None:
    """The cells of a run's ``release.json`` (benchmarks/pace_release.py), or None without one."""
    path = folder / "release.json"
    if not path.is_file():
        return None
    opens = json.loads(path.read_text())["opens"]
    return [
        f"{opens[k]['open']}/{opens[k]['of']}" if k in opens and opens[k]["of"] else "–"
        for k in RELEASE_OFFSETS
    ]


def run_outcomes(folder: Path) -> dict[str, tuple[int, int]]:
    """{kind of start: (successes, rollouts)} of a single-task run's final evaluation."""
    results = json.loads((folder / "results.json").read_text())
    out: dict[str, tuple[int, int]] = {}
    for start, rows in _final_rollouts(results).items():
        out[start] = (sum(1 for r in rows if r["success"]), len(rows))
    return out


def _final_rollouts(results: dict[str, Any]) -> dict[str, list[dict[str, Any]]]:
    """The rollouts of the run's last evaluation (its last epoch), by kind of start."""
    rollouts = results.get("rollouts", [])
    if not rollouts:
        return {}
    last = max(int(r["epoch"]) for r in rollouts)
    by_start: dict[str, list[dict[str, Any]]] = {}
    for r in rollouts:
        if int(r["epoch"]) == last:
            by_start.setdefault(str(r["start"]), []).append(r)
    return by_start


def rate(successes: int, n: int) -> str:
    low, high = wilson_interval(successes, n)
    return f"{successes}/{n} [{low:.2f}, {high:.2f}]"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("work", type=Path)
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args(argv)
    rows: list[str] = []
    table: dict[str, dict[str, Any]] = {}
    outcomes: dict[str, dict[int, bool]] = {}
    for name, task, limit, data in RUNS:
        if not (args.work / "standard" / name / "report.json").is_file():  # written once it is complete
            rows.append(f"| {task} | {data} | `{name}` | {limit} | not evaluated yet | | | |")
            continue
        standard = standard_outcomes(args.work / "standard" / name)
        own = run_outcomes(args.work / "runs" / name)
        ok = sum(standard.values())
        outcomes[name] = standard
        ends = how_failures_end(args.work / "standard" / name)
        table[name] = {
            "task": task,
            "limit": limit,
            "demonstrations": data,
            "standard": standard,
            "own": own,
            "failures_end": ends,
        }
        own_cells = " | ".join(rate(*own[k]) if k in own else "–" for k in ("stored", "heldout"))
        stops = (
            "–"
            if ends is None
            else f"{ends['stopped']} of {ends['failures']} ({ends['stopped_closed']} closed)"
        )
        rows.append(
            f"| {task} | {data} | `{name}` | {limit} | {rate(ok, len(standard))} | {stops} | {own_cells} |"
        )
    lines = [
        "# Learning from demonstrations that fit the standard step limits (issue 74)",
        "",
        "The quick recipe (ResNet-T, quick size, 16 epochs, 100 demonstrations at 64x64, sampler starts) "
        "trained on the expert's demonstrations from before issue 74 and on today's, each task alone "
        "(`tail-`: today's with 10 steps recorded after the goal, `generate --after-goal 10`; `deft-`: "
        "the same from the expert at a deft pace, RESULTS' pending libero_goal/3 and /5 change). "
        "*Standard*: `libero-bench eval RUN --protocol standard --trials 20` (openpi's LIBERO loop, stored "
        "init states 0-19, the suite's own step limit after the 10 waits). *Stored* and *held out*: the "
        "run's own evaluation, 20 starts each, cut at the same limit. Wilson 95% intervals. *Failures "
        f"stopped*: the standard evaluation's failures whose gripper moved less than {STILL_METRES * 100:.0f} cm "
        f"over their last {STILL_STEPS} steps, and of those the ones holding the gripper closed.",
        "",
        "| task | demonstrations | run | step limit | standard | failures stopped | stored | held out |",
        "|---|---|---|---:|---:|---|---:|---:|",
        *rows,
        "",
        "Paired on the standard protocol's starts (the same stored init state, the same fixtures):",
        "",
        "| task | run A | run B | A | B | only A | only B | McNemar exact p |",
        "|---|---|---|---:|---:|---:|---:|---:|",
    ]
    pairs: dict[str, dict[str, float]] = {}
    for a, b in PAIRS:
        if a not in outcomes or b not in outcomes:
            continue
        sa, sb = outcomes[a], outcomes[b]
        common = sorted(set(sa) & set(sb))
        only_a = sum(1 for i in common if sa[i] and not sb[i])
        only_b = sum(1 for i in common if sb[i] and not sa[i])
        p = mcnemar_exact(only_a, only_b)
        pairs[f"{a} vs {b}"] = {"n": len(common), "only_a": only_a, "only_b": only_b, "p": p}
        lines.append(
            f"| {table[a]['task']} | `{a}` | `{b}` | {sum(sa[i] for i in common)}/{len(common)} | "
            f"{sum(sb[i] for i in common)}/{len(common)} | {only_a} | {only_b} | {p:.2g} |"
        )
    releases = {name: release_row(args.work / "standard" / name) for name, *_ in RUNS}
    lines += [
        "",
        "Whether each policy opens the gripper at its own demonstrations' last release "
        "(`python -m benchmarks.pace_release RUN DATA`: 25 of its 100 demonstrations, each release fed with "
        "the demonstration's own window of frames; the demonstration opens from +0):",
        "",
        "| run | " + " | ".join(f"{int(k):+d}" for k in RELEASE_OFFSETS) + " |",
        "|---|" + "---:|" * len(RELEASE_OFFSETS),
        *(
            f"| `{name}` | " + " | ".join(cells) + " |"
            for name, cells in releases.items()
            if cells is not None
        ),
    ]
    args.out.mkdir(parents=True, exist_ok=True)
    write_text(args.out / "pace.md", "\n".join(lines) + "\n")
    serial = {k: {**v, "standard": {str(i): s for i, s in v["standard"].items()}} for k, v in table.items()}
    write_text(args.out / "pace.json", json.dumps({"runs": serial, "pairs": pairs}, indent=2) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
