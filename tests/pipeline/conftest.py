"""The pipeline tests share the session's tiny dataset (``tests/conftest.py``)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from tests.tiny_data import TINY, run_cli

__all__ = ["TINY", "data_table", "run_cli"]


def data_table(root: Path) -> Any:
    """Every frame row of a dataset's parquet files, in global frame order (a pyarrow Table)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    tables = [pq.read_table(p) for p in sorted((root / "data").glob("*/*.parquet"))]
    return pa.concat_tables(tables).sort_by("index")
