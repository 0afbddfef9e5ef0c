"""An expert report read back: its journal's header as the lines above the tables, its tables
written again from the journal alone (:func:`rewrite_report`, nothing measured), and what a card
states of it (:func:`read_measured`, :func:`report_settings`)."""

from __future__ import annotations

import csv
import dataclasses
import json
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from libero_data.cards.expert_table import write_report
from libero_data.errors import FileFormatError, LiberoDataError, MissingFileError

if TYPE_CHECKING:
    from libero_data.experts.report import TaskResult


@dataclass(frozen=True)
class Measured:
    """One task's row of an expert report as a card states it: its successes over its episodes,
    those within its standard limit (None where not recorded), and the successful episodes'
    lengths (empty where the report's journal is not beside its table)."""

    successes: int
    episodes: int
    within: int | None = None
    lengths: tuple[int, ...] = ()


def read_measured(csv_path: Path) -> dict[str, Measured]:
    """{task name: :class:`Measured`} of an ``expert_report.csv`` (and its journal, where it is
    beside it, for the lengths); a table written before the standard limit was counted has no
    ``within_limit`` column and reads as not recorded."""
    if not Path(csv_path).is_file():
        raise MissingFileError(f"expert report {csv_path} does not exist")
    with Path(csv_path).open(newline="") as f:
        try:
            rows = {
                row["name"]: Measured(
                    int(row["successes"]),
                    int(row["episodes"]),
                    int(row["within_limit"]) if row.get("within_limit") else None,
                )
                for row in csv.DictReader(f)
            }
        except (KeyError, TypeError, ValueError, csv.Error, UnicodeDecodeError) as exc:
            what = f"no {exc.args[0]!r} column" if isinstance(exc, KeyError) else str(exc).splitlines()[0]
            raise FileFormatError(f"{csv_path} is not an expert report table ({what})") from None
    lengths = _journal_lengths(Path(csv_path).with_suffix(".jsonl"))
    return {
        name: dataclasses.replace(m, lengths=lengths[name])
        if len(lengths.get(name, ())) == m.successes
        else m
        for name, m in rows.items()
    }


def _journal_lengths(journal: Path) -> dict[str, tuple[int, ...]]:
    """Each task's successful episodes' lengths by task name, from a report's journal (none where
    there is no journal, or not one)."""
    from libero_data.experts.report import read_report

    try:
        _header, done = read_report(journal)
    except (LiberoDataError, OSError):
        return {}
    return {r.name: tuple(r.lengths) for r in done.values()}


def report_meta(header: Mapping[str, Any], results: list[TaskResult], total: int) -> dict[str, str]:
    """The lines above the report's tables, from its journal's header and rows alone."""
    settings = header["settings"]
    meta = {
        "inits per task": str(settings["inits"]),
        "seed": str(settings["seed"]),
        "expert code": str(settings["expert"]),
        "tasks measured": f"{len(results)} of {total}",
        "episode-minutes": f"{sum(r.seconds_per_episode * r.episodes for r in results) / 60:.0f}",
    }
    meta.update({f"version {k}": str(v) for k, v in (settings.get("versions") or {}).items()})
    key = settings.get("numeric_key")
    if key and header.get("machine"):
        meta[f"numeric path {key}"] = str(header["machine"])
    elif key:
        meta["numeric path"] = str(key)
    return meta


def rewrite_report(out_dir: str | Path) -> tuple[Path, Path]:
    """Write a report's tables again from its journal in ``out_dir`` alone (nothing is measured)."""
    from libero_data.experts.report import ReportJournal, read_report

    header, done = read_report(Path(out_dir) / ReportJournal.NAME)
    results = list(done.values())
    return write_report(results, out_dir, meta=report_meta(header, results, len(results)))


def report_settings(journal: Path) -> dict[str, str] | None:
    """Expert code, init states and seed from an expert report's journal header, if it has one."""
    try:
        settings = json.loads(Path(journal).read_text().split("\n", 1)[0])["settings"]
        found = {
            "expert code": str(settings["expert"]),
            "init states per task": str(settings["inits"]),
            "seed": str(settings["seed"]),
        }
        if "numeric_key" in settings:  # reports since machines were recorded
            found["numeric path"] = str(settings["numeric_key"])
        return found
    except (OSError, ValueError, KeyError, TypeError):
        return None  # no journal beside the table (or not one): the card just says less
