"""``libero-data generate``'s options on which episodes a dataset keeps: how many attempts an
episode gets, how long it may be, and what is recorded after its goal."""

from __future__ import annotations

from typing import Annotated

import typer

from libero_data.pipeline.request import AFTER_GOAL, MOST_AFTER_GOAL

MaxAttempts = Annotated[
    int,
    typer.Option("--max-attempts", help="Expert attempts per episode before the episode is given up.", min=1),
]
MaxLength = Annotated[
    str,
    typer.Option(
        "--max-length",
        metavar="N|standard|none",
        help="Longest episode kept, in control steps: N, 'standard' (each task's standard evaluation limit: "
        "openpi's step limit of its suite, libero_spatial 220, libero_object 280, libero_goal 300, libero_10 520, "
        "libero_90 400; LIBERO-PRO/Plus suites and variants take their base suite's, procedural tasks 500) or "
        "'none'. An attempt still going at the bound is stopped and counts as a failed attempt; the card states "
        "the bound and what it cost.",
    ),
]
AfterGoal = Annotated[
    int | None,
    typer.Option(
        "--after-goal",
        help=f"Steps recorded after the goal is first reached, the arm held still and the gripper as it was (open "
        f"after a release), as robosuite's and LIBERO's human collection records them (default: {AFTER_GOAL} for the "
        "scripted expert; other sources keep their episodes as recorded). With 0 a release is the last 3 frames of an "
        "episode. The goal must still hold after them; --max-length counts the steps to the goal.",
        min=0,
        max=MOST_AFTER_GOAL,
        show_default=False,
    ),
]
