"""Episode lengths as the tables and cards state them: summaries, the share within a task's
standard step limit (:func:`libero_data.tasks.horizons.standard_limit`), and the length plot.

The plot is drawn with matplotlib's Agg canvas (no pyplot, no global backend) and written
without the PNG's software tag, so the same lengths give the same bytes.
"""

from __future__ import annotations

import io
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

from libero_data.tasks.horizons import HUMAN_LONGEST, OTHER_LIMIT, base_suite

if TYPE_CHECKING:
    from libero_data.tasks.task import Suite

#: The steps one bar of the length histogram spans.
BIN_STEPS = 10


def length_summary(lengths: Sequence[int]) -> dict[str, float]:
    """Mean, median, 95th percentile and longest of episode lengths (NaN where there are none)."""
    import numpy as np

    if not lengths:
        nan = float("nan")
        return {"mean": nan, "median": nan, "p95": nan, "longest": nan}
    values = np.asarray(lengths, dtype=float)
    return {
        "mean": float(values.mean()),
        "median": float(np.median(values)),
        "p95": float(np.percentile(values, 95)),
        "longest": float(values.max()),
    }


def counted(n: int, noun: str) -> str:
    """``n`` and ``noun``, plural unless one: ``1 episode``, ``3 episodes``."""
    return f"{n} {noun}" if n == 1 else f"{n} {noun}s"


def within_limit(lengths: Sequence[int], limit: int) -> int:
    """How many of ``lengths`` are at most ``limit`` steps."""
    return sum(1 for n in lengths if n <= limit)


def human_longest(suite: str | Suite, task: str | None = None) -> tuple[str, int] | None:
    """(base suite, steps) of LIBERO's longest human demonstration of a task's base suite, if it has one."""
    base = base_suite(suite, task)
    return (base, HUMAN_LONGEST[base]) if base is not None else None


def length_line(lengths: Sequence[int], suite: str) -> str:
    """A dataset's episode lengths in one line, beside LIBERO's longest human demonstration."""
    if not lengths:
        return "–"
    s = length_summary(lengths)
    line = (
        f"mean {s['mean']:.0f}, median {s['median']:.0f}, 95th percentile {s['p95']:.0f}, "
        f"longest {s['longest']:.0f}"
    )
    human = human_longest(suite)
    return line + (f" (LIBERO's longest human demonstration of {human[0]}: {human[1]})" if human else "")


@dataclass(frozen=True)
class LengthPanel:
    """One panel of a length plot: a group's episode lengths, the standard limit(s) of its
    tasks, how many lengths are within their task's limit, and LIBERO's human longest."""

    title: str
    lengths: tuple[int, ...]
    limits: tuple[int, ...]
    within: int
    human: int | None = None


def length_plot(panels: Sequence[LengthPanel], *, columns: int = 3) -> bytes:
    """A PNG: per panel a histogram of the lengths (bars of :data:`BIN_STEPS` steps), a line at
    each standard limit and one at LIBERO's human longest, the counts in its title."""
    import numpy as np
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    columns = max(1, min(columns, len(panels)))
    rows = -(-len(panels) // columns)
    fig = Figure(figsize=(3.8 * columns, 2.4 * rows + 0.5), dpi=100, layout="constrained")
    FigureCanvasAgg(fig)
    for i, panel in enumerate(panels):
        ax = fig.add_subplot(rows, columns, i + 1)
        top = max([*panel.lengths, *panel.limits, panel.human or 0]) + BIN_STEPS
        bins = [float(x) for x in np.arange(0, top + BIN_STEPS, BIN_STEPS)]
        ax.hist(panel.lengths, bins=bins, color="tab:blue", alpha=0.8)
        for limit in sorted(set(panel.limits)):
            ax.axvline(limit, color="tab:red", linewidth=1.4)
        if panel.human is not None:
            ax.axvline(panel.human, color="0.3", linestyle="--", linewidth=1.2)
        n = len(panel.lengths)
        limits = "/".join(str(x) for x in sorted(set(panel.limits)))
        counts = f"{panel.within}/{n} within {limits} ({panel.within / n:.0%}), longest {max(panel.lengths)}"
        ax.set_title(f"{panel.title}\n{counts if n else 'no episodes'}", fontsize=8)
        ax.set_xlabel("steps (20 Hz)", fontsize=7)
        ax.tick_params(labelsize=7)
    handles = [
        Line2D([], [], color="tab:red", linewidth=1.4, label="standard limit"),
        Line2D(
            [], [], color="0.3", linestyle="--", linewidth=1.2, label="LIBERO's longest human demonstration"
        ),
    ]
    fig.legend(handles=handles, loc="outside lower center", ncols=2, fontsize=7, frameon=False)
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", metadata={"Software": None})
    return buffer.getvalue()


def length_section(panels: Sequence[LengthPanel], image: str | None, closing: str) -> str:
    """A card's *Episode lengths* section: per panel its numbers in words, the plot (``image``,
    a path relative to the card) and ``closing`` (what the card says of the length bound)."""
    lines = [
        "Lengths in control steps (20 Hz), against each task's *standard limit*: the steps the field's "
        "evaluations give a policy (openpi's LIBERO loop, counted after its 10 waiting steps; LIBERO-PRO's and "
        "LIBERO-Plus's suites and robustness variants take the limit of the suite they come from, tasks of no "
        f"LIBERO suite {OTHER_LIMIT}, LeRobot's default), so the "
        "longest demonstration a policy copying its data's pace can afford; and beside the longest of LIBERO's "
        "human demonstrations of that suite.",
        "",
    ]
    for p in panels:
        s = length_summary(p.lengths)
        limits = " / ".join(str(x) for x in sorted(set(p.limits)))
        human = f"; LIBERO's longest human demonstration {p.human}" if p.human is not None else ""
        numbers = (
            f"{counted(len(p.lengths), 'episode')}, mean {s['mean']:.0f}, median {s['median']:.0f}, 95th percentile "
            f"{s['p95']:.0f}, longest {s['longest']:.0f}; {p.within} of {len(p.lengths)} "
            f"({p.within / len(p.lengths):.0%}) within the limit"
            if p.lengths
            else "no episodes"
        )
        lines.append(f"- **{p.title}** (standard limit {limits}{human}): {numbers}.")
    if image and any(p.lengths for p in panels):
        lines += ["", f"![Episode lengths against the standard limit]({image})"]
    return "\n".join([*lines, "", closing]).strip()
