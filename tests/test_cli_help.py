"""Every command's --help reads whole in an 80-column terminal (issue 75): long names such as
``observation.images.wrist_image`` or ``$LIBERO_DATA_PLUS_ASSETS`` wrapped, never cut."""

from __future__ import annotations

import pytest
import typer
from typer.testing import CliRunner


def _apps() -> list[tuple[str, typer.Typer]]:
    from libero_bench.cli.commands import app as bench
    from libero_data.cli.commands import app as data

    return [("libero-data", data), ("libero-bench", bench)]


def _commands(app: typer.Typer) -> list[str]:
    return [c.name or c.callback.__name__ for c in app.registered_commands if c.callback is not None]


@pytest.mark.parametrize("name", ["libero-data", "libero-bench"])
def test_help_stays_whole_at_80_columns(name: str) -> None:
    app = dict(_apps())[name]
    runner = CliRunner()
    commands = _commands(app)
    assert len(commands) >= 8
    for command in commands:
        result = runner.invoke(app, [command, "--help"], terminal_width=80, env={"COLUMNS": "80"})
        assert result.exit_code == 0, f"{name} {command} --help: {result.output[-500:]}"
        for line in result.output.splitlines():
            assert len(line) <= 80, f"{name} {command} --help: {line!r}"
            assert "…" not in line, f"{name} {command} --help cuts a word: {line!r}"
    generate = runner.invoke(dict(_apps())["libero-data"], ["generate", "--help"], env={"COLUMNS": "80"})
    assert "observation.images.wrist_image" in generate.output


def test_help_names_what_each_kind_of_client_gets() -> None:
    """``generate --help`` names every registered source and what a request for it needs;
    ``serve --help`` says what openpi's client gets from a policy that acts step by step."""
    from libero_bench.registry_docs import ours
    from libero_data.pipeline.sources import demo_sources

    apps = dict(_apps())
    runner = CliRunner()

    def letters(text: str) -> str:  # rich wraps where it likes, hyphens included
        return "".join(text.split())

    def help_text(app: str, command: str) -> str:
        return letters(runner.invoke(apps[app], [command, "--help"], env={"COLUMNS": "200"}).output)

    generate = help_text("libero-data", "generate")
    # the project's sources (a test's throw-away one may be registered after the help was made)
    for source in (s for s in demo_sources() if ours(type(s))):
        named = f"{source.name}, only with {source.needs}" if source.needs else source.name
        assert letters(named) in generate, f"generate --help does not name the source {named!r}"
    assert letters("Generate scripted demonstrations") not in generate
    serve = help_text("libero-bench", "serve")
    assert letters("predicts one action per step") in serve and letters("--replan-steps 1") in serve
