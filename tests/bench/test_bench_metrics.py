"""FWT / NBT / AUC against small matrices computed by hand from the paper's definitions."""

from __future__ import annotations

import math

import numpy as np
import pytest

from libero_bench.runs import metrics

# 3 tasks, 3 evaluation points each (rows: task k while learning it)
CURVE = [
    [0.2, 0.6, 0.4],  # best 0.6 at e=1 -> held [0.2, 0.6, 0.6] -> FWT 1.4/3
    [0.5, 0.5, 0.3],  # best 0.5 at e=0 -> held [0.5, 0.5, 0.5] -> FWT 0.5
    [0.0, 0.3, 0.9],  # best 0.9 at e=2 -> held [0.0, 0.3, 0.9] -> FWT 0.4
]
NAN = math.nan
AFTER = [  # after[tau, k]: success on k with the checkpoint after tau
    [0.6, NAN, NAN],
    [0.4, 0.5, NAN],
    [0.2, 0.1, 0.9],
]


def test_best_and_held_curve() -> None:
    np.testing.assert_allclose(metrics.best_success(CURVE), [0.6, 0.5, 0.9])
    np.testing.assert_array_equal(metrics.best_index(CURVE), [1, 0, 2])
    np.testing.assert_allclose(metrics.held_curve(CURVE), [[0.2, 0.6, 0.6], [0.5, 0.5, 0.5], [0.0, 0.3, 0.9]])


def test_fwt_by_hand() -> None:
    np.testing.assert_allclose(metrics.fwt_per_task(CURVE), [1.4 / 3, 0.5, 0.4])
    assert metrics.fwt(CURVE) == pytest.approx((1.4 / 3 + 0.5 + 0.4) / 3)


def test_nbt_by_hand() -> None:
    # NBT_1 = ((0.6-0.4) + (0.6-0.2)) / 2 = 0.3 ; NBT_2 = (0.5-0.1) / 1 = 0.4 ; NBT_3 undefined
    per_task = metrics.nbt_per_task(CURVE, AFTER)
    np.testing.assert_allclose(per_task[:2], [0.3, 0.4])
    assert math.isnan(per_task[2])
    assert metrics.nbt(CURVE, AFTER) == pytest.approx(0.35)
    assert metrics.nbt(CURVE, AFTER, last="zero") == pytest.approx(0.7 / 3)


def test_auc_by_hand() -> None:
    # AUC_1 = (FWT_1 + 0.4 + 0.2) / 3 ; AUC_2 = (0.5 + 0.1) / 2 ; AUC_3 = FWT_3
    expected = [(1.4 / 3 + 0.6) / 3, 0.3, 0.4]
    np.testing.assert_allclose(metrics.auc_per_task(CURVE, AFTER), expected)
    assert metrics.auc(CURVE, AFTER) == pytest.approx(sum(expected) / 3)
    s = metrics.scores(CURVE, AFTER)
    assert s.to_dict() == pytest.approx({"fwt": metrics.fwt(CURVE), "nbt": 0.35, "auc": sum(expected) / 3})


def test_paper_grid_of_eleven_epochs() -> None:
    # epochs 0, 5, ..., 50; success climbs 0.1 per evaluation up to 0.7 at e=7, then dips
    row = [0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.5, 0.6, 0.4]
    held = [0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.7, 0.7, 0.7]
    assert metrics.fwt([row]) == pytest.approx(sum(held) / 11)
    # a single task has no backward transfer; AUC equals FWT
    assert math.isnan(metrics.nbt([row], [[0.7]]))
    assert metrics.auc([row], [[0.7]]) == pytest.approx(sum(held) / 11)


def test_unmeasured_points() -> None:
    # NaN before the best point is left out; after it the curve is held (measured or not)
    curve = [[NAN, 0.4, 0.8, NAN]]
    np.testing.assert_allclose(metrics.held_curve(curve), [[NAN, 0.4, 0.8, 0.8]])
    assert metrics.fwt(curve) == pytest.approx((0.4 + 0.8 + 0.8) / 3)
    # ties: the earliest best point wins
    assert metrics.best_index([[0.5, 0.2, 0.5]])[0] == 0


def test_forgetting_free_learner() -> None:
    # a learner that never forgets has NBT 0 and AUC = mean of (FWT_k + later c_kk)/(K-k+1)
    curve = [[1.0, 1.0], [1.0, 1.0]]
    after = [[1.0, NAN], [1.0, 1.0]]
    assert metrics.nbt(curve, after) == 0.0
    assert metrics.auc(curve, after) == pytest.approx(1.0)
    assert metrics.fwt(curve) == pytest.approx(1.0)


def test_bad_inputs_are_errors() -> None:
    with pytest.raises(ValueError, match="curve"):
        metrics.fwt([0.1, 0.2])
    with pytest.raises(ValueError, match="no measured point"):
        metrics.fwt([[NAN, NAN], [0.1, 0.2]])
    with pytest.raises(ValueError, match="after must be"):
        metrics.nbt(CURVE, [[0.1]])
    with pytest.raises(ValueError, match="tau > k"):
        metrics.nbt(CURVE, [[0.6, NAN, NAN], [NAN, 0.5, NAN], [0.2, 0.1, 0.9]])
    with pytest.raises(ValueError, match="last"):
        metrics.nbt(CURVE, AFTER, last="drop")  # type: ignore[arg-type]


def test_mean_and_stderr() -> None:
    mean, err = metrics.mean_and_stderr([0.2, 0.4, 0.6])
    assert mean == pytest.approx(0.4)
    assert err == pytest.approx(0.2 / math.sqrt(3))  # sample std 0.2
    mean, err = metrics.mean_and_stderr([0.5])
    assert mean == 0.5 and math.isnan(err)
    with pytest.raises(ValueError):
        metrics.mean_and_stderr([])
