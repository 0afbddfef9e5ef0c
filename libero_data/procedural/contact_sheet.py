"""A contact sheet: the first and last agentview frame of one expert episode per task, with
the task's instruction, as one PNG grid (to look at generated scenes at a glance)."""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np


def task_frames(task, *, size: int = 160, seed: int = 0) -> tuple[np.ndarray, np.ndarray, bool]:
    """(initial frame, final frame, success) of one expert episode from stored init state 0."""
    from libero_data.experts import Expert
    from libero_data.seeding import episode_seeds
    from libero_data.sim import EnvConfig, LiberoEnv

    init = task.init_states()[0] if task.init_states_path is not None else None
    reset_seed, expert_seed = episode_seeds(seed, task.id, 0)
    with LiberoEnv(task, EnvConfig(cameras=("agentview",), image_size=size)) as env:
        episode = Expert(env).run(init, reset_seed=reset_seed, seed=expert_seed)
        env.set_state(episode.states[0])
        first = env.render("agentview")
        env.set_state(episode.final_state)
        last = env.render("agentview")
    return first, last, bool(episode.success)


def contact_sheet(tasks: list, out: str | Path, *, size: int = 160, columns: int = 3, seed: int = 0) -> Path:
    """Render ``tasks`` (initial | final frame each) into a PNG grid at ``out``."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    rows = (len(tasks) + columns - 1) // columns
    fig, axes = plt.subplots(rows, columns, figsize=(columns * 4.2, rows * 2.6), squeeze=False)
    for ax in axes.flat:
        ax.axis("off")
    for ax, task in zip(axes.flat, tasks, strict=False):
        first, last, ok = task_frames(task, size=size, seed=seed)
        gap = np.full((first.shape[0], 4, 3), 255, dtype=np.uint8)
        ax.imshow(np.concatenate([first, gap, last], axis=1))
        title = "\n".join(textwrap.wrap(task.language, 42))
        ax.set_title(f"{title}\n{'success' if ok else 'expert failed'}", fontsize=8)
    fig.suptitle("initial | final (expert), agentview", fontsize=10)
    fig.tight_layout()
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=100)
    plt.close(fig)
    return out
