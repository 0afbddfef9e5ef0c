"""``libero-data``: LIBERO tasks, scenes and demonstration datasets from the command line.

One module per command; each builds a typed request from its options and calls the library.
Bad input (an unknown task, malformed BDDL, a bad flag) prints one sentence and exits with 2.
The commands are loaded only when asked for (:func:`main`, or ``app``): several load NumPy,
which must come after the numeric path is pinned (:mod:`libero_data.numerics`).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Any

COMMANDS = "libero_data.cli.commands"


def run_tool(commands: str) -> None:
    """Pin the numeric path, then load the Typer ``app`` of the module ``commands`` and run it
    (the entry point of ``libero-data`` and ``libero-bench``)."""
    from libero_data.numerics import pin

    pin()  # before anything loads NumPy
    importlib.import_module(commands).app()


def lazy_app(commands: str) -> Callable[[str], Any]:
    """A module ``__getattr__`` that gives ``app`` (``from <tool>.cli import app``: tests,
    embedding) from the module ``commands``, loaded when first asked for."""

    def __getattr__(name: str) -> Any:
        if name == "app":
            return importlib.import_module(commands).app
        raise AttributeError(f"module {commands.rpartition('.')[0]!r} has no attribute {name!r}")

    return __getattr__


def main() -> None:
    """``libero-data``."""
    run_tool(COMMANDS)


__getattr__ = lazy_app(COMMANDS)
