"""The ``libero-data`` application: its commands, one module each (built when first asked for, after
:func:`libero_data.cli.main` has pinned the numeric path)."""

from __future__ import annotations

import typer

from libero_data.cli import (
    card,
    dataset,
    expert_report,
    generate,
    import_hdf5,
    render_cache,
    rerender,
    scenes,
    tasks,
)

app = typer.Typer(
    name="libero-data",
    help="LIBERO tasks, scenes and demonstration datasets (LeRobot v3 format).",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,
)
app.command("tasks")(tasks.tasks_cmd)
app.command("show")(tasks.show_cmd)
app.command("generate")(generate.generate_cmd)
app.command("scenes")(scenes.scenes_cmd)
app.command("contact-sheet")(scenes.contact_sheet_cmd)
app.command("rerender")(rerender.rerender_cmd)
app.command("import")(import_hdf5.import_cmd)
app.command("render-cache")(render_cache.render_cache_cmd)
app.command("validate")(dataset.validate_cmd)
app.command("replay")(dataset.replay_cmd)
app.command("expert-report")(expert_report.expert_report_cmd)
app.command("card")(card.card_cmd)
