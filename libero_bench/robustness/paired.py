"""Two robustness sweeps compared start for start (``libero-bench compare SWEEP_A SWEEP_B``).

Two sweeps of the same tasks, kinds and levels, with the same held-out placements (their
``robustness.json`` records both), pair up: rollout ``r`` of a cell started from the same
placement in each. Per kind × level (source tasks pooled) and per kind (levels pooled) the
comparison gives each sweep's success with its Wilson interval, the difference B − A with a 95%
paired bootstrap interval (starts resampled within each cell), and McNemar's exact test on the
pairs where exactly one sweep succeeded. :func:`mean_difference` averages B − A over chosen kinds
at one level (the figure a robustness claim states), with its paired bootstrap interval.
"""

from __future__ import annotations

import textwrap
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from libero_bench.analysis.compare import ALPHA, Paired
from libero_bench.robustness.cells import REPORT
from libero_data.errors import RunError

DRAWS = 4000
SEED = 0


def load_sweep(folder: str | Path) -> dict[str, Any]:
    """A sweep's ``robustness.json``, with the outcomes and seeds a pairing needs."""
    from libero_data.runtime.files import read_json

    path = Path(folder) / f"{REPORT}.json"
    summary = read_json(path, required=("request", "table"))
    if "outcomes" not in summary or "heldout_seeds" not in summary:
        raise RunError(
            f"{path} was written before sweeps recorded each rollout's outcome; run the sweep again "
            "(a finished sweep's rollouts are read back, not rolled out again) to compare it"
        )
    return summary


def _pairs(a: dict[str, Any], b: dict[str, Any]) -> dict[tuple[str, int], list[tuple[bool, bool]]]:
    """(kind, level) -> the paired outcomes of every source task's cell (level 0: unperturbed)."""
    for name in sorted(set(a["heldout_seeds"]) | set(b["heldout_seeds"])):
        seeds_a, seeds_b = a["heldout_seeds"].get(name), b["heldout_seeds"].get(name)
        if seeds_a is None or seeds_b is None:
            raise RunError(f"only one of the sweeps rolled out {name}; sweep the same tasks to compare")
        n = min(len(seeds_a), len(seeds_b))
        if seeds_a[:n] != seeds_b[:n]:
            raise RunError(
                f"the sweeps started {name} from different held-out placements (seeds "
                f"{seeds_a[:3]}... and {seeds_b[:3]}...), so their outcomes cannot be paired"
            )
    seed_a, seed_b = a["request"].get("seed", 0), b["request"].get("seed", 0)
    if seed_a != seed_b:
        raise RunError(
            f"the sweeps drew their variants with different seeds ({seed_a} and {seed_b}), so a cell of one "
            "is not the same perturbation as the cell of the same name in the other"
        )
    out: dict[tuple[str, int], list[tuple[bool, bool]]] = {}
    cells_b = {c["name"]: c for c in b["table"]["cells"]}
    kinds = [k for k in a["table"]["grid"] if k in b["table"]["grid"]]
    for cell in a["table"]["cells"]:
        name = cell["name"]
        if name not in cells_b or name not in a["outcomes"] or name not in b["outcomes"]:
            continue
        pairs = list(zip(a["outcomes"][name], b["outcomes"][name], strict=False))
        for kind in kinds if cell["level"] == 0 else [cell["kind"]]:
            if kind in kinds:
                out.setdefault((kind, int(cell["level"])), []).extend(pairs)
    if not out:
        raise RunError("the two sweeps have no cell in common")
    return out


def _paired(pairs: Sequence[tuple[bool, bool]]) -> Paired:
    return Paired(
        a=sum(x for x, _ in pairs),
        b=sum(y for _, y in pairs),
        only_a=sum(x and not y for x, y in pairs),
        only_b=sum(y and not x for x, y in pairs),
        n=len(pairs),
    )


def _bootstrap(
    groups: Sequence[Sequence[tuple[bool, bool]]], rng: np.random.Generator
) -> tuple[float, float]:
    """95% interval of the mean over ``groups`` of each group's B − A success rate, starts
    resampled within each group."""
    draws = np.zeros(DRAWS)
    for group in groups:
        diff = np.array([int(y) - int(x) for x, y in group], dtype=float)
        picks = rng.integers(0, diff.size, size=(DRAWS, diff.size))
        draws += diff[picks].mean(axis=1)
    draws /= len(groups)
    low, high = np.quantile(draws, [0.025, 0.975])
    return float(low), float(high)


def _entry(pairs: Sequence[tuple[bool, bool]], rng: np.random.Generator) -> dict[str, Any]:
    paired = _paired(pairs)
    low, high = _bootstrap([pairs], rng)
    return {
        **paired.to_dict(),
        "difference": (paired.b - paired.a) / paired.n,
        "diff_low": low,
        "diff_high": high,
    }


def compare_sweeps(
    path_a: str | Path | Sequence[str | Path], path_b: str | Path | Sequence[str | Path]
) -> dict[str, Any]:
    """The comparison of two sweeps (see the module docstring), as JSON-ready data. Lists of
    sweeps pair up in order (sweep ``i`` of A with sweep ``i`` of B, say one per task) and their
    pairs are pooled per kind and level."""
    paths_a = [path_a] if isinstance(path_a, (str, Path)) else list(path_a)
    paths_b = [path_b] if isinstance(path_b, (str, Path)) else list(path_b)
    if len(paths_a) != len(paths_b) or not paths_a:
        raise RunError(f"compare as many sweeps of B as of A, got {len(paths_a)} and {len(paths_b)}")
    pairs: dict[tuple[str, int], list[tuple[bool, bool]]] = {}
    named: dict[str, list[str]] = {"a": [], "b": []}
    for one_a, one_b in zip(paths_a, paths_b, strict=True):
        a, b = load_sweep(one_a), load_sweep(one_b)
        named["a"].append(a["policy_name"])
        named["b"].append(b["policy_name"])
        for key, chosen in _pairs(a, b).items():
            pairs.setdefault(key, []).extend(chosen)
    rng = np.random.default_rng(SEED)
    grid: dict[str, dict[str, Any]] = {}
    for (kind, level), chosen in sorted(pairs.items()):
        grid.setdefault(kind, {})[str(level)] = _entry(chosen, rng)
    per_kind = {}
    for kind in grid:
        perturbed = [p for (k, level), ps in pairs.items() if k == kind and level > 0 for p in ps]
        if perturbed:
            per_kind[kind] = _entry(perturbed, rng)
    return {
        "a": {"sweeps": [str(p) for p in paths_a], "policy_name": ", ".join(named["a"])},
        "b": {"sweeps": [str(p) for p in paths_b], "policy_name": ", ".join(named["b"])},
        "levels": sorted({level for _, level in pairs}),
        "alpha": ALPHA,
        "grid": grid,
        "per_kind": per_kind,
        "pairs": {
            f"{k}/{level}": [[bool(x), bool(y)] for x, y in ps] for (k, level), ps in sorted(pairs.items())
        },
    }


def mean_difference(result: dict[str, Any], kinds: Sequence[str], level: int) -> dict[str, Any]:
    """B − A averaged over ``kinds`` at ``level`` (each kind weighted alike), with its 95% paired
    bootstrap interval."""
    groups = []
    for kind in kinds:
        key = f"{kind}/{level}"
        if key not in result["pairs"]:
            raise RunError(f"the sweeps have no {kind} cells of level {level}")
        groups.append([(x, y) for x, y in result["pairs"][key]])
    diffs = [np.mean([int(y) - int(x) for x, y in g]) for g in groups]
    low, high = _bootstrap(groups, np.random.default_rng(SEED))
    return {
        "kinds": list(kinds),
        "level": level,
        "difference": float(np.mean(diffs)),
        "low": low,
        "high": high,
    }


def paired_markdown(result: dict[str, Any]) -> str:
    levels = [str(level) for level in result["levels"]]

    def cell(entry: dict[str, Any] | None) -> str:
        if entry is None:
            return "–"
        star = " *" if entry["significant"] else ""
        return (
            f"{entry['a']['rate']:.0%} → {entry['b']['rate']:.0%} "
            f"({entry['difference']:+.0%} [{entry['diff_low']:+.0%}, {entry['diff_high']:+.0%}], "
            f"p={entry['p_value']:.2g}{star})"
        )

    lines = [
        f"# Robustness: {result['b']['policy_name']} (B) against {result['a']['policy_name']} (A)",
        "",
        "Success A → B per kind and level from the same held-out placements, the difference B − A "
        "with its 95% paired bootstrap interval and McNemar's exact p-value (* below "
        f"{result['alpha']}). Level 0 is the unperturbed task.",
        "",
        "| kind | " + " | ".join(f"level {level}" for level in levels) + " | levels pooled |",
        "|---|" + "---:|" * (len(levels) + 1),
    ]
    for kind, row in result["grid"].items():
        cells = [cell(row.get(level)) for level in levels]
        lines.append(f"| {kind} | " + " | ".join(cells) + f" | {cell(result['per_kind'].get(kind))} |")
    return "\n".join(lines) + "\n"


def heatmaps(result: dict[str, Any], path: Path) -> Path:
    """Side by side: A's success, B's, and B − A (significant cells marked), kind × level."""
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    kinds = list(result["grid"])
    levels = [str(level) for level in result["levels"]]

    def values(pick: Any) -> np.ndarray:
        return np.array(
            [
                [pick(result["grid"][k][c]) if c in result["grid"][k] else np.nan for c in levels]
                for k in kinds
            ],
            dtype=float,
        )

    panels = [
        ("A: " + result["a"]["policy_name"], values(lambda e: e["a"]["rate"]), "RdYlGn", (0.0, 1.0)),
        ("B: " + result["b"]["policy_name"], values(lambda e: e["b"]["rate"]), "RdYlGn", (0.0, 1.0)),
        (
            f"B − A (* McNemar p < {result['alpha']:.2g})",
            values(lambda e: e["difference"]),
            "PuOr",
            (-1.0, 1.0),
        ),
    ]
    width = 1.0 + 0.8 * len(levels)
    fig, axes = plt.subplots(1, 3, figsize=(3 * width + 1.5, 0.9 + 0.5 * len(kinds)), dpi=120, sharey=True)
    for ax, (title, grid, cmap, (low, high)) in zip(axes, panels, strict=True):
        image = ax.imshow(grid, vmin=low, vmax=high, cmap=cmap, aspect="auto")
        for i, kind in enumerate(kinds):
            for j, level in enumerate(levels):
                entry = result["grid"][kind].get(level)
                if entry is None:
                    continue
                if cmap == "PuOr":
                    text = f"{entry['difference']:+.0%}" + ("*" if entry["significant"] else "")
                else:
                    text = f"{grid[i, j]:.0%}"
                ax.text(j, i, text, ha="center", va="center", fontsize=7)
        ax.set_xticks(range(len(levels)), ["none" if c == "0" else f"L{c}" for c in levels])
        # pooled sweeps name every policy: wrap the title rather than let it run into the next panel
        ax.set_title(textwrap.fill(title, 40), fontsize=8)
        fig.colorbar(image, ax=ax, fraction=0.05)
    axes[0].set_yticks(range(len(kinds)), kinds)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path


def write_comparison(result: dict[str, Any], out: Path) -> list[Path]:
    import os

    from libero_data.runtime.files import write_json, write_text

    for side in ("a", "b"):  # the sweeps named from the comparison's folder
        result[side]["sweeps"] = [
            os.path.relpath(Path(p).resolve(), out.resolve()) for p in result[side]["sweeps"]
        ]
    return [
        write_json(out / "compare.json", result),
        write_text(out / "compare.md", paired_markdown(result)),
        heatmaps(result, out / "compare.png"),
    ]
