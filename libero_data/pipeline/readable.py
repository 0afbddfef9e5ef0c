"""Whether a dataset folder can be read at all: one sentence naming the file before any work.

Commands that read a dataset (training, re-rendering, replays) check its metadata and tables
here first, so a damaged copy (metadata that is not JSON, another LeRobot format version, a
truncated Parquet table, a missing table) is refused before anything is written or shown, rather
than failing inside LeRobot, ``datasets`` or pyarrow halfway through. ``libero-data validate``
goes further (frame counts, videos, MCAP logs, replays) and reports what it finds.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from libero_data.errors import DatasetError, MissingFileError, first_line
from libero_data.runtime.files import read_json

#: The LeRobot dataset format versions these tools read.
FORMAT = "v3."


def readable_dataset(root: Path) -> dict[str, Any]:
    """The dataset's ``meta/info.json`` once its metadata and tables are known readable."""
    root = Path(root)
    info_path = root / "meta" / "info.json"
    if not root.is_dir():
        raise MissingFileError(f"dataset folder {root} does not exist")
    if not info_path.is_file():
        raise DatasetError(f"{root} is not a LeRobot dataset (no meta/info.json)")
    info: dict[str, Any] = read_json(info_path, required=("features", "fps", "total_episodes"))
    version = str(info.get("codebase_version", ""))
    if not version.startswith(FORMAT):
        raise DatasetError(
            f"{info_path} says LeRobot dataset format {version or '(none)'}; these tools read {FORMAT}x "
            "(convert older datasets with lerobot's convert_dataset_v21_to_v30)"
        )
    if (root / "meta" / "libero.json").is_file():
        read_json(root / "meta" / "libero.json")
    _check_tables(root)
    return info


def _check_tables(root: Path) -> None:
    import pyarrow.parquet as pq

    for folder in (root / "meta" / "episodes", root / "data"):
        files = sorted(folder.rglob("*.parquet")) if folder.is_dir() else []
        if not files:
            raise DatasetError(
                f"{folder} is missing or holds no Parquet files: {root} is not a whole dataset"
            )
        for path in files:
            try:
                pq.read_metadata(path)
            except Exception as exc:  # pyarrow's errors for a damaged file vary by damage
                raise DatasetError(f"{path} is not a readable Parquet file ({first_line(exc)})") from None
