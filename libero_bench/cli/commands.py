"""The ``libero-bench`` application: its commands, one module each (built when first asked for, after
:func:`libero_bench.cli.main` has pinned the numeric path)."""

from __future__ import annotations

from typing import Annotated

import typer

from libero_bench.cli import migrate, policy, results, robustness, run, saliency
from libero_data.cli.common import user_errors

app = typer.Typer(
    name="libero-bench",
    help="Lifelong learning on libero-data datasets, and evaluation in simulation of any policy (runs, LeRobot policies, openpi-protocol servers).",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,
)


@app.callback()
def _root() -> None:
    """Lifelong learning on libero-data datasets, and evaluation in simulation of any policy (runs, LeRobot policies, openpi-protocol servers)."""


@app.command("orders")
@user_errors
def orders_cmd(
    order: Annotated[int | None, typer.Option("--order", help="Print only this order.", min=0)] = None,
) -> None:
    """Print LIBERO's upstream task orders for the 10-task suites (used by `run --order`)."""
    from libero_data.errors import InputError
    from libero_data.tasks import task_orders

    orders = task_orders()
    if order is not None and order >= len(orders):
        raise InputError(f"task order must be in 0..{len(orders) - 1}, got {order}", field="order")
    for i, perm in enumerate(orders):
        if order is None or i == order:
            typer.echo(f"{i:2d}: {' '.join(map(str, perm))}")


app.command("run")(run.run_cmd)
app.command("report")(results.report_cmd)
app.command("compare")(results.compare_cmd)
app.command("eval")(policy.eval_cmd)
app.command("serve")(policy.serve_cmd)
app.command("replay")(results.replay_cmd)
app.command("saliency")(saliency.saliency_cmd)
app.command("robustness")(robustness.robustness_cmd)
app.command("migrate")(migrate.migrate_cmd)
