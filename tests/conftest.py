"""Shared test set-up: one thread per process, headless rendering, small fixtures."""

from __future__ import annotations

import os

# Tests run on 2 cores: one thread per process keeps them from fighting (see NOTES.md).
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")
