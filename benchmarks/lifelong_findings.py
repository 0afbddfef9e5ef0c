"""The LIBERO paper's findings about lifelong algorithms and policy architectures, and how each is
decided on our runs (issues 59 and 78); ``benchmarks/lifelong_report.py`` writes what they give.

A *method* is an algorithm with a policy, its runs named ``<method>-s<seed>`` in the runs folder:
``seql``, ``er``, ``ewc``, ``packnet``, ``mtl`` with ResNet-T (the quick preset's policy), and
``er-rnn``, ``er-vit``, ``packnet-rnn``, ``packnet-vit`` with ResNet-RNN and ViT-T. Two methods
are compared over the seeds both have, paired by seed and start
(:func:`libero_bench.analysis.seeds.compare_seeds`).

The paper's abstract names three discoveries; how each is tested here (one suite, libero_object
0, 1, 2):

1. SeqL has the best forward transfer: SeqL's FWT against ER's, EWC's and PackNet's.
2. PackNet forgets least (NBT against SeqL's, ER's and EWC's) and leads on LIBERO-Object (AUC
   against theirs). Its other half, ER beating PackNet on LIBERO-Long, needs that suite: not run.
3. EWC is worse than SeqL: EWC's FWT and AUC against SeqL's.
4. ER is robust across suites: needs several suites; one is run here, so it is not tested.
5. ResNet-T and ViT-T learn and keep more than ResNet-RNN: their AUC against ResNet-RNN's, with
   ER and with PackNet.
6. No single encoder is best for every algorithm (the order of ResNet-T and ViT-T depends on it):
   ViT-T's AUC against ResNet-T's with ER and with PackNet, each two-sided.
7. Naive supervised pretraining can hurt lifelong learning: needs pretraining runs; not run yet.

A finding's comparisons form a family; their paired permutation p-values are adjusted by Holm's
method. A directed finding is *reproduced* when every comparison goes its way with an adjusted
p < 0.05, *contradicted* when one goes the other way with an adjusted p < 0.05, and *not resolved
at this budget* otherwise. The order finding (6) is reproduced when the order is significant both
ways (one algorithm prefers ViT-T, another ResNet-T), contradicted when it is significant the same
way for every algorithm, and not resolved otherwise. Each kind of start (LIBERO's stored init
states; held-out placements) gets its verdict; the held-out one is the headline (those starts chose
no checkpoint).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from libero_bench.runs.folder import STARTS

ALGOS = ("seql", "er", "ewc", "packnet", "mtl")
#: The architecture runs: algorithm -> its methods with ResNet-RNN and ViT-T.
ARCHITECTURES = {"er": ("er-rnn", "er-vit"), "packnet": ("packnet-rnn", "packnet-vit")}
POLICIES = {"": "ResNet-T", "rnn": "ResNet-RNN", "vit": "ViT-T"}
#: The policy each method suffix names (``libero-bench run --policy``).
POLICY_IDS = {"": "resnet_t", "rnn": "resnet_rnn", "vit": "vit_t"}
ALGO_NAMES = {"seql": "SeqL", "er": "ER", "ewc": "EWC", "packnet": "PackNet", "mtl": "MTL"}
RUN_NAME = re.compile(r"^(?P<algo>[a-z]+)(?:-(?P<policy>rnn|vit))?-s(?P<seed>\d+)$")
ALPHA = 0.05


def display(method: str) -> str:
    """'SeqL', 'ER (ResNet-RNN)'"""
    algo, _, policy = method.partition("-")
    name = ALGO_NAMES.get(algo, algo)
    return f"{name} ({POLICIES[policy]})" if policy else name


@dataclass(frozen=True)
class Claim:
    """One comparison of a finding: ``subject``'s ``metric`` is higher (``higher``), lower
    (``not higher``) than ``other``'s, or either (``higher is None``: an order finding)."""

    subject: str
    other: str
    metric: str
    higher: bool | None


@dataclass(frozen=True)
class Finding:
    key: str
    text: str
    claims: tuple[Claim, ...]
    untested: str = ""  # why (part of) the finding cannot be tested on one suite
    order: bool = False  # decided by the signs of its two-sided claims (finding 6)


FINDINGS = (
    Finding(
        "seql_best_fwt",
        "SeqL has the best forward transfer",
        tuple(Claim("seql", other, "fwt", True) for other in ("er", "ewc", "packnet")),
    ),
    Finding(
        "packnet_forgets_least",
        "PackNet forgets least (lowest NBT) and leads on LIBERO-Object (highest AUC)",
        tuple(
            Claim("packnet", other, metric, metric == "auc")
            for metric in ("nbt", "auc")
            for other in ("seql", "er", "ewc")
        ),
        untested="its other half, ER beating PackNet on LIBERO-Long, needs LIBERO-Long runs",
    ),
    Finding(
        "ewc_worse_than_seql",
        "EWC is worse than SeqL (lower FWT and AUC)",
        (Claim("ewc", "seql", "fwt", False), Claim("ewc", "seql", "auc", False)),
    ),
    Finding(
        "er_robust_across_suites",
        "ER is robust across suites",
        (),
        untested="one suite (libero_object) is run at this budget",
    ),
    Finding(
        "transformers_ahead_of_rnn",
        "ResNet-T and ViT-T beat ResNet-RNN (higher AUC with ER and PackNet)",
        tuple(
            Claim(method, rnn, "auc", True)
            for algo, (rnn, vit) in ARCHITECTURES.items()
            for method in (algo, vit)
        ),
    ),
    Finding(
        "encoder_order_depends_on_algorithm",
        "No encoder is best for every algorithm (ViT-T against ResNet-T differs between ER and PackNet)",
        tuple(Claim(vit, algo, "auc", None) for algo, (_, vit) in ARCHITECTURES.items()),
        order=True,
    ),
    Finding(
        "pretraining_can_hurt",
        "Naive supervised pretraining can hurt lifelong learning",
        (),
        untested="it needs pretraining runs, the third part of issue 78 (after the seeds and the architectures)",
    ),
)


def method_runs(runs: Path) -> dict[str, list[Path]]:
    """Method -> its finished run folders (``<method>-s<seed>`` with a results.json), in seed order."""
    out: dict[str, list[tuple[int, Path]]] = {}
    for folder in runs.iterdir():
        match = RUN_NAME.match(folder.name)
        if match and (folder / "results.json").is_file():
            method = folder.name.rsplit("-s", 1)[0]
            out.setdefault(method, []).append((int(match["seed"]), folder))
    return {method: [p for _, p in sorted(found)] for method, found in sorted(out.items())}


def _seed(folder: Path) -> int:
    return int(folder.name.rsplit("-s", 1)[1])


def comparisons(methods: dict[str, list[Path]]) -> dict[str, dict[str, Any]]:
    """'a-vs-b' -> ``compare_seeds`` of the two methods over the seeds both have, for every pair a
    finding names whose methods both have runs."""
    from libero_bench.analysis.seeds import compare_seeds

    out = {}
    for a, b in sorted({(c.subject, c.other) for f in FINDINGS for c in f.claims}):
        seeds = {_seed(p) for p in methods.get(a, [])} & {_seed(p) for p in methods.get(b, [])}
        if seeds:
            out[f"{a}-vs-{b}"] = compare_seeds(
                [p for p in methods[a] if _seed(p) in seeds], [p for p in methods[b] if _seed(p) in seeds]
            )
    return out


def _claim_row(claim: Claim, compared: dict[str, dict[str, Any]], start: str) -> dict[str, Any]:
    row: dict[str, Any] = {
        "subject": claim.subject,
        "other": claim.other,
        "metric": claim.metric,
        "tested": False,
    }
    result = compared.get(f"{claim.subject}-vs-{claim.other}", {})
    block = result.get(start)
    metric = ((block or {}).get("difference") or {}).get("metrics", {}).get(claim.metric)
    if metric is None:
        return row
    claimed = "either" if claim.higher is None else "higher" if claim.higher else "lower"
    went = metric["difference"] != 0 and (claim.higher is None or (metric["difference"] > 0) == claim.higher)
    row.update(
        tested=True,
        seeds=result["seeds"],
        claimed=claimed,
        subject_value=metric["a"],
        other_value=metric["b"],
        difference=metric["difference"],
        low=metric["low"],
        high=metric["high"],
        p_value=metric["p_value"],
        paired=metric["p_value"] is not None,
        as_claimed=went,
    )
    return row


def verdict(rows: list[dict[str, Any]], order: bool = False) -> str:
    """reproduced / contradicted / not resolved, from a family's rows with Holm-adjusted p."""
    if not rows or not all(r["tested"] for r in rows):
        return "not tested"
    significant = [r for r in rows if r["adjusted_p"] < ALPHA]
    if order:
        signs = {r["difference"] > 0 for r in significant}
        if len(signs) == 2:
            return "reproduced"
        if len(significant) == len(rows):
            return "contradicted"
        return "not resolved at this budget"
    if any(not r["as_claimed"] for r in significant):
        return "contradicted"
    if len(significant) == len(rows):
        return "reproduced"
    return "not resolved at this budget"


def missing_runs(finding: Finding, methods: dict[str, list[Path]]) -> list[str]:
    """The methods a finding compares that have no run."""
    names = {c.subject for c in finding.claims} | {c.other for c in finding.claims}
    return sorted(n for n in names if n not in methods)


def findings(compared: dict[str, dict[str, Any]]) -> list[dict[str, Any]]:
    """Each finding's comparisons per kind of start, with Holm-adjusted p-values and a verdict."""
    from libero_data.stats import holm_adjusted

    out = []
    for finding in FINDINGS:
        entry: dict[str, Any] = {"key": finding.key, "text": finding.text, "untested": finding.untested}
        for start in STARTS:
            rows = [_claim_row(c, compared, start) for c in finding.claims]
            tested = [r for r in rows if r["tested"]]
            # unpaired rows (not evaluated alike) have no p-value: they count as not significant
            p = [r["p_value"] if r["p_value"] is not None else 1.0 for r in tested]
            for row, adjusted in zip(tested, holm_adjusted(p), strict=True):
                row["adjusted_p"] = adjusted
            entry[start] = {"rows": rows, "verdict": verdict(rows, finding.order)}
        out.append(entry)
    return out
