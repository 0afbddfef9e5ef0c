"""Two expert reports task for task: do they hold the same episodes?

A change to the code that decides an episode changes the expert's code hash, and the expert
tables are measured again. Where the change was meant to keep every episode (a refactoring),
this says whether it did: per task, the successes and every successful episode's length in
control steps, compared between the committed report and the new one.

    python -m benchmarks.compare_expert_tables cards/expert_report.jsonl NEW/expert_report.jsonl
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any


def _rows(path: Path) -> tuple[dict[str, Any], dict[str, dict[str, Any]]]:
    lines = path.read_text().splitlines()
    settings = json.loads(lines[0])["settings"]
    return settings, {row["ref"]: row for row in map(json.loads, lines[1:])}


def compare(old: Path, new: Path) -> dict[str, Any]:
    """Tasks both reports measured, those whose episodes differ, and the two expert codes."""
    old_settings, old_rows = _rows(old)
    new_settings, new_rows = _rows(new)
    both = sorted(set(old_rows) & set(new_rows))
    differ = [
        ref
        for ref in both
        if (old_rows[ref]["successes"], old_rows[ref]["lengths"])
        != (new_rows[ref]["successes"], new_rows[ref]["lengths"])
    ]
    return {
        "codes": (old_settings["expert"], new_settings["expert"]),
        "compared": len(both),
        "episodes": sum(int(new_rows[ref]["episodes"]) for ref in both),
        "differ": differ,
        "missing": sorted(set(old_rows) - set(new_rows)),
    }


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("old", type=Path)
    parser.add_argument("new", type=Path)
    args = parser.parse_args()
    found = compare(args.old, args.new)
    old_code, new_code = found["codes"]
    print(
        f"{found['compared']} tasks ({found['episodes']} episodes) measured by both {old_code} and {new_code}; "
        f"{len(found['differ'])} differ, {len(found['missing'])} not yet measured again"
    )
    for ref in found["differ"]:
        print(f"differs: {ref}")
    sys.exit(1 if found["differ"] else 0)


if __name__ == "__main__":
    main()
