"""The test command is what CI runs, and it checks lint, formatting and types as well as tests."""

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
