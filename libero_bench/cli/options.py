"""Options the commands that roll a policy out share (eval, robustness): where the policy runs,
how many environments step at once, and a policy server's observation mapping."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from libero_data.tasks.horizons import OPENPI_LIMITS, SUITE, limit_text

_DEVICES = "cpu, cuda or mps (default: cuda where available, then mps, else cpu)"
Device = Annotated[
    str | None,
    typer.Option("--device", help=f"Where the policy runs, once for all environments: {_DEVICES}."),
]
EnvWorkers = Annotated[
    int,
    typer.Option(
        "--workers",
        "-w",
        help="Processes that step the environments (physics and rendering): 1 steps them in this process, "
        "N >= 2 in N worker processes (as --workers everywhere).",
        min=1,
    ),
]
BatchSize = Annotated[
    int | None,
    typer.Option(
        "--batch-size",
        "-b",
        help="Environments stepped at once (default: two per worker). With two or more per worker they "
        "take turns in two halves: the policy answers one half in one batched forward pass while the "
        "workers step the other. Each environment holds its scene in memory: --batch-size equal to --workers "
        "keeps one per worker.",
        min=1,
    ),
]
Server = Annotated[
    str | None,
    typer.Option(
        "--server",
        help="Evaluate a policy served over openpi's websocket protocol at ws://HOST:PORT (openpi's "
        "serve_policy.py, libero-bench serve, ...) instead of a policy folder.",
    ),
]
SentImageSize = Annotated[
    int | None,
    typer.Option(
        "--image-size",
        help="With --server, --protocol standard or --benchmark: camera images sent (to a server or a local "
        "policy), resized with padding to this square size (default: the size the server's metadata names, "
        "else 224 as openpi's LIBERO client).",
        min=8,
    ),
]
ReplanSteps = Annotated[
    int,
    typer.Option(
        "--replan-steps",
        help="With --server: actions executed of each chunk the server returns before asking again "
        "(openpi's LIBERO client: 5).",
        min=1,
    ),
]


def policy_or_server(policy: object, server: str | None) -> str:
    """The policy reference of a command that takes a folder or ``--server``, exactly one of them."""
    from libero_bench.rollouts.policy_kinds import is_server
    from libero_data.errors import InputError

    if (policy is None) == (server is None):
        raise InputError("give a policy folder or --server ws://HOST:PORT, not both and not neither")
    if server is not None and not is_server(server):
        raise InputError(f"--server takes a websocket address such as ws://HOST:PORT, got {server!r}")
    return str(server if server is not None else policy)


KeepRollouts = Annotated[
    bool,
    typer.Option(
        "--keep-work",
        help="Keep the work files (each rollout's shard) once the rollouts are joined in rollouts/; by default "
        "the finished folder holds the results, report, rollouts and recordings only.",
    ),
]

_STEP_LIMIT = f"Steps before a rollout is cut: a number, or 'suite' for {limit_text(SUITE)}"
_BASE_SUITE = "a LIBERO-PRO, LIBERO-Plus or variant task takes its base suite's"
MaxSteps = Annotated[
    str,
    typer.Option(
        "--max-steps",
        help=f"{_STEP_LIMIT}; {_BASE_SUITE}.",
        show_default=True,
    ),
]
#: ``eval``'s, whose standard protocol and benchmarks take openpi's limits.
EvalMaxSteps = Annotated[
    str,
    typer.Option(
        "--max-steps",
        help=f"{_STEP_LIMIT}; under --protocol standard and --benchmark, openpi's ("
        + ", ".join(f"{suite} {n}" for suite, n in OPENPI_LIMITS.items())
        + f"); {_BASE_SUITE}.",
        show_default=True,
    ),
]
ServeDevice = Annotated[
    str | None,
    typer.Option(
        "--device",
        help="Where the served policy runs, one batched forward pass for every request that arrives "
        f"together: {_DEVICES}.",
    ),
]

ProtocolName = Annotated[
    str,
    typer.Option(
        "--protocol",
        help="libero-bench: stored and held-out starts (--stored, --heldout), intervals, paired tests. "
        "standard: LIBERO's evaluation as openpi's LIBERO client runs it, request for request (--trials "
        "episodes per task from stored init states 0..N-1, fixtures as LIBERO's resets place them after "
        "seed 7, 10 waiting steps, the suite's limit 220/280/300/520/400, 256 px cameras sent as 224 "
        "padded, replan 5): the number papers report.",
    ),
]
Trials = Annotated[
    int,
    typer.Option(
        "--trials",
        help="--protocol standard and --benchmark libero-pro: episodes per task (openpi: 50).",
        min=1,
        max=50,
    ),
]
Benchmark = Annotated[
    str | None,
    typer.Option(
        "--benchmark",
        help="libero-pro: the standard protocol over each base suite in --tasks (or tasks of it) and its "
        "four LIBERO-PRO families (object, swap, lan, task), and LIBERO-PRO's table (original, Obj, Pos, "
        "Sem, Task) with n and Wilson intervals; --trials per task. libero-plus (with --plus): LIBERO-Plus's "
        "tasks of each base suite in --tasks (libero_object: all; libero_object/0: those made from that task; "
        "plus/libero_object/17: one), each once from init state 0 under the standard protocol, and their "
        "table (seven categories and a total) with n and Wilson intervals.",
    ),
]
PerCategory = Annotated[
    int | None,
    typer.Option(
        "--per-category",
        help="--benchmark libero-plus: run this many tasks per category and suite (stratified by difficulty "
        "where --plus-classification gives it), drawn with --seed: the same tasks for every policy.",
        min=1,
    ),
]
SampleSeed = Annotated[int, typer.Option("--seed", help="--per-category: the seed of the draw.")]
PlusPrompt = Annotated[
    str,
    typer.Option(
        "--plus-prompt",
        help="LIBERO-Plus tasks: 'clean' sends each task's instruction; 'raw' sends what their benchmark "
        "sends, the task's file name as words with the perturbation's suffix ('... basket view 0 0 100 0 0 "
        "initstate 358'), for comparison.",
    ),
]
PlusClassification = Annotated[
    Path | None,
    typer.Option(
        "--plus-classification",
        help="Their task_classification.json: each task's difficulty, by which --per-category stratifies "
        "(default: the one in their checkout given as --plus; the wheel has none).",
    ),
]
EvalTasks = Annotated[
    list[str] | None,
    typer.Option(
        "--tasks",
        "-t",
        help="Tasks (libero_object/0, suite/name, a .bddl file), suites (libero_object, a LIBERO-PRO suite such "
        "as libero_goal_swap) or suite folders made by libero-data (procedural tasks, variants); repeat or "
        "comma-separate.",
    ),
]
StoredStarts = Annotated[
    int, typer.Option("--stored", help="Rollouts per task from LIBERO's stored init states.", min=0)
]
HeldoutStarts = Annotated[
    int,
    typer.Option(
        "--heldout", help="Rollouts per task from held-out placements no demonstration started from.", min=0
    ),
]
