"""Pictures of task scenes."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from libero_data.errors import InputError
from libero_data.runtime.files import write_bytes
from libero_data.tasks import Task


def render_initial_scene(
    task: Task,
    out: str | Path,
    *,
    size: int = 256,
    init: int = 0,
    seed: int = 0,
    renderer: str | None = None,
    render_quality: str = "full",
) -> Path:
    """Render the task's initial scene from stored init state ``init`` and save a PNG.

    Both cameras are placed side by side (agentview left, eye-in-hand right). Tasks without
    stored init states (plain BDDL files) use LIBERO's placement sampler with ``seed``.
    """
    from PIL import Image

    from libero_data.sim import EnvConfig, LiberoEnv

    state = None
    if task.init_states_path is not None:
        states = task.init_states()
        if not 0 <= init < len(states):
            raise InputError(f"task {task.id} has init states 0..{len(states) - 1}, not {init}", field="init")
        state = states[init]
    out = Path(out)
    with LiberoEnv(task, EnvConfig(image_size=size, renderer=renderer, render_quality=render_quality)) as env:
        obs = env.reset(state, seed=seed)
        picture = np.concatenate([obs["agentview"], obs["eye_in_hand"]], axis=1)
    png = io.BytesIO()
    Image.fromarray(picture).save(png, format="PNG")
    return write_bytes(out, png.getvalue())
