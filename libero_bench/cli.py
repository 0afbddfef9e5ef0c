"""``libero-bench``: lifelong-learning benchmark on libero-data datasets."""

from __future__ import annotations

from typing import Annotated

import typer

app = typer.Typer(
    name="libero-bench",
    help="Lifelong robot learning on LIBERO datasets made by libero-data.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)


@app.callback()
def _root() -> None:
    """Lifelong robot learning on LIBERO datasets made by libero-data."""


@app.command("orders")
def orders_cmd(
    order: Annotated[int | None, typer.Option("--order", help="Print only this order.", min=0)] = None,
) -> None:
    """Print LIBERO's upstream task orders for the 10-task suites (used by `run --order`)."""
    from libero_data.tasks import task_orders

    orders = task_orders()
    if order is not None and order >= len(orders):
        typer.echo(f"error: task order must be in 0..{len(orders) - 1}, got {order}", err=True)
        raise typer.Exit(2)
    for i, perm in enumerate(orders):
        if order is None or i == order:
            typer.echo(f"{i:2d}: {' '.join(map(str, perm))}")


def main() -> None:
    app()


if __name__ == "__main__":
    main()
