"""``libero-bench``: the lifelong-learning benchmark on datasets made by libero-data.

One module per command; each builds a typed request from its options and calls the library.
Bad input (a missing folder, an unknown task, a bad option) prints one sentence and exits with
2. Heavy modules (torch, lerobot, the simulator) are imported inside the commands.
"""

from __future__ import annotations

from typing import Any


def main() -> None:
    """``libero-bench``: pin the numeric path, then load the commands and run the one asked for.

    The commands are imported only now: several load NumPy, which must come after the pin
    (:mod:`libero_data.numerics`)."""
    from libero_data.numerics import pin

    pin()  # before anything loads NumPy
    from libero_bench.cli.commands import app

    app()


def __getattr__(name: str) -> Any:
    if name == "app":  # ``from libero_bench.cli import app`` (tests, embedding): the Typer application
        from libero_bench.cli.commands import app

        return app
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
