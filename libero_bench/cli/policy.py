"""``libero-bench eval``: a LeRobot policy (from lerobot-train) or a served one evaluated in our
simulator; ``libero-bench serve``: our policies and LeRobot's behind openpi's websocket protocol."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

from libero_bench.cli.options import (
    BatchSize,
    Benchmark,
    Device,
    EnvWorkers,
    EvalMaxSteps,
    EvalTasks,
    HeldoutStarts,
    KeepRollouts,
    PerCategory,
    PlusClassification,
    PlusPrompt,
    ProtocolName,
    ReplanSteps,
    SampleSeed,
    SentImageSize,
    ServeDevice,
    Server,
    StoredStarts,
    Trials,
    policy_or_server,
)
from libero_data.cli.common import (
    ExecutorKind,
    PlusAssetsOption,
    PlusFilesOption,
    RayAddress,
    ViewRenderQuality,
    quiet_environment,
    rollout_progress,
    say,
    split_list,
    use_plus,
    user_errors,
)


@user_errors
def eval_cmd(
    policy: Annotated[
        Path | None,
        typer.Argument(
            help="A LeRobot policy (the pretrained_model/ folder lerobot-train writes), a libero-bench run "
            "folder (its final checkpoint), or --server."
        ),
    ] = None,
    tasks: EvalTasks = None,
    out: Annotated[
        Path | None, typer.Option("--out", "-o", help="Evaluation folder (created; an existing one resumes).")
    ] = None,
    stored: StoredStarts = 20,
    heldout: HeldoutStarts = 20,
    protocol: ProtocolName = "libero-bench",
    trials: Trials = 50,
    benchmark: Benchmark = None,
    max_steps: EvalMaxSteps = "suite",
    server: Server = None,
    device: Device = None,
    workers: EnvWorkers = 1,
    batch_size: BatchSize = None,
    executor: ExecutorKind = "local",
    ray_address: RayAddress = None,
    image_size: SentImageSize = None,
    replan_steps: ReplanSteps = 5,
    render_quality: ViewRenderQuality = "full",
    keep_work: KeepRollouts = False,
    plus: PlusFilesOption = None,
    plus_assets: PlusAssetsOption = None,
    per_category: PerCategory = None,
    seed: SampleSeed = 0,
    plus_prompt: PlusPrompt = "clean",
    plus_classification: PlusClassification = None,
) -> None:
    """Evaluate a policy in simulation: a LeRobot policy (ACT, Diffusion Policy, SmolVLA, ...), a
    libero-bench run, or a served one (--server); every rollout stored, success with intervals.

    The policy runs once, on --device, batched over --batch-size environments that step in --workers
    processes (or Ray actors with --executor ray). A policy folder's inputs are served from its declared
    features (either camera naming, any image size, the 8-D state) and its own pre- and post-processors
    run as in lerobot-eval. A server gets, under the default protocol, openpi's LIBERO observation
    (observation/image, observation/wrist_image, observation/state, prompt) with the arm's joints, the
    gripper and a rollout key, over a connection per episode; under --protocol standard and
    --benchmark, openpi's request exactly as its LIBERO client sends it (with the entries the server's
    metadata asks for). Its action chunks are executed --replan-steps at a time. --protocol standard reproduces openpi's LIBERO client exactly (docs/evaluation.md:
    Reproducing a published LIBERO score); --benchmark libero-pro makes LIBERO-PRO's table, --benchmark
    libero-plus (with --plus) LIBERO-Plus's.
    """
    quiet_environment()
    from libero_bench.evaluation.policy_eval import EvalRequest
    from libero_bench.rollouts.loop import RolloutResources
    from libero_data.errors import InputError
    from libero_data.runtime.jobs import JobPlacement
    from libero_data.tasks.horizons import parse_step_limit

    if not tasks:
        raise InputError("name the tasks to evaluate on", field="tasks")
    if out is None:
        raise InputError("name the evaluation folder", field="out")
    execution = RolloutResources(JobPlacement(executor, workers, ray_address), batch_size, device)
    use_plus(plus, plus_assets)
    shared = {
        "max_steps": parse_step_limit(max_steps),
        "render_quality": render_quality,
        "image_size": image_size,
        "replan_steps": replan_steps,
    }
    chosen, refs = policy_or_server(policy, server), split_list(tasks)
    if benchmark == "libero-plus":
        plus_options = {"per_category": per_category, "seed": seed, "prompt": _plus_prompt(plus_prompt)}
        run = {"execution": execution, "keep_work": keep_work, **shared, **plus_options}
        _libero_plus(chosen, refs, out, classification=plus_classification, **run)
    elif benchmark is not None:
        run = {"execution": execution, "keep_work": keep_work, **shared}
        _libero_pro(chosen, refs, out, trials=trials, benchmark=benchmark, **run)
    else:
        request = EvalRequest(
            chosen,
            tuple(refs),
            stored,
            heldout,
            protocol=protocol,
            trials=trials,
            prompt=_plus_prompt(plus_prompt),
            **shared,  # type: ignore[arg-type]
        )
        _evaluate(request, out, execution, keep_work)


def _evaluate(request: Any, out: Path, execution: Any, keep_work: bool) -> None:
    """One evaluation (not a benchmark's table): the rollouts, the report, the chart."""
    from libero_bench.evaluation.policy_eval import eval_markdown, evaluate_policy
    from libero_bench.rollouts.policy_kinds import policy_source
    from libero_bench.rollouts.protocol import get_protocol

    chosen = get_protocol(request.protocol)
    source = policy_source(
        request.policy, request.image_size, request.replan_steps, chosen.request
    )  # before any output
    with rollout_progress() as (done, total):
        summary = evaluate_policy(
            request,
            out,
            execution=execution,
            on_result=done,
            on_total=total,
            source=source,
            keep_work=keep_work,
        )
    say(eval_markdown(summary))
    say(
        f"wrote {out / 'report.md'}, {out / 'report.json'}, {out / 'success.png'}, the rollouts in {out / 'rollouts'}"
    )


def _plus_prompt(choice: str) -> str:
    from libero_data.errors import InputError

    prompts = {"clean": "instruction", "raw": "file-name"}
    if choice not in prompts:
        raise InputError(f"--plus-prompt is clean or raw, not {choice!r}", field="plus_prompt")
    return prompts[choice]


def _libero_plus(
    policy: str, refs: list[str], out: Path, *, classification: Path | None, **options: object
) -> None:
    from libero_bench.evaluation.libero_plus import evaluate_libero_plus, plus_markdown
    from libero_data.tasks.plus_sample import read_difficulty

    difficulty = read_difficulty(classification)  # their checkout's own where none is named
    with rollout_progress() as (done, total):
        table = evaluate_libero_plus(
            policy,
            refs,
            out,
            difficulty=difficulty,
            on_result=done,
            on_total=total,
            **options,  # type: ignore[arg-type]
        )
    say(plus_markdown(table))
    say(
        f"wrote {out / 'libero_plus.md'}, {out / 'libero_plus.json'}, {out / 'libero_plus.png'} and a folder per suite"
    )


def _libero_pro(policy: str, refs: list[str], out: Path, *, benchmark: str, **options: object) -> None:
    from libero_bench.evaluation.libero_pro import BENCHMARK, evaluate_libero_pro, pro_markdown
    from libero_data.errors import InputError

    if benchmark != BENCHMARK:
        raise InputError(
            f"unknown benchmark {benchmark!r}; choose {BENCHMARK} or libero-plus", field="benchmark"
        )
    with rollout_progress() as (done, total):
        table = evaluate_libero_pro(policy, refs, out, on_result=done, on_total=total, **options)  # type: ignore[arg-type]
    say(pro_markdown(table))
    say(
        f"wrote {out / 'libero_pro.md'}, {out / 'libero_pro.json'}, {out / 'libero_pro.png'} and a folder per suite"
    )


@user_errors
def serve_cmd(
    policy: Annotated[
        Path,
        typer.Argument(
            help="A libero-bench run folder (its final checkpoint) or a LeRobot pretrained_model/ folder."
        ),
    ],
    port: Annotated[int, typer.Option("--port", "-p", help="Port to listen on.", min=1, max=65535)] = 8000,
    host: Annotated[
        str, typer.Option("--host", help="Address to listen on (0.0.0.0: every interface of this machine).")
    ] = "127.0.0.1",
    device: ServeDevice = None,
    view_task: Annotated[
        int | None,
        typer.Option(
            "--view-task",
            help="A run: the task whose evaluation view serves (PackNet's masks; default: the last it learned).",
            min=0,
        ),
    ] = None,
    max_message_mb: Annotated[
        float,
        typer.Option(
            "--max-message-mb",
            help="Largest request read (MiB); a larger one closes its connection unread. The default fits "
            "two 512 px images with room.",
            min=0.01,
        ),
    ] = 8.0,
) -> None:
    """Serve a policy over openpi's websocket protocol (msgpack, nothing unpickled), so that a GPU machine
    serves while others roll out (libero-bench eval --server ws://HOST:PORT).

    Requests that arrive together, from any number of connections, go through one batched forward pass.
    openpi's client (and eval --server --protocol standard) gets the policy's action chunk per request;
    a policy that predicts one action per step (every libero-bench run) answers it only where the
    client asks at every step (eval --replan-steps 1), and a run also needs the arm's joints in each
    request (the metadata's inputs list what it reads). libero-bench's default protocol opens a
    connection per episode and gets the one action the policy takes now. A request that
    cannot be served gets one sentence back; the log on stderr names each connection, refusal and failure.
    The policy makes one forward pass before the server listens. Stop with Ctrl-C.
    """
    quiet_environment()
    import asyncio
    import logging
    import sys

    from libero_bench.rollouts.actors import default_device
    from libero_bench.rollouts.server import log as server_log
    from libero_bench.rollouts.server import served_policy

    # The operator's view: each connection, refusal and failure (with its id), on stderr.
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(message)s"))
    server_log.addHandler(handler)
    server_log.setLevel(logging.INFO)
    server_log.propagate = False

    chosen = device or default_device()
    server = served_policy(
        str(policy), chosen, view_task, max_message_bytes=int(max_message_mb * 1024 * 1024)
    )
    metadata = server.metadata
    ready = lambda bound: say(  # noqa: E731
        f"serving the {metadata['policy_type']} policy on {chosen} at ws://{host}:{bound} "
        f"(camera images of {metadata['image_size']} px, {metadata['action_horizon']} action(s) per request); "
        "Ctrl-C stops"
    )
    try:
        asyncio.run(server.serve(host, port, ready=ready))
    except OSError as exc:
        from libero_data.errors import InputError

        raise InputError(f"cannot listen on {host}:{port}: {exc.strerror or exc}", field="port") from None
    finally:
        server.actor.close()
