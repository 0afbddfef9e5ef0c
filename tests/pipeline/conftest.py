"""The pipeline tests share the session's tiny dataset (``tests/conftest.py``)."""

from __future__ import annotations

from tests.tiny_data import TINY, run_cli

__all__ = ["TINY", "run_cli"]
