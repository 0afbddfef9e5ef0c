"""Shared test set-up: one thread per process, headless rendering, small fixtures."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from tests.tiny_data import make_procedural_suite, make_tiny_dataset

# Tests run on 2 cores: one thread per process keeps them from fighting (see NOTES.md).
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")


@pytest.fixture(scope="session")
def tiny_dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two libero_goal tasks, one expert episode each, 64x64 images (~1.5 min to make); shared
    by the pipeline and benchmark tests."""
    return make_tiny_dataset(tmp_path_factory.mktemp("tiny") / "dataset")


@pytest.fixture(scope="session")
def procedural_suite(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A generated two-task procedural suite with its dataset (a few minutes to make)."""
    return make_procedural_suite(tmp_path_factory.mktemp("procedural") / "p")
