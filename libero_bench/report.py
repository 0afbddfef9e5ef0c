"""Reports over finished runs: FWT / NBT / AUC (mean ± standard error over seeds), a
success-matrix heatmap and per-task success curves (PNG), and a JSON with every number.

Runs are grouped by what they compare (algorithm, policy, preset and task list); the runs
of a group are its seeds. A run that stopped early is reported over the tasks it finished
(``tasks_done`` says so). Needs numpy and matplotlib only (no torch).
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from libero_bench import metrics
from libero_bench.run_files import RunFolder, RunResults
from libero_data.errors import InputError, MissingFileError, RunError
from libero_data.runtime.files import write_json


@dataclass
class RunSummary:
    """One run's numbers over its finished tasks."""

    path: Path
    config: dict[str, Any]
    results: RunResults
    tasks_done: int

    @property
    def group(self) -> tuple[str, str, str, tuple[str, ...]]:
        c = self.config
        return (c["algo"], c["policy"], c["preset"]["name"], tuple(t["name"] for t in c["tasks"]))

    @property
    def label(self) -> str:
        return f"{self.config['algo']} + {self.config['policy']}"

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        k = self.tasks_done
        curve = np.asarray(self.results.curve, dtype=np.float64)[:k]
        after = np.asarray(self.results.after, dtype=np.float64)[:k, :k]
        return curve, after

    def scores(self) -> dict[str, Any]:
        curve, after = self.arrays()
        return {
            "fwt": metrics.fwt(curve),
            "nbt": metrics.nbt(curve, after),
            "auc": metrics.auc(curve, after),
            "per_task": {
                "fwt": metrics.fwt_per_task(curve).tolist(),
                "nbt": metrics.nbt_per_task(curve, after).tolist(),
                "auc": metrics.auc_per_task(curve, after).tolist(),
                "best": metrics.best_success(curve).tolist(),
            },
        }

    def matrix(self) -> np.ndarray:
        """``M[tau, k]``: success on task k after learning task tau (diagonal: the best while
        learning it); NaN above the diagonal."""
        curve, after = self.arrays()
        m = np.full(after.shape, np.nan)
        best = metrics.best_success(curve)
        for tau in range(after.shape[0]):
            m[tau, :tau] = after[tau, :tau]
            m[tau, tau] = best[tau]
        return m


def load_run(path: str | Path) -> RunSummary:
    """Read a run folder; :class:`RunError` when it is not one or has no finished task."""
    folder = RunFolder(Path(path))
    if not folder.root.is_dir():
        raise MissingFileError(f"run folder {folder.root} does not exist")
    config = folder.read_config()
    results = folder.read_results()
    done = results.finished_tasks
    if done == 0:
        raise RunError(f"run {folder.root} has not finished its first task yet")
    return RunSummary(folder.root, config, results, done)


def _finite(value: float) -> float | None:
    return None if value is None or not math.isfinite(value) else float(value)


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9]+", "-", text).strip("-").lower() or "run"


def summarize(runs: Sequence[RunSummary]) -> dict[str, Any]:
    """Every number of the report: per run and per group (mean and standard error)."""
    groups: dict[tuple[Any, ...], list[RunSummary]] = {}
    for run in runs:
        groups.setdefault(run.group, []).append(run)
    run_rows = []
    for run in runs:
        s = run.scores()
        run_rows.append(
            {
                "path": str(run.path),
                "algo": run.config["algo"],
                "policy": run.config["policy"],
                "preset": run.config["preset"]["name"],
                "seed": run.config["seed"],
                "tasks": [t["name"] for t in run.config["tasks"]],
                "tasks_done": run.tasks_done,
                "complete": run.results.complete,
                "eval_epochs": run.results.eval_epochs,
                "curve": [[_finite(v) for v in row] for row in run.arrays()[0].tolist()],
                "after": [[_finite(v) for v in row] for row in run.arrays()[1].tolist()],
                "best_epoch": run.results.best_epoch[: run.tasks_done],
                "losses": run.results.losses[: run.tasks_done],
                "fwt": _finite(s["fwt"]),
                "nbt": _finite(s["nbt"]),
                "auc": _finite(s["auc"]),
                "per_task": {k: [_finite(v) for v in vals] for k, vals in s["per_task"].items()},
            }
        )
    group_rows = []
    used: set[str] = set()
    for key, members in groups.items():
        label = members[0].label
        slug = _slug(f"{members[0].config['algo']}-{members[0].config['policy']}")
        if slug in used:
            slug = f"{slug}-{len(used)}"
        used.add(slug)
        row: dict[str, Any] = {
            "label": label,
            "slug": slug,
            "algo": key[0],
            "policy": key[1],
            "preset": key[2],
            "tasks": list(key[3]),
            "runs": [str(m.path) for m in members],
            "seeds": [m.config["seed"] for m in members],
            "tasks_done": min(m.tasks_done for m in members),
        }
        for metric in ("fwt", "nbt", "auc"):
            values = [v for m in members if math.isfinite(v := float(m.scores()[metric]))]
            if values:
                mean, err = metrics.mean_and_stderr(values)
                row[metric] = {"mean": _finite(mean), "stderr": _finite(err), "n": len(values)}
            else:
                row[metric] = {"mean": None, "stderr": None, "n": 0}
        group_rows.append(row)
    return {"runs": run_rows, "groups": group_rows}


def _cell(stat: dict[str, Any]) -> str:
    if stat["mean"] is None:
        return "–"
    err = "–" if stat["stderr"] is None else f"{stat['stderr']:.2f}"
    return f"{stat['mean']:.2f} ± {err}"


def table_rows(summary: dict[str, Any]) -> list[list[str]]:
    """Rows of the headline table: method, runs, tasks, FWT, NBT, AUC."""
    rows = []
    for g in summary["groups"]:
        rows.append(
            [
                g["label"],
                f"{len(g['runs'])} (seeds {', '.join(map(str, g['seeds']))})",
                f"{g['tasks_done']}/{len(g['tasks'])}",
                _cell(g["fwt"]),
                _cell(g["nbt"]),
                _cell(g["auc"]),
            ]
        )
    return rows


TABLE_HEADER = ["method", "runs", "tasks", "FWT (↑)", "NBT (↓)", "AUC (↑)"]


def markdown_table(summary: dict[str, Any]) -> str:
    lines = ["| " + " | ".join(TABLE_HEADER) + " |", "|" + "---|" * len(TABLE_HEADER)]
    lines += ["| " + " | ".join(row) + " |" for row in table_rows(summary)]
    return "\n".join(lines) + "\n"


def _nanmean(stack: np.ndarray) -> np.ndarray:
    """Mean over the first axis ignoring NaN; NaN where nothing was measured (no warning)."""
    counts = np.sum(np.isfinite(stack), axis=0)
    sums = np.nansum(stack, axis=0)
    return np.where(counts > 0, sums / np.maximum(counts, 1), np.nan)


def _plots(runs: Sequence[RunSummary], group: dict[str, Any], out: Path) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    members = [r for r in runs if str(r.path) in group["runs"]]
    k = group["tasks_done"]
    names = group["tasks"][:k]
    matrices = np.stack([m.matrix()[:k, :k] for m in members])
    mean_matrix = _nanmean(matrices)
    written = []

    fig, ax = plt.subplots(figsize=(1.0 + 0.6 * k, 0.8 + 0.6 * k), dpi=120)
    shown = np.ma.masked_invalid(mean_matrix)
    image = ax.imshow(shown, vmin=0.0, vmax=1.0, cmap="viridis")
    for tau in range(k):
        for j in range(tau + 1):
            value = mean_matrix[tau, j]
            if math.isfinite(value):
                ax.text(
                    j,
                    tau,
                    f"{value:.2f}",
                    ha="center",
                    va="center",
                    fontsize=7,
                    color="w" if value < 0.6 else "k",
                )
    ax.set_xticks(range(k), [str(i) for i in range(k)])
    ax.set_yticks(range(k), [str(i) for i in range(k)])
    ax.set_xlabel("task evaluated")
    ax.set_ylabel("after learning task")
    ax.set_title(f"{group['label']}: success", fontsize=9)
    fig.colorbar(image, ax=ax, fraction=0.046, pad=0.04)
    fig.tight_layout()
    path = out / f"{group['slug']}_success_matrix.png"
    fig.savefig(path)
    plt.close(fig)
    written.append(path)

    epochs = np.asarray(members[0].results.eval_epochs)
    curves = np.stack([m.arrays()[0][:k] for m in members])  # (runs, K, E)
    fig, ax = plt.subplots(figsize=(6, 3.5), dpi=120)
    for task in range(curves.shape[1]):
        mean = _nanmean(curves[:, task, :])
        ax.plot(epochs[: mean.shape[0]], mean, marker="o", label=f"{task}: {names[task]}"[:48])
    ax.set_ylim(-0.05, 1.05)
    ax.set_xlabel("epoch")
    ax.set_ylabel("success rate")
    ax.set_title(f"{group['label']}: success while learning each task", fontsize=9)
    ax.legend(fontsize=6, loc="best")
    fig.tight_layout()
    path = out / f"{group['slug']}_success_curves.png"
    fig.savefig(path)
    plt.close(fig)
    written.append(path)
    return written


def write_report(run_paths: Sequence[str | Path], out: str | Path) -> dict[str, Any]:
    """Write ``report.json``, ``report.md`` and the PNGs into ``out``; returns the summary
    (with ``files``: what was written)."""
    if not run_paths:
        raise InputError("give at least one run folder", field="runs")
    runs = [load_run(p) for p in run_paths]
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    summary = summarize(runs)
    files = []
    for group in summary["groups"]:
        files.extend(_plots(runs, group, out))
    (out / "report.md").write_text("# libero-bench report\n\n" + markdown_table(summary))
    files.append(out / "report.md")
    summary["files"] = [str(p) for p in [*files, out / "report.json"]]
    write_json(out / "report.json", summary)
    return summary
