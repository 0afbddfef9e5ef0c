"""``bench_render_fast --rows``: a run cut short keeps the scenes it measured (issue 39's bench
takes about an hour on two cores)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from benchmarks.bench_render_fast import _load_rows


def test_rows_measured_before_are_found_and_a_cut_off_line_is_ignored(tmp_path: Path) -> None:
    rows = tmp_path / "rows.jsonl"
    assert _load_rows(None) == {} and _load_rows(rows) == {}
    first = {
        "task": "libero_90/23",
        "size": 128,
        "faces_after": np.int64(115107),
        "fast_step": np.float64(0.03),
    }
    with rows.open("a") as f:
        f.write(json.dumps(first, default=lambda v: v.item()) + "\n")
        f.write('{"task": "libero_90/28", "size": 128, "fast_st')  # the run was killed mid-line
    found = _load_rows(rows)
    assert list(found) == [("libero_90/23", 128)]
    assert found["libero_90/23", 128]["faces_after"] == 115107
