"""What a card says of its episodes' lengths: each task's standard limit and its successes within
it, the length plot's panels (one per base suite of the tasks), the length bound a dataset was
made under and what that bound cost (attempts stopped at it, episodes given up).

Both cards use it: the one ``generate`` writes into a dataset (:func:`dataset_lengths`) and the
one rendered from an expert report before any data exists (:func:`report_lengths`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from libero_data.cards.lengths import (
    LengthPanel,
    counted,
    human_longest,
    length_plot,
    length_section,
    within_limit,
)
from libero_data.pipeline.request import AFTER_GOAL, STANDARD
from libero_data.tasks.horizons import base_suite, standard_limit

if TYPE_CHECKING:
    from libero_data.cards.expert_files import Measured
    from libero_data.pipeline.episodes import EpisodeDone
    from libero_data.pipeline.request import GenerateRequest, Slot
    from libero_data.tasks.task import Suite, Task

#: Where a dataset keeps its length plot (``meta/`` is published whole, with the card).
LENGTH_PLOT = "meta/episode_lengths.png"


@dataclass(frozen=True)
class TaskLengths:
    """One task's lengths as a card states them."""

    task: Task
    limit: int  # its standard limit
    lengths: tuple[int, ...]  # its episodes' (the dataset's, or the expert report's successes)
    within: int | None  # its successes within the standard limit (None: not known)
    bound: int | None = None  # the length bound it was searched under (None: none)
    attempts: int = 0
    successes: int = 0
    too_long: int = 0  # attempts stopped at the bound
    given_up: int = 0


def dataset_lengths(
    request: GenerateRequest,
    suite: Suite,
    slots: Sequence[Slot],
    status: Mapping[str, EpisodeDone],
    infos: Sequence[Mapping[str, Any]],
    *,
    of_attempts: bool = True,
) -> list[TaskLengths]:
    """Per requested task: its standard limit and bound, its published episodes' lengths, its
    successes (within the limit), attempts, attempts stopped and episodes given up.

    ``of_attempts``: successes and attempts are the finished slots' (a search that keeps only
    successful attempts); otherwise the published episodes whose goal holds after their last
    action (``episode.json``'s ``success``), of the episodes published
    (:data:`~libero_data.cards.card.GOAL_REACHED`)."""
    rows = []
    for position, index in enumerate(request.tasks):
        task = suite.task(index)
        limit = standard_limit(suite, task.name)
        done = [status[s.key] for s in slots if s.position == position and s.key in status]
        episodes = [i for i in infos if int(i["task_index"]) == index]
        if of_attempts:
            attempts = sum(d.attempts for d in done)
            successes = [d.length for d in done if d.success]
        else:
            attempts = len(episodes)
            successes = [to_goal(i) for i in episodes if i.get("success", True)]
        rows.append(
            TaskLengths(
                task=task,
                limit=limit,
                lengths=tuple(to_goal(i) for i in episodes),
                within=sum(1 for n in successes if n <= limit),
                bound=request.length_bound(task),
                attempts=attempts,
                successes=len(successes),
                too_long=sum(d.too_long for d in done),
                given_up=sum(1 for d in done if not d.success),
            )
        )
    return rows


def to_goal(info: Mapping[str, Any]) -> int:
    """An episode's steps to its goal, what the standard limit and the length bound count: its
    length, less the steps recorded after the goal (``--after-goal``: ``goal_step`` names it)."""
    return int(info.get("goal_step") or info["length"])


def after_goal_words(request: GenerateRequest) -> str:
    """The card's settings row for the steps recorded after the goal."""
    if not request.after_goal:
        return "0 (`--after-goal 0`): an episode ends at the step its goal is first reached"
    default = ", the default" if request.after_goal == AFTER_GOAL else ""
    return (
        f"{request.after_goal} (`--after-goal {request.after_goal}`{default}): the arm held still, the gripper as it was; "
        "the goal still holds after them. Lengths against the limit and the bound count the steps to the goal"
    )


def report_lengths(
    request: GenerateRequest, suite: Suite, measured: Mapping[str, Measured]
) -> list[TaskLengths]:
    """Per task of ``suite``: what an expert report measured of its lengths (first attempts), with
    the bound ``request`` (the default one) would give it."""
    rows = []
    for task in suite.tasks:
        m = measured.get(task.name)
        limit = standard_limit(suite, task.name)
        lengths = m.lengths if m is not None else ()
        within = m.within if m is not None and m.within is not None else None
        if within is None and m is not None and len(lengths) == m.successes:
            within = within_limit(lengths, limit)
        rows.append(
            TaskLengths(
                task,
                limit,
                lengths,
                within,
                bound=request.length_bound(task),
                attempts=m.episodes if m else 0,
                successes=m.successes if m else 0,
            )
        )
    return rows


def panels(suite: Suite, rows: Sequence[TaskLengths]) -> list[LengthPanel]:
    """The plot's panels: one per base suite of the tasks (one for nearly every dataset)."""
    groups: dict[str | None, list[TaskLengths]] = {}
    for row in rows:
        groups.setdefault(base_suite(suite, row.task.name), []).append(row)
    out = []
    for base, members in groups.items():
        title = suite.name if len(groups) == 1 else f"{suite.name}: tasks of {base or 'no LIBERO suite'}"
        if base is None:
            title += " (no base suite: the default limit)"
        human = human_longest(suite, members[0].task.name)
        out.append(
            LengthPanel(
                title=title,
                lengths=tuple(n for r in members for n in r.lengths),
                limits=tuple(sorted({r.limit for r in members})),
                within=sum(within_limit(r.lengths, r.limit) for r in members),
                human=human[1] if human else None,
            )
        )
    return out


def bound_words(request: GenerateRequest, rows: Sequence[TaskLengths]) -> str:
    """The card's settings row for the length bound."""
    if request.max_length is None:
        return "none: episodes are kept however long they are"
    bounds = " / ".join(str(b) for b in sorted({r.bound for r in rows if r.bound is not None}))
    if request.max_length == STANDARD:
        return f"{bounds} steps: each task's standard limit (`--max-length standard`, the default)"
    return f"{bounds} steps (`--max-length {request.max_length}`)"


def dataset_note(request: GenerateRequest, rows: Sequence[TaskLengths]) -> str:
    """What a dataset's card says of its length bound and of what the bound cost."""
    over = sum(len(r.lengths) - within_limit(r.lengths, r.limit) for r in rows)
    episodes = sum(len(r.lengths) for r in rows)
    if request.max_length is None:
        return (
            f"**Length bound: none.** Episodes are kept however long they are: {over} of "
            f"{counted(episodes, 'episode')} {'is' if over == 1 else 'are'} longer than their task's standard limit."
        )
    words = bound_words(request, rows)
    if request.rerender_of:
        longer = sum(1 for r in rows for n in r.lengths if r.bound is not None and n > r.bound)
        return (
            f"**Length bound: {words}.** These episodes were searched under it for `{request.rerender_of}`, whose "
            f"card says what it cost; {longer} of the {counted(episodes, 'episode')} here "
            f"{'is' if longer == 1 else 'are'} longer than it."
        )
    stopped = sum(r.too_long for r in rows)
    per_task = ", ".join(f"task {r.task.index}: {r.too_long}" for r in rows if r.too_long)
    return (
        f"**Length bound: {words}.** An attempt still going at the bound was stopped there and counted as a "
        "failed attempt (whether it would have reached the goal later is not known), and the search went on "
        "with the next attempt's seeds from the same start. What it cost: "
        f"{stopped} of {sum(r.attempts for r in rows)} attempts stopped at the bound"
        f"{f' ({per_task})' if per_task else ''}, each followed by another attempt unless its episode was "
        f"given up; {counted(sum(r.given_up for r in rows), 'episode')} given up after {request.max_attempts} "
        f"failed attempts (for any reason). Of the {counted(episodes, 'episode')} kept, {over} "
        f"{'is' if over == 1 else 'are'} longer than their task's standard limit."
    )


def report_note(rows: Sequence[TaskLengths]) -> str:
    """What a card rendered from an expert report says of the length bound ``generate`` sets."""
    lengths = sum(len(r.lengths) for r in rows)
    over = sum(len(r.lengths) - within_limit(r.lengths, r.limit) for r in rows)
    share = f" ({over / lengths:.0%})" if lengths else ""
    slow = [r for r in rows if r.within is not None and r.attempts and r.within < r.attempts / 2]
    warning = (
        " Tasks with fewer than half of their attempts within the limit: "
        + ", ".join(f"{r.task.index} ({r.within}/{r.attempts})" for r in slow)
        + ": with the default most of their attempts are stopped, and a task none of whose attempts fits gives "
        "up its episodes (`--max-length none` keeps them however long)."
        if slow
        else ""
    )
    return (
        "**Length bound.** `libero-data generate` keeps by default only episodes within each task's standard "
        "limit (`--max-length`): an attempt still going at the limit is stopped and the search goes on with "
        f"the next attempt. Of the expert's successful attempts in the report, {over} of {lengths}{share} are "
        f"longer: with the default, each such start costs another attempt.{warning}"
    )


def success_line(rows: Sequence[TaskLengths], header: str = "expert success") -> str:
    """Success at all and within the standard limit over all of a card's tasks, with 95% intervals
    (``header``: what the card's success column is called)."""
    from libero_data.stats import wilson_interval

    attempts = sum(r.attempts for r in rows)
    if not attempts:
        return ""

    def rate(n: int) -> str:
        low, high = wilson_interval(n, attempts)
        return f"{n}/{attempts} ({n / attempts:.1%}, 95% interval {low:.1%}–{high:.1%})"

    line = f"**All tasks:** {header} {rate(sum(r.successes for r in rows))}"
    if all(r.within is not None for r in rows):
        line += f"; within the standard limit {rate(sum(r.within or 0 for r in rows))}"
    return line + "."


def lengths_card(
    suite: Suite, rows: Sequence[TaskLengths], note: str, image: str, success_header: str = "expert success"
) -> tuple[str, bytes | None]:
    """The card's *Episode lengths* section and its plot (None where no task has lengths)."""
    chosen = panels(suite, rows)
    plot = length_plot(chosen) if any(p.lengths for p in chosen) else None
    closing = "\n\n".join(x for x in (success_line(rows, success_header), note) if x)
    return length_section(chosen, image if plot is not None else None, closing), plot
