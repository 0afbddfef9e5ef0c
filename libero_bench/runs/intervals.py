"""Uncertainty of a run's numbers: Wilson intervals of success rates and bootstrap intervals
of FWT, NBT and AUC.

Every number of a run is a mean over rollouts: ``curve[k][e]`` over the rollouts of task k at
evaluated epoch e, ``after[tau][k]`` over those of task k after task tau. The bootstrap draws
each cell's rollouts again with replacement (independently per cell, as they were run),
recomputes the metrics from the drawn matrices, and takes the 2.5th and 97.5th percentiles.
Over several runs of one method (seeds) it first draws the runs, then the rollouts within
each (a two-level bootstrap), so the interval covers both sources of variation.

Needs numpy only. Draws come from a fixed seed: the same runs give the same intervals.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from libero_bench.runs import metrics
from libero_bench.runs.folder import AFTER, LEARNING, STORED, RunResults
from libero_data.stats import wilson_interval

#: Bootstrap draws (the percentiles of 2000 draws move by well under 0.01 between seeds).
DRAWS = 2000
SEED = 20240531
METRICS = ("fwt", "nbt", "auc")


@dataclass(frozen=True)
class Rate:
    """A success rate with its count and 95% Wilson interval."""

    successes: int
    n: int

    @property
    def rate(self) -> float:
        return self.successes / self.n if self.n else math.nan

    def to_dict(self) -> dict[str, Any]:
        low, high = wilson_interval(self.successes, self.n) if self.n else (math.nan, math.nan)
        return {
            "rate": _finite(self.rate),
            "successes": self.successes,
            "n": self.n,
            "low": _finite(low),
            "high": _finite(high),
        }


def _finite(value: float) -> float | None:
    return None if value is None or not math.isfinite(value) else float(value)


def cell_outcomes(
    results: RunResults, tasks_done: int, start: str
) -> tuple[list[list[np.ndarray]], list[list[np.ndarray]]]:
    """The rollout outcomes (0/1 arrays) behind every ``curve`` and ``after`` cell, from one
    kind of start. A cell without rollouts of its own (MTL copies its kept curve into ``after``)
    is empty. Within a cell the outcomes are in rollout order."""
    k, epochs = tasks_done, results.eval_epochs
    curve: list[list[list[int]]] = [[[] for _ in epochs] for _ in range(k)]
    after: list[list[list[int]]] = [[[] for _ in range(k)] for _ in range(k)]
    # In rollout order, so that a cell's i-th outcome comes from the same start in every run.
    for r in sorted(results.rollouts, key=lambda r: int(r["rollout"])):
        if r.get("start", STORED) != start or r["task_position"] >= k:
            continue
        pos = int(r["task_position"])
        if r["phase"] == LEARNING and r["epoch"] in epochs:
            curve[pos][epochs.index(r["epoch"])].append(int(bool(r["success"])))
        elif r["phase"] == AFTER and int(r["learned_after"]) < k:
            after[int(r["learned_after"])][pos].append(int(bool(r["success"])))
    return (
        [[np.asarray(c, dtype=np.float64) for c in row] for row in curve],
        [[np.asarray(c, dtype=np.float64) for c in row] for row in after],
    )


def final_rates(results: RunResults, tasks_done: int, start: str) -> list[Rate]:
    """Per task, the success of the last checkpoint (after the last finished task): its
    ``after`` rollouts, or for the last task those of its kept epoch."""
    curve, after = cell_outcomes(results, tasks_done, start)
    last = tasks_done - 1
    out = []
    for k in range(tasks_done):
        outcomes = after[last][k] if k < last and after[last][k].size else curve[k][results.kept_index(k)]
        out.append(Rate(int(outcomes.sum()), int(outcomes.size)))
    return out


class RunDraws:
    """Bootstrap draws of one run's FWT, NBT and AUC from one kind of start."""

    def __init__(
        self, results: RunResults, tasks_done: int, start: str, draws: int = DRAWS, seed: int = SEED
    ) -> None:
        self.results, self.k, self.start, self.draws = results, tasks_done, start, draws
        self.rng = np.random.default_rng(seed)
        curve_cells, after_cells = cell_outcomes(results, tasks_done, start)
        self.cells = curve_cells, after_cells
        #: MTL learns all tasks at once: no rollouts after other tasks.
        self.mtl = not any(r.get("phase") == AFTER for r in results.rollouts)
        self.point = _as_matrices(results, tasks_done, start)
        self.curves = self._draw(curve_cells, self.point[0])  # (B, K, E)
        self.afters = self._draw(after_cells, self.point[1])  # (B, K, K)
        self.kept = None if start == STORED else [results.kept_index(t) for t in range(tasks_done)]
        self.fill_mtl_after(self.curves, self.afters)

    @property
    def layout(self) -> tuple[tuple[int, ...], ...]:
        """Rollouts per cell. Two runs with the same layout get the same resampled indices from
        the same seed, so their draws stay paired start for start."""
        return tuple(tuple(c.size for c in row) for cells in self.cells for row in cells)

    def fill_mtl_after(self, curves: np.ndarray, afters: np.ndarray) -> None:
        """For MTL (no rollouts after other tasks): after[tau][k] is the kept curve point of
        task k, for every tau. In place, on (B, K, E) and (B, K, K) draws."""
        if self.mtl:
            for t in range(self.k):
                afters[:, :, t] = curves[:, t, self.results.kept_index(t)][:, None]

    def _draw(self, cells: list[list[np.ndarray]], point: np.ndarray) -> np.ndarray:
        out = np.repeat(point[None], self.draws, axis=0)
        for i, row in enumerate(cells):
            for j, outcomes in enumerate(row):
                n = outcomes.size
                if n:
                    out[:, i, j] = outcomes[self.rng.integers(0, n, size=(self.draws, n))].mean(axis=1)
        return out

    def metric(self, name: str) -> np.ndarray:
        """The metric's value in every draw: (B,) (NaN where it is undefined)."""
        return self.metric_of(name, self.curves, self.afters)

    def metric_of(self, name: str, curves: np.ndarray, afters: np.ndarray) -> np.ndarray:
        """The metric of each of (B, K, E) curve and (B, K, K) after matrices, with this run's
        kept epochs: (B,), NaN where it is undefined."""
        fn = _METRIC_FNS[name]
        values = np.full(curves.shape[0], np.nan)
        for b in range(curves.shape[0]):
            try:
                values[b] = fn(curves[b], afters[b], self.kept)
            except ValueError:  # a cell with no measurement: the metric is undefined
                values[b] = math.nan
        return values

    def value(self, name: str) -> float:
        try:
            return float(_METRIC_FNS[name](self.point[0], self.point[1], self.kept))
        except ValueError:
            return math.nan


def swap_null(
    a: RunDraws, b: RunDraws, names: Sequence[str], draws: int = DRAWS, seed: int = SEED
) -> dict[str, np.ndarray]:
    """The null distribution of ``metric(A) - metric(B)`` under a paired permutation, for each
    metric in ``names``: (draws,) signed differences, NaN where a metric is undefined.

    If the two runs were exchangeable, either run's outcome from a start (in every cell) could
    as well have been the other's: each pair is swapped with probability 1/2 and the metric
    difference recomputed (one set of swaps serves every metric). Needs both runs evaluated
    alike (the same :attr:`RunDraws.layout`)."""
    if a.layout != b.layout:
        raise ValueError(
            "the runs were not evaluated alike (cells or rollouts differ); they cannot be paired"
        )
    rng = np.random.default_rng(seed)
    swapped = []
    for index in range(2):
        out_a = np.repeat(a.point[index][None], draws, axis=0)
        out_b = np.repeat(b.point[index][None], draws, axis=0)
        for i, (row_a, row_b) in enumerate(zip(a.cells[index], b.cells[index], strict=True)):
            for j, (x, y) in enumerate(zip(row_a, row_b, strict=True)):
                if x.size:
                    swap = rng.random((draws, x.size)) < 0.5
                    out_a[:, i, j] = np.where(swap, y, x).mean(axis=1)
                    out_b[:, i, j] = np.where(swap, x, y).mean(axis=1)
        swapped.append((out_a, out_b))
    (curves_a, curves_b), (afters_a, afters_b) = swapped
    a.fill_mtl_after(curves_a, afters_a)
    b.fill_mtl_after(curves_b, afters_b)
    return {
        name: a.metric_of(name, curves_a, afters_a) - b.metric_of(name, curves_b, afters_b) for name in names
    }


def permutation_p(observed: float, null: np.ndarray) -> float:
    """Two-sided p of an observed difference against its null draws: the share of finite draws at
    least as far from 0 (with a tolerance for rounding), counting the observed draw itself; NaN
    when the observed difference is undefined."""
    if not math.isfinite(observed):
        return math.nan
    far = np.abs(null[np.isfinite(null)])
    return float((1 + np.sum(far >= abs(observed) - 1e-9)) / (1 + far.size))


def swap_test(
    a: RunDraws, b: RunDraws, names: Sequence[str], draws: int = DRAWS, seed: int = SEED
) -> dict[str, float]:
    """Two-sided p-value of a paired permutation test of ``metric(A) - metric(B)``, for each
    metric in ``names`` (:func:`swap_null`; for one cell this is McNemar's exact test, estimated
    from the draws)."""
    null = swap_null(a, b, names, draws, seed)
    return {name: permutation_p(a.value(name) - b.value(name), null[name]) for name in names}


def _as_matrices(results: RunResults, k: int, start: str) -> tuple[np.ndarray, np.ndarray]:
    curve = np.asarray(results.curve_of(start), dtype=np.float64)[:k]
    after = np.asarray(results.after_of(start), dtype=np.float64)[:k, :k]
    return curve, after


_METRIC_FNS: dict[str, Callable[[np.ndarray, np.ndarray, Any], float]] = {
    "fwt": lambda c, a, kept: metrics.fwt(c, kept),
    "nbt": lambda c, a, kept: metrics.nbt(c, a, kept=kept),
    "auc": lambda c, a, kept: metrics.auc(c, a, kept),
}


def interval(values: np.ndarray) -> tuple[float, float]:
    """The 95% percentile interval of draws (NaN where no draw is defined)."""
    finite = values[np.isfinite(values)]
    if finite.size == 0:
        return math.nan, math.nan
    low, high = np.percentile(finite, [2.5, 97.5])
    return float(low), float(high)


def metric_summary(runs: Sequence[RunDraws], seed: int = SEED) -> dict[str, dict[str, Any]]:
    """Per metric: the mean over runs and its 95% interval (over rollouts for one run; over
    runs and rollouts for several)."""
    rng = np.random.default_rng(seed + 1)
    out: dict[str, dict[str, Any]] = {}
    for name in METRICS:
        points = np.array([r.value(name) for r in runs])
        draws = np.stack([r.metric(name) for r in runs])  # (R, B)
        if len(runs) > 1:
            pick = rng.integers(0, len(runs), size=(draws.shape[1], len(runs)))  # (B, R)
            combined = np.nanmean(draws[pick, np.arange(draws.shape[1])[:, None]], axis=1)
        else:
            combined = draws[0]
        low, high = interval(combined)
        finite = points[np.isfinite(points)]
        out[name] = {
            "mean": _finite(float(finite.mean())) if finite.size else None,
            "low": _finite(low),
            "high": _finite(high),
            "runs": len(runs),
            "interval": "bootstrap over rollouts" if len(runs) == 1 else "bootstrap over runs and rollouts",
        }
    return out
