"""The verdicts of benchmarks/lifelong_findings.py on the paper's findings: a finding is reproduced
only when every comparison of its family goes its way after Holm's adjustment, contradicted when
one goes the other way, and otherwise not resolved; the encoder-order finding is reproduced when
the order is significant both ways."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from benchmarks.lifelong_findings import ALGOS, ARCHITECTURES, FINDINGS, findings, method_runs


def _compared(values: dict[str, dict[str, float]], p: float) -> dict[str, dict[str, Any]]:
    """Comparisons as compare_runs gives them, for every pair a finding names, with the metric
    values given per algorithm and one p-value for every difference."""
    out: dict[str, dict[str, Any]] = {}
    for finding in FINDINGS:
        for claim in finding.claims:
            a, b = claim.subject, claim.other
            metrics = {
                m: {
                    "a": values[a][m],
                    "b": values[b][m],
                    "difference": values[a][m] - values[b][m],
                    "low": values[a][m] - values[b][m] - 0.1,
                    "high": values[a][m] - values[b][m] + 0.1,
                    "p_value": p,
                }
                for m in ("fwt", "nbt", "auc")
            }
            block = {"difference": {"paired": True, "metrics": metrics}}
            out[f"{a}-vs-{b}"] = {"seeds": [0, 1, 2], "stored": block, "heldout": block}
    return out


#: The paper's LIBERO-Object row: each finding holds in it.
PAPER_LIKE = {
    "seql": {"fwt": 0.78, "nbt": 0.76, "auc": 0.26},
    "er": {"fwt": 0.67, "nbt": 0.43, "auc": 0.44},
    "ewc": {"fwt": 0.56, "nbt": 0.69, "auc": 0.16},
    "packnet": {"fwt": 0.60, "nbt": 0.17, "auc": 0.60},
    # the architectures as the abstract has them: both transformers ahead of ResNet-RNN, ViT-T
    # ahead of ResNet-T with ER and behind it with PackNet
    "er-rnn": {"fwt": 0.40, "nbt": 0.50, "auc": 0.25},
    "er-vit": {"fwt": 0.70, "nbt": 0.40, "auc": 0.50},
    "packnet-rnn": {"fwt": 0.40, "nbt": 0.20, "auc": 0.35},
    "packnet-vit": {"fwt": 0.55, "nbt": 0.15, "auc": 0.55},
}


def _verdicts(values: dict[str, dict[str, float]], p: float) -> dict[str, str]:
    return {f["key"]: f["heldout"]["verdict"] for f in findings(_compared(values, p))}


def test_the_papers_numbers_reproduce_its_findings_when_significant() -> None:
    assert set(PAPER_LIKE) | {"mtl"} == set(ALGOS) | {m for pair in ARCHITECTURES.values() for m in pair}
    verdicts = _verdicts(PAPER_LIKE, p=0.001)  # 6 comparisons × 0.001 stays under 0.05
    assert verdicts == {
        "seql_best_fwt": "reproduced",
        "packnet_forgets_least": "reproduced",
        "ewc_worse_than_seql": "reproduced",
        "er_robust_across_suites": "not tested",
        "transformers_ahead_of_rnn": "reproduced",
        "encoder_order_depends_on_algorithm": "reproduced",
        "pretraining_can_hurt": "not tested",
    }


def test_holm_adjustment_can_leave_a_finding_unresolved() -> None:
    # p = 0.03 each: alone significant, but not two (or three, or six) of them after Holm's adjustment
    verdicts = _verdicts(PAPER_LIKE, p=0.03)
    assert verdicts["seql_best_fwt"] == "not resolved at this budget"
    assert verdicts["packnet_forgets_least"] == "not resolved at this budget"
    assert verdicts["ewc_worse_than_seql"] == "not resolved at this budget"


def test_a_significant_difference_the_other_way_contradicts() -> None:
    values = {algo: dict(row) for algo, row in PAPER_LIKE.items()}
    values["ewc"]["fwt"] = 0.95  # EWC transfers forward better than SeqL
    verdicts = _verdicts(values, p=0.001)
    assert verdicts["seql_best_fwt"] == "contradicted"
    assert verdicts["ewc_worse_than_seql"] == "contradicted"
    assert verdicts["packnet_forgets_least"] == "reproduced"


def test_one_encoder_order_for_every_algorithm_contradicts_the_order_finding() -> None:
    values = {m: dict(row) for m, row in PAPER_LIKE.items()}
    values["packnet-vit"]["auc"] = 0.70  # ViT-T ahead with both algorithms
    assert _verdicts(values, p=0.001)["encoder_order_depends_on_algorithm"] == "contradicted"
    values["packnet-rnn"]["auc"] = 0.80  # and ResNet-RNN ahead of both transformers with PackNet
    assert _verdicts(values, p=0.001)["transformers_ahead_of_rnn"] == "contradicted"
    assert _verdicts(values, p=0.2)["encoder_order_depends_on_algorithm"] == "not resolved at this budget"


def test_a_finding_whose_runs_are_missing_is_not_tested() -> None:
    compared = {k: v for k, v in _compared(PAPER_LIKE, 0.001).items() if "rnn" not in k}
    verdicts = {f["key"]: f["heldout"]["verdict"] for f in findings(compared)}
    assert verdicts["transformers_ahead_of_rnn"] == "not tested"
    assert verdicts["encoder_order_depends_on_algorithm"] == "reproduced"  # it needs no ResNet-RNN run


def test_runs_are_grouped_into_methods_by_name_in_seed_order(tmp_path: Path) -> None:
    for name in ("er-s1", "er-s0", "er-vit-s0", "packnet-rnn-s2", "sweep-ewc-500", "mtl-s0", "ewc-s3"):
        (tmp_path / name).mkdir()
        if name != "ewc-s3":  # unfinished: no results.json
            (tmp_path / name / "results.json").write_text("{}")
    assert {m: [p.name for p in runs] for m, runs in method_runs(tmp_path).items()} == {
        "er": ["er-s0", "er-s1"],
        "er-vit": ["er-vit-s0"],
        "mtl": ["mtl-s0"],
        "packnet-rnn": ["packnet-rnn-s2"],
    }


def test_the_sweep_keeps_the_highest_auc_then_the_least_forgetting() -> None:
    from benchmarks.lifelong_report import pick

    def row(value: float, auc: float, nbt: float, done: int = 2) -> dict[str, Any]:
        return {
            "run": f"r{value}",
            "value": value,
            "tasks_done": done,
            "auc": {"mean": auc},
            "nbt": {"mean": nbt},
        }

    assert pick([row(500, 0.4, 0.3), row(5000, 0.6, 0.5), row(50000, 0.5, 0.1)])["value"] == 5000
    assert pick([row(500, 0.6, 0.3), row(5000, 0.6, 0.1)])["value"] == 5000  # a tie goes to less forgetting
    assert pick([row(500, 0.6, 0.3), row(5000, 0.6, 0.3)])["value"] == 500  # then to the smaller setting
    assert (
        pick([row(500, 0.4, 0.3), row(5000, 0.9, 0.1, done=1)])["value"] == 500
    )  # an unfinished run is not kept


def test_the_report_says_whether_a_run_went_on_from_its_sweep_run(tmp_path: Path) -> None:
    from benchmarks.lifelong_report import origins_markdown, went_on_from

    sweep_lines = '{"what": "epoch", "seconds": 80.0}\n{"what": "evaluate", "seconds": 280.0}\n'
    for name, text in {
        "sweep-ewc-500": sweep_lines,
        "sweep-packnet-075": sweep_lines.replace("80.0", "81.0"),
        "ewc-s0": sweep_lines + '{"what": "epoch", "seconds": 79.0}\n',  # copied, then resumed
        "packnet-s0": sweep_lines,  # timed as EWC's sweep run, but no PackNet sweep run begins it
    }.items():
        (tmp_path / name).mkdir()
        (tmp_path / name / "timings.jsonl").write_text(text)
    assert went_on_from(tmp_path, "ewc", tmp_path / "ewc-s0") == "sweep-ewc-500"
    assert went_on_from(tmp_path, "packnet", tmp_path / "packnet-s0") is None
    text = origins_markdown(tmp_path)
    assert "EWC (`ewc-s0`) went on from the sweep run kept (`sweep-ewc-500`)" in text
    assert "PackNet (`packnet-s0`) learned tasks 0 and 1 again itself" in text


def test_the_cost_table_counts_loss_passes_apart_from_epochs(tmp_path: Path) -> None:
    from benchmarks.lifelong_report import cost_rows

    lines = [
        '{"what": "epoch", "label": "task_a: epoch 0/2", "seconds": 10.0}',  # the loss pass
        '{"what": "epoch", "label": "task_a: epoch 1/2", "seconds": 100.0}',
        '{"what": "epoch", "label": "task_a: epoch 2/2", "seconds": 110.0}',
        '{"what": "epoch", "label": "task_a: post-task epoch 1/2", "seconds": 90.0}',
        '{"what": "evaluate", "label": "task_a", "seconds": 360.0}',
    ]
    (tmp_path / "packnet-s0").mkdir()
    (tmp_path / "packnet-s0" / "timings.jsonl").write_text("\n".join(lines) + "\n")
    (row,) = cost_rows(tmp_path)
    assert (row["epochs"], row["loss_passes"]) == (3, 1)
    assert row["seconds_per_epoch"] == 100.0
    assert row["training_hours"] == 310.0 / 3600 and row["evaluation_hours"] == 0.1
