"""What each severity level of a robustness kind looks like, before using it: one PNG per kind,
the source task (level 0) and levels 1–5 side by side, agentview over eye-in-hand, each with
the variant's instruction and what was drawn for it."""

from __future__ import annotations

import tempfile
import textwrap
from pathlib import Path
from typing import Any

import numpy as np

from libero_data.perturb.kinds import get_kind
from libero_data.perturb.levels import LEVELS


def level_variants(task: Any, kind: str, seed: int = 0) -> list[tuple[int, Any, str]]:
    """(level, problem or None, why not) for levels 0 (the source) to 5 of ``kind``."""
    from libero_data.procedural.variants import make_variant
    from libero_data.scenes.sampler import SamplingError
    from libero_data.seeding import variant_level_rng

    out: list[tuple[int, Any, str]] = [(0, task.problem, "")]
    for level in LEVELS:
        rng = variant_level_rng(seed, task.index, 0, level)
        try:
            out.append(
                (
                    level,
                    make_variant(task.problem, task.id, kind, rng, language=task.language, level=level),
                    "",
                )
            )
        except SamplingError as exc:
            out.append((level, None, str(exc)))
    return out


def _frames(bddl: Path, state: np.ndarray | None, size: int, reset_seed: int) -> dict[str, np.ndarray]:
    from libero_data.sim import EnvConfig, LiberoEnv

    with LiberoEnv(bddl, EnvConfig(image_size=size)) as env:
        obs = env.reset(state, seed=reset_seed, settle=5)
    return {"agentview": obs["agentview"], "eye_in_hand": obs["eye_in_hand"]}


def kind_sheet(task: Any, kind: str, out: str | Path, *, size: int = 128, seed: int = 0) -> Path:
    """Write the contact sheet of ``kind`` on ``task`` (levels 0–5) to ``out`` (a PNG)."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    from libero_data.bddl import write
    from libero_data.perturb.spec import Perturbation

    variants = level_variants(task, kind, seed)
    # Kinds that keep the source's layout start from its first stored state; the others
    # (layout, distractors, swap) from LIBERO's sampler, with the same seed.
    stored = task.init_states()[0] if task.init_states_path is not None else None
    fig, axes = plt.subplots(2, len(variants), figsize=(2.3 * len(variants), 5.4), squeeze=False)
    with tempfile.TemporaryDirectory() as tmp:
        for col, (level, problem, why) in enumerate(variants):
            for ax in axes[:, col]:
                ax.axis("off")
            if problem is None:
                axes[0, col].set_title(f"level {level}\n(none: {textwrap.shorten(why, 40)})", fontsize=7)
                continue
            path = Path(tmp) / f"level{level}.bddl"
            path.write_text(write(problem))
            keeps_layout = get_kind(kind).keeps_layout or level == 0
            frames = _frames(path, stored if keeps_layout else None, size, seed)
            axes[0, col].imshow(frames["agentview"])
            axes[1, col].imshow(frames["eye_in_hand"])
            p = Perturbation.from_json(problem.perturbation)
            detail = p.describe().split("(", 1)[1].rstrip(")") if p is not None else ""
            label = "source" if level == 0 else f"level {level}"
            text = "\n".join(textwrap.wrap(problem.language, 30)[:3])
            axes[0, col].set_title(f"{label}\n{text}", fontsize=7)
            if detail:
                axes[1, col].set_title("\n".join(textwrap.wrap(detail, 34)[:4]), fontsize=5)
    fig.suptitle(f"{kind}: {task.id} ({task.language}); agentview above, eye-in-hand below", fontsize=9)
    fig.tight_layout()
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out
