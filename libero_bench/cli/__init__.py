"""``libero-bench``: the lifelong-learning benchmark on datasets made by libero-data.

One module per command; each builds a typed request from its options and calls the library.
Bad input (a missing folder, an unknown task, a bad option) prints one sentence and exits with
2. Heavy modules (torch, lerobot, the simulator) are imported inside the commands, and the
commands themselves only once the numeric path is pinned (:func:`libero_data.cli.run_tool`).
"""

from __future__ import annotations

from libero_data.cli import lazy_app, run_tool

COMMANDS = "libero_bench.cli.commands"


def main() -> None:
    """``libero-bench``."""
    run_tool(COMMANDS)


__getattr__ = lazy_app(COMMANDS)
