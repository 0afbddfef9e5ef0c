"""The test command is what CI runs, and it checks lint, formatting and types as well as tests;
library code carries no dates and cites no measurement that a committed script does not repeat;
README is the front door, and its links and the docs' lead somewhere."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _commands(script: str) -> list[str]:
    """The script's command lines, comments and blank lines left out."""
    lines = (ROOT / script).read_text().splitlines()
    return [line.strip() for line in lines if line.strip() and not line.strip().startswith("#")]


def test_ci_runs_the_readme_test_command() -> None:
    assert _commands(".ci/run")[-1] == "exec bash scripts/test"
    assert "scripts/test" in (ROOT / "README.md").read_text()


def test_the_test_command_checks_lint_format_and_types_then_runs_pytest() -> None:
    text = "\n".join(_commands("scripts/test"))
    for check in (r"ruff check\b", r"ruff format --check\b", r"\bmypy\b", r"-m pytest \"\$@\""):
        assert re.search(check, text), check
    # mypy's own configuration names what it checks: the packages, the tests, the benchmarks and
    # the LeRobot plugin package.
    pyproject = (ROOT / "pyproject.toml").read_text()
    assert 'files = ["libero_data", "libero_bench", "tests", "benchmarks", "plugins"]' in pyproject


def test_library_code_carries_no_dates_or_unrepeatable_measurements() -> None:
    # Docstrings and comments say what the code does and why. A figure that is the reason for a
    # choice is cited from benchmarks/ (RESULTS.md, measured by a committed bench_*.py script),
    # where it can be measured again: not from a dated run, nor from a script that is not here.
    date = re.compile(r"\b20\d\d-[01]\d-[0-3]\d\b")
    found = []
    for package in ("libero_data", "libero_bench"):
        for path in sorted((ROOT / package).rglob("*.py")):
            for number, line in enumerate(path.read_text().splitlines(), 1):
                if date.search(line) or "one-off script" in line.lower():
                    found.append(f"{path.relative_to(ROOT)}:{number}: {line.strip()}")
    assert not found, "\n".join(found)


#: README is the front door: what the toolkit is, the two commands, one example per capability and
#: where to read more. The rest lives in docs/, one page per capability (issue 57).
README_WORDS = 1_700
#: A Markdown link or image: [text](target) or ![alt](target).
LINK = re.compile(r"\]\(([^)\s]+)\)")


def _relative_links(page: Path) -> list[str]:
    """The page's links to files in the repository (web addresses and bare anchors left out),
    without their anchors."""
    targets = LINK.findall(page.read_text())
    return [t.split("#")[0] for t in targets if "://" not in t and not t.startswith(("#", "mailto:"))]


def test_readme_is_the_front_door_and_links_to_every_docs_page() -> None:
    readme = ROOT / "README.md"
    words = len(readme.read_text().split())
    assert words <= README_WORDS, f"README.md has {words} words: move detail to its page in docs/"
    linked = {t for t in _relative_links(readme) if t.startswith("docs/")}
    assert linked, "README.md links to no docs/ page"
    for target in sorted(linked):
        assert (ROOT / target).is_file(), f"README.md links to {target}, which does not exist"
    pages = {f"docs/{p.name}" for p in (ROOT / "docs").glob("*.md")}
    assert pages <= linked, f"docs pages README.md does not link to: {sorted(pages - linked)}"


def test_every_relative_link_of_readme_and_the_docs_points_to_a_file() -> None:
    pages = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
    broken = [
        f"{page.relative_to(ROOT)}: {target}"
        for page in pages
        for target in _relative_links(page)
        if not (page.parent / target).exists()
    ]
    assert not broken, broken


def test_committed_results_name_paths_relative_to_their_folder() -> None:
    """No committed result names a path of the machine that made it; the runs a committed report
    or sweep names, and a run's initial checkpoint, are found from the file's own folder."""
    import json

    machine = re.compile(r'["`](/work|/home|/tmp|/root|/Users|[A-Z]:\\\\)[^"`]*["`]')
    named = []
    for path in sorted((ROOT / "benchmarks" / "results").rglob("*")):
        if path.suffix not in (".json", ".md", ".jsonl", ".csv") or not path.is_file():
            continue
        text = path.read_text()
        assert not machine.search(text), f"{path.relative_to(ROOT)}: {machine.search(text)}"
        if path.suffix != ".json":
            continue
        data = json.loads(text)
        if path.name == "robustness.json":
            named.append((path, data["policy"]))
        elif path.name == "report.json" and "groups" in data:
            named += [(path, run["path"]) for run in data["runs"]]
        elif path.name in ("report.json", "libero_pro.json") and "policy" in data:  # an evaluation's
            named.append((path, data["policy"]))
        elif path.name == "config.json" and data.get("init_checkpoint"):
            named.append((path, data["init_checkpoint"]))
    assert len(named) >= 45  # 12 sweeps, 11 runs named by reports, 2 initial checkpoints, 21 evaluations
    for path, name in named:
        assert (path.parent / name).exists(), f"{path.relative_to(ROOT)} names {name}, which is not there"


def test_no_tracked_file_is_the_environment_or_a_link_out_of_the_repository() -> None:
    """A worktree's `.venv` link once slipped into a commit, and a checkout then replaced the
    environment it pointed to with the link itself."""
    import shutil
    import subprocess

    import pytest

    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("not a git checkout (an unpacked archive): nothing is tracked")
    tracked = subprocess.run(
        ["git", "ls-files", "-s"], cwd=ROOT, capture_output=True, text=True, check=True
    ).stdout.splitlines()
    links = [line.split("\t", 1)[1] for line in tracked if line.startswith("120000")]
    paths = [line.split("\t", 1)[1] for line in tracked]
    assert not [p for p in paths if p == ".venv" or p.startswith(".venv/")]
    for link in links:
        target = (ROOT / link).resolve()
        assert target.is_relative_to(ROOT), f"{link} links out of the repository, to {target}"
