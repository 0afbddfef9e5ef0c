"""``libero-bench``: lifelong-learning benchmark on libero-data datasets.

Bad input (a missing folder, an unknown task, a bad option) prints one sentence and exits
with 2. Heavy modules (torch, lerobot, the simulator) are imported inside the commands.
"""

from __future__ import annotations

import functools
import logging
import os
import sys
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, TypeVar

import typer

# The same console and one-sentence errors as libero-data's command line.
from libero_data.cli import _console, fail

if TYPE_CHECKING:
    from rich.console import Console

    from libero_bench.presets import TrainPreset

app = typer.Typer(
    name="libero-bench",
    help="Lifelong robot learning on LIBERO datasets made by libero-data.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
F = TypeVar("F", bound=Callable[..., Any])


def user_errors[F: Callable[..., Any]](fn: F) -> F:
    """Turn expected failures into one sentence on stderr and exit code 2."""

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return fn(*args, **kwargs)
        except KeyError as exc:  # registries and task lookups
            raise fail(str(exc.args[0]) if exc.args else str(exc)) from None
        except (FileNotFoundError, NotADirectoryError, ValueError) as exc:
            raise fail(str(exc)) from None
        except KeyboardInterrupt:
            raise fail("interrupted", code=130) from None

    return wrapper  # type: ignore[return-value]


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


# -- run -----------------------------------------------------------------------------------------------
def _split(text: str | None) -> list[str]:
    return [part.strip() for part in (text or "").split(",") if part.strip()]


def apply_overrides(preset: TrainPreset, assignments: list[str]) -> TrainPreset:
    """``field=value`` overrides of a preset (values parsed as JSON, else as text)."""
    import dataclasses
    import json

    fields = {f.name for f in dataclasses.fields(preset)}
    changes: dict[str, Any] = {}
    for item in assignments:
        name, sep, raw = item.partition("=")
        name = name.strip()
        if not sep or not name:
            raise ValueError(f"--set takes field=value, got {item!r}")
        if name not in fields or name == "name":
            raise ValueError(
                f"--set: the preset has no field {name!r}; fields: {', '.join(sorted(fields - {'name'}))}"
            )
        try:
            value = json.loads(raw)
        except json.JSONDecodeError:
            value = raw
        changes[name] = tuple(value) if isinstance(value, list) else value
    return preset.replace(**changes) if changes else preset


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


@app.command("run")
@user_errors
def run_cmd(
    data: Annotated[Path, typer.Option("--data", help="A dataset made by `libero-data generate`.")],
    out: Annotated[Path, typer.Option("--out", "-o", help="Run folder (created; an existing run resumes).")],
    algo: Annotated[str, typer.Option("--algo", help="seql, er, ewc, packnet or mtl.")] = "er",
    policy: Annotated[str, typer.Option("--policy", help="resnet_rnn, resnet_t or vit_t.")] = "resnet_t",
    preset: Annotated[str, typer.Option("--preset", help="paper or smoke.")] = "smoke",
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
        str, typer.Option("--device", help="cpu or cuda (training; rollouts run on CPU workers).")
    ] = "cpu",
    workers: Annotated[
        int, typer.Option("--workers", help="Rollout worker processes (0: in this process).", min=0)
    ] = 1,
    loader_workers: Annotated[
        int, typer.Option("--loader-workers", help="DataLoader worker processes.", min=0)
    ] = 0,
    executor: Annotated[
        str,
        typer.Option(
            "--executor",
            help="Where rollouts run: 'local' (--workers processes) or 'ray' (--workers Ray actors; same results).",
        ),
    ] = "local",
    ray_address: Annotated[
        str | None,
        typer.Option(
            "--ray-address",
            help="Ray cluster to join (e.g. auto or ray://head:10001); default: start Ray here.",
        ),
    ] = None,
    threads: Annotated[
        int, typer.Option("--threads", help="Torch threads of the training process.", min=1)
    ] = 1,
    init_checkpoint: Annotated[
        Path | None,
        typer.Option(
            "--init-checkpoint", help="Start from these policy weights (a run's checkpoints/task_NNN.pt)."
        ),
    ] = None,
    overrides: Annotated[
        list[str] | None,
        typer.Option("--set", help="Override a preset field, e.g. --set eval_rollouts=5 (repeatable)."),
    ] = None,
) -> None:
    """Train a lifelong learner task by task, evaluate it in simulation and store every rollout."""
    import time

    os.environ.setdefault("OMP_NUM_THREADS", str(threads))
    os.environ.setdefault("SVT_LOG", "1")  # the AV1 encoder's banner, once per rollout video
    os.environ.setdefault("HF_HUB_DISABLE_PROGRESS_BARS", "1")  # the sentence encoder's loading bar
    from libero_bench.presets import get_preset
    from libero_data.pipeline.memory import limit_malloc_arenas

    limit_malloc_arenas()  # rollouts run in this process with --workers 0
    chosen = apply_overrides(get_preset(preset), overrides or [])
    import torch

    from libero_bench.train import RunOptions, RunRequest, Trainer, check_device, check_out_folder, plan_run

    check_device(device)
    check_out_folder(out)
    torch.set_num_threads(threads)
    request = RunRequest(
        data=data,
        algo=algo,
        policy=policy,
        preset=chosen,
        tasks=tuple(_split(tasks)) or None,
        order=order,
        seed=seed,
        init_checkpoint=init_checkpoint,
    )
    console = _console()
    with console.status("reading the dataset and embedding the tasks"):
        plan = plan_run(request)
    from libero_data.pipeline.ray_runtime import executor_problem

    problem = executor_problem(executor, ray_address)
    if problem is not None:
        raise typer.BadParameter(problem[1], param_hint=problem[0])
    options = RunOptions(
        device=device,
        workers=workers,
        loader_workers=loader_workers,
        executor=executor,
        ray_address=ray_address,
    )
    trainer = Trainer(plan, out, options)
    started = time.perf_counter()
    trainer.prepare()
    with _RunLogging(trainer.folder.log), _progress(console) as observer:
        trainer.observer = observer
        trainer_results = trainer.run()
    minutes = (time.perf_counter() - started) / 60
    rollouts = len(trainer_results.rollouts)
    console.print(
        f"done: {len(plan.tasks)} tasks, {rollouts} rollouts in {out} ({minutes:.1f} min)", markup=False
    )
    from libero_bench.report import load_run, summarize, table_rows

    _print_table(console, table_rows(summarize([load_run(out)])))
    console.print(f"report with plots: libero-bench report {out}", markup=False)


class _progress:
    """Rich progress bars for training and evaluation, fed by the trainer's callbacks."""

    def __init__(self, console: Console) -> None:
        self.console = console

    def __enter__(self) -> Any:
        from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

        from libero_bench.train import RunObserver

        progress = Progress(
            TextColumn("{task.description}"),
            BarColumn(),
            MofNCompleteColumn(),
            TextColumn("{task.fields[info]}"),
            TimeElapsedColumn(),
            console=self.console,
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


def _print_table(console: Console, rows: list[list[str]]) -> None:
    from rich.table import Table

    from libero_bench.report import TABLE_HEADER

    table = Table(title_justify="left")
    for column in TABLE_HEADER:
        table.add_column(column)
    for row in rows:
        table.add_row(*row)
    console.print(table)


# -- report ----------------------------------------------------------------------------------------------
@app.command("report")
@user_errors
def report_cmd(
    runs: Annotated[list[Path], typer.Argument(help="Run folders (seeds of one method are averaged).")],
    out: Annotated[
        Path | None, typer.Option("--out", "-o", help="Report folder; default: FIRST_RUN/report.")
    ] = None,
) -> None:
    """FWT / NBT / AUC (mean ± standard error over runs), success matrix and curves (PNG), JSON."""
    from libero_bench.report import table_rows, write_report

    target = out or (runs[0] / "report")
    summary = write_report(runs, target)
    console = _console()
    _print_table(console, table_rows(summary))
    for path in summary["files"]:
        console.print(f"wrote {path}", markup=False)


# -- replay ---------------------------------------------------------------------------------------------
@app.command("replay")
@user_errors
def replay_cmd(
    run: Annotated[Path, typer.Argument(help="A run folder.")],
    task: Annotated[str, typer.Option("--task", help="Task name or position in the run.")],
    rollout: Annotated[
        int | None,
        typer.Option(
            "--rollout", help="Which of the task's rollouts (in run order); omit to list them.", min=0
        ),
    ] = None,
    rrd: Annotated[Path | None, typer.Option("--rrd", help="Save the Rerun recording here.")] = None,
) -> None:
    """Show a stored evaluation rollout: list a task's rollouts, or save one's Rerun recording."""
    import shutil

    from libero_bench.run_files import RunFolder, find_task

    folder = RunFolder(run)
    config = folder.read_config()
    results = folder.read_results()
    chosen = find_task(config, task)
    mine = sorted(
        (r for r in results.rollouts if r["task_position"] == chosen["position"]), key=lambda r: r["key"]
    )
    console = _console()
    if not mine:
        raise ValueError(f"task {chosen['name']} has no rollouts in {run} yet")
    if rollout is None:
        for i, r in enumerate(mine):
            when = {
                "learning": f"while learning it, epoch {r['epoch']}",
                "pruned": "after pruning, before fine-tuning",
                "after": f"checkpoint kept after task {r['learned_after']}",
            }.get(r["phase"], r["phase"])
            outcome = "success" if r["success"] else "failure"
            console.print(f"{i:4d}  {r['key']}  {when}: {outcome} ({r['steps']} steps)", markup=False)
        return
    if rollout >= len(mine):
        raise ValueError(f"task {chosen['name']} has rollouts 0..{len(mine) - 1}, not {rollout}")
    record = mine[rollout]
    source = folder.rrd_file(record["key"])
    if not source.is_file():
        raise ValueError(f"the recording {source} is missing")
    outcome = "success" if record["success"] else "failure"
    console.print(
        f"{record['key']}: {chosen['language']} — {outcome} after {record['steps']} steps", markup=False
    )
    if rrd is None:
        console.print(f"recording: {source}\nopen it with: rerun {source}", markup=False)
        return
    rrd.parent.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(source, rrd)
    console.print(f"wrote {rrd}", markup=False)


# -- saliency ---------------------------------------------------------------------------------------------
@app.command("saliency")
@user_errors
def saliency_cmd(
    run: Annotated[Path, typer.Argument(help="A run folder.")],
    task: Annotated[str, typer.Option("--task", help="Task name or position in the run.")],
    frames: Annotated[
        str | None,
        typer.Option("--frames", help="Comma-separated frame indices; default: 4 spread over the episode."),
    ] = None,
    source: Annotated[
        str, typer.Option("--source", help="demo (the task's first demonstration) or rollout.")
    ] = "demo",
    rollout: Annotated[
        int, typer.Option("--rollout", help="With --source rollout: which of the task's rollouts.", min=0)
    ] = 0,
    after: Annotated[
        str | None,
        typer.Option("--after", help="Use the checkpoint kept after this task; default: after --task."),
    ] = None,
    out: Annotated[
        Path | None, typer.Option("--out", "-o", help="Output folder; default: RUN/saliency/<task>.")
    ] = None,
) -> None:
    """Perturbation saliency of the agentview encoder: PNG overlays and a Rerun recording."""
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    from libero_bench.saliency_run import saliency_for_run

    written = saliency_for_run(
        run,
        task=task,
        frames=_frame_list(frames),
        source=source,
        rollout=rollout,
        after=after,
        out=out,
    )
    console = _console()
    for path in written:
        console.print(f"wrote {path}", markup=False)


def _frame_list(text: str | None) -> list[int] | None:
    if not text:
        return None
    try:
        return [int(f) for f in _split(text)]
    except ValueError:
        raise ValueError(f"--frames takes comma-separated frame numbers, got {text!r}") from None


def main() -> None:
    from libero_data.numerics import pin

    pin()  # before anything loads NumPy: see libero_data.numerics
    app()


if __name__ == "__main__":
    main()
