"""``libero-bench run``: train a lifelong learner task by task, evaluate it in simulation."""

from __future__ import annotations

import logging
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from libero_bench.cli.options import EnvWorkers
from libero_data.cli.common import (
    ExecutorKind,
    RayAddress,
    console,
    quiet_environment,
    say,
    split_list,
    user_errors,
)

if TYPE_CHECKING:
    from rich.console import Console


EvalRenderQuality = Annotated[
    str | None,
    typer.Option(
        "--render-quality",
        help="Images of the evaluation rollouts: 'full' (LIBERO's renderer) or 'fast' (simplified meshes); "
        "default: the preset's (paper, smoke: full; quick: fast). Same as --set eval_render_quality=...",
    ),
]

InitCheckpoint = Annotated[
    Path | None,
    typer.Option(
        "--init-checkpoint", help="Start from these weights (a run's task_NNN.safetensors, or bare)."
    ),
]
Overrides = Annotated[
    list[str] | None,
    typer.Option("--set", help="Override a preset field, e.g. --set eval_rollouts=5 (repeatable)."),
]
AlgoSettings = Annotated[
    list[str] | None,
    typer.Option(
        "--algo-set",
        help="Set a field of the algorithm's config, e.g. --algo-set penalty_weight=5000 (EWC's lambda) or "
        "--algo-set prune_fraction=0.5 (PackNet); repeatable. Recorded in the run's config.",
    ),
]
Mix = Annotated[
    list[Path] | None,
    typer.Option(
        "--mix",
        help="Another dataset whose episodes of the run's tasks and of their variants "
        "(<task>__<kind>..., as `libero-data generate --variants-of` makes) are trained on too; "
        "repeatable. Held-out evaluation starts skip where they began.",
    ),
]
MixWeight = Annotated[
    float,
    typer.Option(
        "--mix-weight",
        help="Share of each epoch's windows drawn from the --mix episodes; an epoch keeps the "
        "length of the run's own data, so the gradient steps do not change.",
    ),
]

StopAfter = Annotated[
    int | None,
    typer.Option(
        "--stop-after",
        help="Stop once the first N tasks are learned and the earlier ones evaluated again, e.g. to sweep "
        "a setting on a sequence's first tasks; the same command without it continues the run from there "
        "with the numbers it would have had (not for mtl, which learns every task at once).",
        min=1,
    ),
]


@user_errors
def run_cmd(
    data: Annotated[
        Path, typer.Option("--data", help="A libero-data dataset (made by generate, import or rerender).")
    ],
    out: Annotated[Path, typer.Option("--out", "-o", help="Run folder (created; an existing run resumes).")],
    algo: Annotated[str, typer.Option("--algo", help="seql, er, ewc, packnet or mtl.")] = "er",
    policy: Annotated[str, typer.Option("--policy", help="resnet_rnn, resnet_t or vit_t.")] = "resnet_t",
    preset: Annotated[
        str,
        typer.Option(
            "--preset",
            help="paper (LIBERO's protocol), quick (learning on CPU, ~1 h per task) or smoke (a quick check).",
        ),
    ] = "smoke",
    tasks: Annotated[
        str | None,
        typer.Option(
            "--tasks", help="Comma-separated task names or suite indices, in training order; default: all."
        ),
    ] = None,
    order: Annotated[
        int | None,
        typer.Option("--order", help="Upstream task order (see `libero-bench orders`); needs 10 tasks."),
    ] = None,
    seed: Annotated[int | None, typer.Option("--seed", help="Run seed; default: the preset's.")] = None,
    device: Annotated[
        str,
        typer.Option("--device", help="cpu, cuda or cuda:N: training, and the policy in evaluation rounds."),
    ] = "cpu",
    workers: EnvWorkers = 1,
    loader_workers: Annotated[
        int, typer.Option("--loader-workers", help="DataLoader worker processes.", min=0)
    ] = 0,
    executor: ExecutorKind = "local",
    ray_address: RayAddress = None,
    threads: Annotated[
        int, typer.Option("--threads", help="Torch threads of the training process.", min=1)
    ] = 1,
    init_checkpoint: InitCheckpoint = None,
    overrides: Overrides = None,
    algo_settings: AlgoSettings = None,
    render_quality: EvalRenderQuality = None,
    mix: Mix = None,
    mix_weight: MixWeight = 0.5,
    stop_after: StopAfter = None,
) -> None:
    """Train a lifelong learner task by task, evaluate it in simulation and store every rollout."""
    quiet_environment(threads)
    import torch

    from libero_bench.train.plan import RunOptions, RunRequest, check_device, check_out_folder, plan_run
    from libero_bench.train.presets import get_preset
    from libero_bench.train.trainer import Trainer
    from libero_data.runtime.jobs import JobPlacement
    from libero_data.runtime.memory import limit_malloc_arenas

    limit_malloc_arenas()  # rollouts run in this process with --workers 1
    runner = JobPlacement(executor, workers, ray_address)  # checked before any work
    quality = [f"eval_render_quality={render_quality}"] if render_quality is not None else []
    chosen = get_preset(preset).with_overrides([*(overrides or []), *quality])
    check_device(device)
    check_out_folder(out)
    torch.set_num_threads(threads)
    request = RunRequest(
        data=data,
        algo=algo,
        policy=policy,
        preset=chosen,
        tasks=tuple(split_list(tasks)) or None,
        order=order,
        seed=seed,
        init_checkpoint=init_checkpoint,
        mix=tuple(mix or ()),
        algo_settings=tuple(algo_settings or ()),
        mix_weight=mix_weight,
    )
    with console().status("reading the dataset and embedding the tasks"):
        plan = plan_run(request)
    options = RunOptions(
        device=device, executor=runner, loader_workers=loader_workers, threads=threads, stop_after=stop_after
    )
    trainer = Trainer(plan, out, options)
    started = time.perf_counter()
    trainer.prepare()
    with _RunLogging(trainer.folder.log), _Bars(console()) as observer:
        trainer.observer = observer
        done = trainer.run()
    minutes = (time.perf_counter() - started) / 60
    stopped = done.finished_tasks < len(plan.tasks)
    say(
        (f"stopped after {done.finished_tasks} of " if stopped else "done: ")
        + f"{len(plan.tasks)} tasks, {len(done.rollouts)} rollouts in {out} ({minutes:.1f} min)"
        + ("; the same command without --stop-after continues it" if stopped else "")
    )
    from libero_bench.analysis.report import summarize, table_rows
    from libero_bench.cli.results import print_table
    from libero_bench.runs.summary import load_run

    print_table(table_rows(summarize([load_run(out)])))
    say(f"report with plots: libero-bench report {out}")


class _RunLogging:
    """The library's INFO log into ``run.log``; only warnings reach the terminal."""

    NAMES = ("libero_bench", "libero_data")

    def __init__(self, path: Path) -> None:
        self.file = logging.FileHandler(path)
        self.file.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(name)s: %(message)s"))
        self.console = logging.StreamHandler(sys.stderr)
        self.console.setLevel(logging.WARNING)
        self.saved: dict[str, tuple[int, bool]] = {}

    def __enter__(self) -> _RunLogging:
        for name in self.NAMES:
            logger = logging.getLogger(name)
            self.saved[name] = (logger.level, logger.propagate)
            logger.setLevel(logging.INFO)
            logger.propagate = False
            logger.addHandler(self.file)
            logger.addHandler(self.console)
        return self

    def __exit__(self, *exc: object) -> None:
        for name, (level, propagate) in self.saved.items():
            logger = logging.getLogger(name)
            logger.removeHandler(self.file)
            logger.removeHandler(self.console)
            logger.setLevel(level)
            logger.propagate = propagate
        self.file.close()


class _Bars:
    """Rich progress bars for training and evaluation, fed by the trainer's callbacks."""

    def __init__(self, out: Console) -> None:
        self.out = out

    def __enter__(self) -> Any:
        from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

        from libero_bench.train.trainer import RunObserver

        progress = Progress(
            TextColumn("{task.description}"),
            BarColumn(),
            MofNCompleteColumn(),
            TextColumn("{task.fields[info]}"),
            TimeElapsedColumn(),
            console=self.out,
            transient=False,
        )
        self.progress = progress
        progress.start()
        train = progress.add_task("train", total=1, visible=False, info="")
        evaluate = progress.add_task("evaluate", total=1, visible=False, info="")

        class Bars(RunObserver):
            wins = 0
            done = 0

            def phase(self, text: str) -> None:
                progress.console.print(text, markup=False)

            def train_start(self, label: str, batches: int) -> None:
                progress.reset(train, total=batches, description=f"  {label}", visible=True, info="")

            def train_step(self, loss: float) -> None:
                progress.update(train, advance=1, info=f"loss {loss:.3f}")

            def eval_start(self, label: str, rollouts: int) -> None:
                self.wins = self.done = 0
                progress.reset(
                    evaluate, total=rollouts, description=f"  evaluate {label}", visible=True, info=""
                )

            def rollout_done(self, result: Any) -> None:
                self.wins += bool(result.success)
                self.done += 1
                progress.update(evaluate, advance=1, info=f"{self.wins}/{self.done} succeeded")

            def eval_end(self, label: str, success: float) -> None:
                progress.console.print(f"    {label}: success {success:.2f}", markup=False)

        return Bars()

    def __exit__(self, *exc: object) -> None:
        self.progress.stop()
