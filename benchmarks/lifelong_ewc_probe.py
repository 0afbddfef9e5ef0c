"""Where EWC's forgetting lives (issue 59): in every EWC sweep run (``benchmarks/lifelong.sh sweep``)
task 0 fell from 0.85 to 0.00 after task 1, whatever the penalty weight. This probe reads each
run's checkpoints after task 0 and after task 1 and measures, on task 0's training windows (the
behaviour-cloning loss in evaluation mode, no simulation):

- the loss of the weights after task 0, after task 1, after task 1 with task 0's batch-norm
  statistics put back (EWC's penalty covers weights, not those statistics), and after task 1 with
  the weights of the lower half by Fisher value put back to their anchor (the half the diagonal
  Fisher calls unimportant; the upper half keeps its moves);
- how far each half of the weights moved (L2 norm of the change), and the share of weights whose
  penalty stiffness ``lambda * F`` exceeds 1.

    python -m benchmarks.lifelong_ewc_probe WORK [--out benchmarks/results/lifelong]

WORK is the work folder of ``benchmarks/lifelong.sh`` (its runs keep their checkpoints there).
Writes ``ewc_probe.json`` and ``ewc_probe.md`` in ``--out``.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

RESULTS = Path(__file__).resolve().parent / "results" / "lifelong"


def _task0_loader(run: Path, config: dict[str, Any]) -> Any:
    import torch

    from libero_bench.train.fitting import task_loader
    from libero_bench.train.plan import RunRequest, plan_run
    from libero_bench.train.presets import TrainPreset

    data = Path(config["data"])  # relative to the run folder
    request = RunRequest(
        data=data if data.is_absolute() else (run / data).resolve(),
        algo=config["algo"],
        policy=config["policy"],
        preset=TrainPreset.from_dict(config["preset"]),
        tasks=tuple(str(t["name"]) for t in config["tasks"]),
        seed=config["seed"],
    )
    return task_loader(plan_run(request), [0], seed=0, device=torch.device("cpu"))


def _loss(config: dict[str, Any], weights: dict[str, Any], loader: Any) -> float:
    from libero_bench.policies import build_policy, config_from_dict
    from libero_bench.train.fitting import loss_epoch

    policy = build_policy(config_from_dict(config["policy_config"]))
    policy.load_state_dict(weights)
    return loss_epoch(policy, loader, lambda _: None)["total"]


def probe(run: Path, loader: Any = None) -> dict[str, Any]:
    """The numbers above for one EWC run stopped after (at least) two tasks."""
    import torch

    from libero_bench.runs.saved_policy import read_checkpoint

    config = json.loads((run / "config.json").read_text())
    weight = float(config["algo_config"]["penalty_weight"])
    after0 = read_checkpoint(run / "checkpoints" / "task_000.safetensors")
    after1 = read_checkpoint(run / "checkpoints" / "task_001.safetensors")["policy"]
    fisher, anchor = after0["algo"]["fisher"], after0["algo"]["anchor"]  # the penalty while learning task 1
    names = sorted(fisher)
    f = torch.cat([fisher[n].flatten() for n in names])
    moved = torch.cat([(after1[n] - anchor[n]).flatten() for n in names])
    low = f <= f.median()
    reset, start = {}, 0
    for n in names:  # the low-Fisher half back at the anchor, the rest as after task 1
        size = fisher[n].numel()
        back = low[start : start + size].view_as(anchor[n])
        reset[n] = torch.where(back, anchor[n], after1[n])
        start += size
    statistics = {k: v for k, v in after0["policy"].items() if "running_" in k or "num_batches" in k}
    loader = loader if loader is not None else _task0_loader(run, config)
    losses = {
        "after_task_0": _loss(config, after0["policy"], loader),
        "after_task_1": _loss(config, after1, loader),
        "after_task_1_with_task_0_norm_statistics": _loss(config, {**after1, **statistics}, loader),
        "after_task_1_low_fisher_half_reset": _loss(config, {**after1, **reset}, loader),
    }
    return {
        "run": run.name,
        "penalty_weight": weight,
        "weights": int(f.numel()),
        "share_stiffness_above_1": float((weight * f > 1).float().mean()),
        "moved_high_fisher_half": float(moved[~low].norm()),
        "moved_low_fisher_half": float(moved[low].norm()),
        "task0_loss": losses,
    }


def markdown(rows: list[dict[str, Any]]) -> str:
    lines = [
        "| run | λ | share of weights with λF > 1 | moved: high-F half | moved: low-F half | task-0 loss after task 0 | after task 1 | with task 0's norm statistics | with the low-F half reset |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        loss = r["task0_loss"]
        lines.append(
            f"| {r['run']} | {r['penalty_weight']:g} | {r['share_stiffness_above_1']:.2f} | "
            f"{r['moved_high_fisher_half']:.2f} | {r['moved_low_fisher_half']:.2f} | {loss['after_task_0']:.1f} | "
            f"{loss['after_task_1']:.1f} | {loss['after_task_1_with_task_0_norm_statistics']:.1f} | "
            f"{loss['after_task_1_low_fisher_half_reset']:.1f} |"
        )
    return (
        "\n".join(lines)
        + "\n\nTask-0 behaviour-cloning loss (negative log-likelihood, evaluation mode, mean over task 0's "
        "training windows; lower is better). Moved: L2 norm of the weights' change from the anchor (after "
        "task 0) to the checkpoint after task 1, over the half of the weights above and below the median "
        "Fisher value. Made by `python -m benchmarks.lifelong_ewc_probe WORK` from the sweep runs' checkpoints.\n"
    )


def main() -> None:
    from libero_data.runtime.files import write_json, write_text
    from libero_data.runtime.versions import versions

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("work", type=Path, help="the work folder of benchmarks/lifelong.sh")
    parser.add_argument("--out", type=Path, default=RESULTS, help="where ewc_probe.json and .md go")
    args = parser.parse_args()
    runs = sorted(
        p
        for p in (args.work / "runs").glob("sweep-ewc-*")
        if (p / "checkpoints" / "task_001.safetensors").is_file()
    )
    if not runs:
        raise SystemExit(f"{args.work / 'runs'} holds no EWC sweep run with a checkpoint after task 1")
    loader = _task0_loader(runs[0], json.loads((runs[0] / "config.json").read_text()))
    rows = sorted((probe(run, loader) for run in runs), key=lambda r: r["penalty_weight"])
    write_json(args.out / "ewc_probe.json", {"versions": versions(python=True), "runs": rows})
    write_text(args.out / "ewc_probe.md", markdown(rows))
    print(markdown(rows))


if __name__ == "__main__":
    main()
