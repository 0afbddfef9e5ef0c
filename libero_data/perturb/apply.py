"""Applying a :class:`~libero_data.perturb.spec.Perturbation` to a built LIBERO scene.

``LiberoEnv`` calls these; each takes the robosuite environment it wraps and hands the work to
the perturbation's kind (:mod:`libero_data.perturb.kinds`):

- :func:`apply_scene` once, after the scene is built (``camera``, ``lighting``, ``texture``:
  only what cameras see changes, physics is untouched);
- :func:`start_robot` after each reset (``robot_init``);
- :func:`add_noise` to each observation (``noise``; the state stays clean).
"""

from __future__ import annotations

from typing import Any

from libero_data.perturb.kinds import get_kind
from libero_data.perturb.spec import Perturbation


def apply_scene(raw: Any, p: Perturbation) -> None:
    """Change the built scene of ``raw`` (robosuite's env) as ``p`` says."""
    get_kind(p.kind).apply_scene(raw, p)


def start_robot(raw: Any, p: Perturbation, reset_seed: int) -> None:
    """Move the arm's start for this reset as ``p`` says."""
    get_kind(p.kind).start_robot(raw, p, reset_seed)


def add_noise(obs: dict[str, Any], p: Perturbation, cameras: tuple[str, ...]) -> None:
    """Change the observation ``obs`` in place as ``p`` says (its ``sim_state`` stays clean)."""
    get_kind(p.kind).observe(obs, p, cameras)
