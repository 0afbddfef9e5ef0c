"""The notebooks run top to bottom (they are documentation that must not rot)."""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import pytest

NOTEBOOKS = Path(__file__).resolve().parents[1] / "notebooks"


def run_notebook(path: Path, tmp_path: Path) -> None:
    import nbformat
    from nbclient import NotebookClient

    nb = nbformat.read(path, as_version=4)
    saved = dict(os.environ)
    # The kernel spec starts "python": make that this environment's interpreter.
    os.environ["PATH"] = str(Path(sys.executable).parent) + os.pathsep + os.environ.get("PATH", "")
    os.environ["LIBERO_DATA_NOTEBOOK_OUT"] = str(tmp_path)
    try:
        NotebookClient(
            nb, timeout=900, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}}
        ).execute()
    finally:
        os.environ.clear()
        os.environ.update(saved)
    errors = [
        o
        for c in nb.cells
        if c.cell_type == "code"
        for o in c.get("outputs", [])
        if o.get("output_type") == "error"
    ]
    assert not errors


@pytest.mark.sim
def test_quickstart(tmp_path: Path) -> None:
    run_notebook(NOTEBOOKS / "01_quickstart.ipynb", tmp_path)
    assert (tmp_path / "quickstart" / "meta" / "info.json").is_file()


@pytest.mark.sim
@pytest.mark.slow  # a lifelong run end to end, as test_bench_run does; run after the default suite
def test_lifelong_benchmark(tmp_path: Path, tiny_dataset: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # the session's tiny dataset instead of generating one, and a shorter run
    monkeypatch.setenv("LIBERO_BENCH_NOTEBOOK_DATA", str(tiny_dataset))
    monkeypatch.setenv("LIBERO_BENCH_NOTEBOOK_QUICK", "1")
    run_notebook(NOTEBOOKS / "02_lifelong_benchmark.ipynb", tmp_path)
    run = tmp_path / "run-er-resnet_t"
    assert json.loads((run / "results.json").read_text())["complete"]
    report = json.loads((run / "report" / "report.json").read_text())
    assert [g["label"] for g in report["groups"]] == ["er + resnet_t"]


@pytest.mark.sim
@pytest.mark.xdist_group("procedural")  # with the other readers of the shared procedural suite
def test_procedural_tasks(tmp_path: Path, procedural_suite: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("LIBERO_DATA_NOTEBOOK_PROCEDURAL", str(procedural_suite))
    run_notebook(NOTEBOOKS / "03_procedural_tasks.ipynb", tmp_path)
    assert (tmp_path / "contact_sheet.png").stat().st_size > 10_000
