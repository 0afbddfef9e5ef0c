"""Fixtures for the libero_bench tests: one torch thread, tiny synthetic batches."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
import torch
from bench_helpers import BatchFactory, make_run, synthetic_batch


@pytest.fixture(autouse=True, scope="session")
def _one_thread() -> Iterator[None]:
    previous = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(previous)


@pytest.fixture
def make_batch() -> BatchFactory:
    return synthetic_batch


@pytest.fixture(scope="session")
def er_run(tiny_dataset: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A finished two-task ER run on the tiny dataset, made without simulation (its checkpoints
    hold replay memories keyed by task number); read-only to the tests."""
    return make_run(tiny_dataset, tmp_path_factory.mktemp("er_run") / "run")
