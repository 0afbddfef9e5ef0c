"""Committed results made before results named paths relative to their folder, rewritten as
today's code writes them (issue 57): a run's datasets and initial checkpoint relative to the run,
a report's or comparison's runs relative to it, a sweep's policy and variant files relative to
the sweep.

Every committed result was made in a work folder (``../quick-work``, ``../quick``) laid out as
``benchmarks/robustness_data.sh`` and ``benchmarks/quick.sh`` lay it out: datasets at its top,
runs in ``runs/`` (or ``runs-fixed-arm/``), sweeps in ``sweeps/``. A path is named relative to
where its file stood in that folder; where the thing named was committed too (a run a report
reads, the policy a sweep measured), relative to where both are committed, so that the
committed report still finds its runs.

    python -m benchmarks.relative_paths
"""

from __future__ import annotations

import argparse
import json
import os
import re
from pathlib import Path
from typing import Any

RESULTS = Path(__file__).resolve().parent / "results"
#: The work folders the committed results were made in.
WORK = re.compile(r"^/work/(quick-work|quick)/")
#: The runs of the earlier work folder (``/work/quick``: the recipes and the fixed-arm round) a
#: committed report names, and where they are committed (RESULTS.md: Quick results).
COMMITTED_AS = {
    "/work/quick/runs/single-0": "quick/recipes/smoke-d50",
    "/work/quick/runs-fixed-arm/single-0.full-eval": "quick/fixed-arm/runs/single-0",
    "/work/quick/runs-fixed-arm/single-1": "quick/fixed-arm/runs/single-1",
}


def _in_work(path: str) -> str | None:
    """``path`` relative to its work folder, or None for a path outside one."""
    match = WORK.match(path)
    return path[match.end() :] if match else None


def _committed(path: str, results: Path, here: Path) -> Path | None:
    """The committed copy of what stood at ``path``, if any: ``../quick-work``'s runs and sweeps
    are committed under the same names (in the results folder of the file naming them first: both
    `quick/` and `robustness_data/` hold a `runs/single-spatial-8`), ``../quick``'s as
    :data:`COMMITTED_AS` says."""
    if path in COMMITTED_AS:
        return results / COMMITTED_AS[path]
    inside = _in_work(path)
    if path.startswith("/work/quick-work/") and inside is not None:
        own = here.relative_to(results).parts[0]
        for root in (own, *(r for r in ("quick", "robustness_data") if r != own)):
            if (results / root / inside).exists():
                return results / root / inside
    return None


def _named(path: Any, original: str, results: Path, here: Path) -> Any:
    """``path`` (absolute, in a work folder) named from the file's folder: from the committed
    folder ``here`` where the target was committed too, else from where the file stood in the
    work folder (``original``, relative to it)."""
    if isinstance(path, str) and path.startswith("benchmarks/results/"):  # named from the repository's root
        return os.path.relpath(results.parent.parent / path, here)
    if not isinstance(path, str) or (inside := _in_work(path)) is None:
        return path
    target = _committed(path, results, here)
    if target is not None:
        return os.path.relpath(target, here)
    return os.path.relpath("/w/" + inside, "/w/" + original)


def _run_config(data: dict[str, Any], original: str, results: Path, here: Path) -> None:
    data["data"] = _named(data["data"], original, results, here)
    data["init_checkpoint"] = _named(data.get("init_checkpoint"), original, results, here)
    for entry in data.get("mix", {}).get("datasets", []):
        entry["data"] = _named(entry["data"], original, results, here)


def _report(data: dict[str, Any], original: str, results: Path, here: Path) -> None:
    for run in data.get("runs", []):
        run["path"] = _named(run["path"], original, results, here)
    for group in data.get("groups", []):
        group["runs"] = [_named(p, original, results, here) for p in group["runs"]]
    if "files" in data:  # named from the repository's root before: from the report's folder now
        data["files"] = [Path(p).name if (here / Path(p).name).exists() else p for p in data["files"]]


def _sweep(data: dict[str, Any], original: str, results: Path, here: Path) -> None:
    data["policy"] = _named(data["policy"], original, results, here)
    for cell in data["table"]["cells"]:
        cell["bddl"] = _named(cell["bddl"], original, results, here)


def rewrite(results: Path = RESULTS) -> list[Path]:
    """Rewrite every committed result that names an absolute path; the files changed."""
    from libero_bench.robustness.cells import sweep_markdown

    changed = []
    for path in sorted(results.rglob("*.json")):
        text = path.read_text()
        if not re.search(r'"(/work/(quick-work|quick)|benchmarks/results)/', text):
            continue
        here = path.parent
        data = json.loads(text)
        rel = here.relative_to(results).as_posix()
        if path.name == "config.json" and "algo" in data:
            # a run: it stood in the work folder's runs/ (runs-fixed-arm/ for the fixed-arm runs)
            _run_config(
                data, ("runs-fixed-arm/" if "fixed-arm" in rel else "runs/") + here.name, results, here
            )
        elif path.name == "report.json" and "groups" in data:
            _report(data, "reports/" + here.name, results, here)
        elif path.name == "compare.json" and {"a", "b"} <= set(data):
            for side in ("a", "b"):
                if "path" in data[side]:
                    data[side]["path"] = _named(data[side]["path"], "compare/" + here.name, results, here)
                if "sweeps" in data[side]:
                    data[side]["sweeps"] = [
                        _named(p, "compare/" + here.name, results, here) for p in data[side]["sweeps"]
                    ]
        elif path.name == "robustness.json":
            _sweep(data, "sweeps/" + here.name, results, here)
        else:
            raise SystemExit(f"{path} names an absolute path and is not a run, report or sweep")
        path.write_text(json.dumps(data, indent=2, sort_keys=True) + "\n")
        changed.append(path)
        if path.name == "robustness.json":  # its title names the policy (the heatmap does not)
            levels = tuple(int(level) for level in data["request"]["levels"])
            (here / "robustness.md").write_text(sweep_markdown(data, levels))
            changed.append(here / "robustness.md")
    return changed


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.parse_args()
    for path in rewrite():
        print(f"rewrote {path.relative_to(RESULTS.parent.parent)}")


if __name__ == "__main__":
    main()
