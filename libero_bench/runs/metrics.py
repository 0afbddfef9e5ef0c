"""Lifelong-learning metrics of the LIBERO paper as pure functions over success rates.

Layout (K tasks, in the order they are learned; E evaluation points per task):

- ``curve[k, e]``: success on task k at the e-th evaluation while learning task k (for the
  paper: epochs 0, 5, ..., 50, so E = 11). ``NaN`` where not measured.
- ``after[tau, k]``: success on task k with the checkpoint kept after learning task tau
  (only ``tau > k`` is read; the rest may be ``NaN``).

Definitions (the contract; tasks counted 1..K in the formulas, 0..K-1 in the arrays):

- ``c_kk = max_e curve[k, e]`` (best success while learning k, ignoring NaN);
  ``e*_k`` the earliest evaluation reaching it; the curve is held at ``c_kk`` for e >= e*_k
  (measured or not), because the best checkpoint is the one kept.
- ``FWT_k`` = mean of the held curve over its evaluation points (NaN points before e*_k
  are left out); with 11 points this is (1/11) sum_e c_{k,k,e}.
- ``NBT_k = 1/(K-k) sum_{tau=k+1..K} (c_kk - c_{tau,k})``. The last task has no later
  checkpoint: its NBT is undefined (NaN in ``per_task``) and the average ``nbt`` is over
  the first K-1 tasks (``last="zero"`` instead counts it as 0 and averages over K).
- ``AUC_k = 1/(K-k+1) (FWT_k + sum_{tau=k+1..K} c_{tau,k})`` (for the last task, FWT_K).
- ``fwt``, ``nbt``, ``auc``: the averages of the per-task values over the tasks.

Every function takes an optional ``kept``: per task, the evaluation point whose checkpoint the
run kept. Given, ``c_kk`` is the curve at that point instead of its maximum. Success measured
from held-out starts uses it: the checkpoint was chosen on the stored starts, and taking the
held-out maximum would choose again, on the held-out starts themselves.

Only numpy is needed; inputs may be anything ``np.asarray`` accepts (lists, torch tensors
on CPU).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]


def _curve(curve: ArrayLike) -> FloatArray:
    c = np.asarray(curve, dtype=np.float64)
    if c.ndim != 2 or c.shape[0] == 0 or c.shape[1] == 0:
        raise ValueError(f"curve must be a non-empty (K, E) array, got shape {c.shape}")
    if np.isnan(c).all(axis=1).any():
        missing = np.flatnonzero(np.isnan(c).all(axis=1)).tolist()
        raise ValueError(f"curve has no measured point for task(s) {missing}")
    return c


def _after(after: ArrayLike, k: int) -> FloatArray:
    a = np.asarray(after, dtype=np.float64)
    if a.shape != (k, k):
        raise ValueError(f"after must be a ({k}, {k}) array to match curve, got shape {a.shape}")
    later = np.tril(np.ones((k, k), dtype=bool), -1)  # [tau, k] with tau > k
    if np.isnan(a[later]).any():
        raise ValueError("after[tau, k] must be measured for every tau > k")
    return a


Kept = ArrayLike | None


def best_index(curve: ArrayLike, kept: Kept = None) -> NDArray[np.int64]:
    """``e*_k``: the earliest evaluation point reaching ``c_kk`` (or the kept one), per task: (K,)."""
    c = _curve(curve)
    if kept is not None:
        index = np.asarray(kept, dtype=np.int64).reshape(-1)
        if index.shape != (c.shape[0],) or (index < 0).any() or (index >= c.shape[1]).any():
            raise ValueError(f"kept must give one evaluation point in 0..{c.shape[1] - 1} per task")
        return index
    return np.nanargmax(c, axis=1).astype(np.int64)


def best_success(curve: ArrayLike, kept: Kept = None) -> FloatArray:
    """``c_kk`` per task: (K,)."""
    c = _curve(curve)
    return c[np.arange(c.shape[0]), best_index(c, kept)]


def held_curve(curve: ArrayLike, kept: Kept = None) -> FloatArray:
    """The curve with every point from ``e*_k`` on set to ``c_kk``: (K, E)."""
    c = _curve(curve).copy()
    first = best_index(c, kept)
    best = c[np.arange(c.shape[0]), first]
    for k in range(c.shape[0]):
        c[k, first[k] :] = best[k]
    return c


def fwt_per_task(curve: ArrayLike, kept: Kept = None) -> FloatArray:
    """``FWT_k``: (K,)."""
    return np.nanmean(held_curve(curve, kept), axis=1)


def nbt_per_task(curve: ArrayLike, after: ArrayLike, kept: Kept = None) -> FloatArray:
    """``NBT_k``: (K,), NaN for the last task."""
    c = _curve(curve)
    n = c.shape[0]
    a = _after(after, n)
    best = best_success(c, kept)
    out = np.full(n, np.nan)
    for k in range(n - 1):
        out[k] = float(np.mean(best[k] - a[k + 1 :, k]))
    return out


def auc_per_task(curve: ArrayLike, after: ArrayLike, kept: Kept = None) -> FloatArray:
    """``AUC_k``: (K,)."""
    c = _curve(curve)
    n = c.shape[0]
    a = _after(after, n)
    fwt_k = fwt_per_task(c, kept)
    return np.array([(fwt_k[k] + a[k + 1 :, k].sum()) / (n - k) for k in range(n)])


def fwt(curve: ArrayLike, kept: Kept = None) -> float:
    """Forward transfer: mean of ``FWT_k`` over the K tasks."""
    return float(np.mean(fwt_per_task(curve, kept)))


def nbt(
    curve: ArrayLike, after: ArrayLike, last: Literal["exclude", "zero"] = "exclude", kept: Kept = None
) -> float:
    """Negative backward transfer (lower is better; forgetting is positive).

    ``last="exclude"`` averages over the first K-1 tasks (NaN when K = 1); ``"zero"``
    counts the last task as 0 and averages over all K.
    """
    per_task = nbt_per_task(curve, after, kept)
    if last == "zero":
        return float(np.mean(np.nan_to_num(per_task, nan=0.0)))
    if last != "exclude":
        raise ValueError(f"last must be 'exclude' or 'zero', got {last!r}")
    defined = per_task[:-1]
    return float(np.mean(defined)) if defined.size else math.nan


def auc(curve: ArrayLike, after: ArrayLike, kept: Kept = None) -> float:
    """Area under the success curve: mean of ``AUC_k`` over the K tasks."""
    return float(np.mean(auc_per_task(curve, after, kept)))


@dataclass(frozen=True)
class LifelongScores:
    """The three headline numbers of one run."""

    fwt: float
    nbt: float
    auc: float

    def to_dict(self) -> dict[str, float]:
        return {"fwt": self.fwt, "nbt": self.nbt, "auc": self.auc}


def scores(curve: ArrayLike, after: ArrayLike, kept: Kept = None) -> LifelongScores:
    """FWT, NBT (last task excluded) and AUC of one run."""
    return LifelongScores(fwt(curve, kept), nbt(curve, after, kept=kept), auc(curve, after, kept))


def mean_and_stderr(values: Sequence[float] | ArrayLike) -> tuple[float, float]:
    """Mean and standard error (sample std / sqrt(n)) over seeds; the error is NaN for n = 1."""
    v = np.asarray(values, dtype=np.float64).reshape(-1)
    if v.size == 0:
        raise ValueError("mean_and_stderr needs at least one value")
    if v.size == 1:
        return float(v[0]), math.nan
    return float(v.mean()), float(v.std(ddof=1) / math.sqrt(v.size))
