"""Fixtures for the libero_bench tests: one torch thread, tiny synthetic batches."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
import torch
from bench_helpers import BatchFactory, synthetic_batch


@pytest.fixture(autouse=True, scope="session")
def _one_thread() -> Iterator[None]:
    previous = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(previous)


@pytest.fixture
def make_batch() -> BatchFactory:
    return synthetic_batch
