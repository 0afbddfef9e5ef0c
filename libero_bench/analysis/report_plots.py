"""The report's pictures, one set per method: the success matrix (stored | held-out starts),
learning curves with Wilson error bars, and FWT / NBT / AUC with their 95% intervals; and where
a report holds several methods, their FWT / NBT / AUC side by side."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from libero_bench.runs.folder import HELDOUT, STARTS, STORED
from libero_bench.runs.intervals import METRICS, Rate, cell_outcomes

if TYPE_CHECKING:
    from libero_bench.runs.summary import RunSummary

COLOURS = {STORED: "tab:blue", HELDOUT: "tab:orange"}
LABELS = {STORED: "stored starts", HELDOUT: "held-out starts"}


def _nanmean(stack: np.ndarray) -> np.ndarray:
    """Mean over the first axis ignoring NaN; NaN where nothing was measured (no warning)."""
    counts = np.sum(np.isfinite(stack), axis=0)
    sums = np.nansum(stack, axis=0)
    return np.where(counts > 0, sums / np.maximum(counts, 1), np.nan)


def group_plots(members: Sequence[RunSummary], group: dict[str, Any], out: Path) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg", force=True)
    return [_matrix(members, group, out), _curves(members, group, out), _metrics(group, out)]


def _matrix(members: Sequence[RunSummary], group: dict[str, Any], out: Path) -> Path:
    import matplotlib.pyplot as plt

    k = group["tasks_done"]
    starts = [s for s in STARTS if group[s] is not None]
    fig, axes = plt.subplots(
        1, len(starts), figsize=(0.6 + (0.6 * k + 1.2) * len(starts), 1.0 + 0.6 * k), dpi=120
    )
    axes = np.atleast_1d(axes)
    for ax, start in zip(axes, starts, strict=True):
        mean = _nanmean(np.stack([m.matrix(start)[:k, :k] for m in members if m.has(start)]))
        image = ax.imshow(np.ma.masked_invalid(mean), vmin=0.0, vmax=1.0, cmap="viridis")
        for tau in range(k):
            for j in range(tau + 1):
                if math.isfinite(mean[tau, j]):
                    colour = "w" if mean[tau, j] < 0.6 else "k"
                    ax.text(j, tau, f"{mean[tau, j]:.2f}", ha="center", va="center", fontsize=7, color=colour)
        ax.set_xticks(range(k), [str(i) for i in range(k)])
        ax.set_yticks(range(k), [str(i) for i in range(k)])
        ax.set_xlabel("task evaluated")
        ax.set_ylabel("after learning task")
        ax.set_title(LABELS[start], fontsize=8)
    fig.colorbar(image, ax=list(axes), fraction=0.046, pad=0.04)
    fig.suptitle(f"{group['label']}: success", fontsize=9)
    path = out / f"{group['slug']}_success_matrix.png"
    fig.savefig(path, bbox_inches="tight")
    plt.close(fig)
    return path


def _curves(members: Sequence[RunSummary], group: dict[str, Any], out: Path) -> Path:
    """Success while learning each task, pooled over the group's runs, with Wilson intervals."""
    import matplotlib.pyplot as plt

    k = group["tasks_done"]
    names = group["tasks"][:k]
    epochs = list(members[0].results.eval_epochs)
    fig, ax = plt.subplots(figsize=(6.5, 3.6), dpi=120)
    markers = "osD^v<>px*"
    for start in (s for s in STARTS if group[s] is not None):
        pooled = [[Rate(0, 0) for _ in epochs] for _ in range(k)]
        for m in members:
            curve, _ = cell_outcomes(m.results, k, start)
            for t in range(k):
                for e, outcomes in enumerate(curve[t]):
                    pooled[t][e] = Rate(
                        pooled[t][e].successes + int(outcomes.sum()), pooled[t][e].n + outcomes.size
                    )
        for t in range(k):
            cells = [(epochs[e], r.to_dict()) for e, r in enumerate(pooled[t]) if r.n]
            if not cells:
                continue
            x = (
                np.array([c[0] for c in cells], dtype=float)
                + (0.08 * (t - k / 2))
                + (0.03 if start == HELDOUT else 0)
            )
            y = np.array([c[1]["rate"] for c in cells])
            err = np.array([[c[1]["rate"] - c[1]["low"], c[1]["high"] - c[1]["rate"]] for c in cells]).T
            ax.errorbar(
                x,
                y,
                yerr=err,
                marker=markers[t % len(markers)],
                linestyle="-" if start == STORED else "--",
                color=COLOURS[start],
                alpha=0.6 + 0.4 * (t + 1) / k,
                capsize=2,
                label=f"{t}: {names[t]}"[:40] + f" ({LABELS[start]})",
            )
    ax.set_ylim(-0.05, 1.05)
    ax.set_xlabel("epoch")
    ax.set_ylabel("success rate (95% Wilson)")
    ax.set_title(f"{group['label']}: success while learning each task", fontsize=9)
    ax.legend(fontsize=5, loc="best")
    fig.tight_layout()
    path = out / f"{group['slug']}_success_curves.png"
    fig.savefig(path)
    plt.close(fig)
    return path


def _metrics(group: dict[str, Any], out: Path) -> Path:
    """FWT, NBT and AUC from each kind of start, with their 95% bootstrap intervals."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(4.8, 3.0), dpi=120)
    starts = [s for s in STARTS if group[s] is not None]
    width = 0.8 / max(len(starts), 1)
    for i, start in enumerate(starts):
        _metric_bars(
            ax, group[start], (i - (len(starts) - 1) / 2) * width, width, COLOURS[start], LABELS[start]
        )
    _metric_axis(ax)
    ax.set_title(f"{group['label']}: 95% intervals", fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    path = out / f"{group['slug']}_metrics.png"
    fig.savefig(path)
    plt.close(fig)
    return path


def methods_plot(groups: Sequence[dict[str, Any]], out: Path) -> Path:
    """FWT, NBT and AUC of every method side by side, one panel per kind of start, with the
    95% intervals: where the methods of one report differ."""
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    starts = [s for s in STARTS if any(g[s] is not None for g in groups)]
    fig, axes = plt.subplots(1, len(starts), figsize=(0.8 + 3.6 * len(starts), 3.2), dpi=120, sharey=True)
    axes = np.atleast_1d(axes)
    width = 0.8 / len(groups)
    colours = plt.get_cmap("tab10")
    for ax, start in zip(axes, starts, strict=True):
        for i, group in enumerate(groups):
            if group[start] is None:
                continue
            offset = (i - (len(groups) - 1) / 2) * width
            _metric_bars(ax, group[start], offset, width, colours(i % 10), group["label"][:40])
        _metric_axis(ax)
        ax.set_title(LABELS[start], fontsize=9)
    axes[0].set_ylabel("mean with 95% interval")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, fontsize=7, loc="lower center", ncol=min(len(groups), 4), frameon=False)
    fig.suptitle("methods compared", fontsize=9)
    fig.tight_layout(rect=(0, 0.08 + 0.04 * ((len(groups) - 1) // 4), 1, 1))
    path = out / "methods_metrics.png"
    fig.savefig(path)
    plt.close(fig)
    return path


def _metric_bars(
    ax: Any, stats: dict[str, Any], offset: float, width: float, colour: Any, label: str
) -> None:
    """One bar per metric at ``offset`` from its tick, with its 95% interval as an error bar."""
    rows = [stats[m] for m in METRICS]
    x = np.arange(len(METRICS)) + offset
    y, low, high = (
        np.array([r[key] if r[key] is not None else np.nan for r in rows], dtype=float)
        for key in ("mean", "low", "high")
    )
    ax.bar(x, y, width=width, color=colour, label=label)
    ax.errorbar(x, y, yerr=np.vstack([y - low, high - y]), fmt="none", ecolor="k", capsize=3)


def _metric_axis(ax: Any) -> None:
    ax.axhline(0.0, color="k", linewidth=0.5)
    ax.set_xticks(range(len(METRICS)), ["FWT (↑)", "NBT (↓)", "AUC (↑)"])
