"""Applying a :class:`~libero_data.perturb.spec.Perturbation` to a built LIBERO scene.

``LiberoEnv`` calls these four for every perturbation, whatever its kind; each hands the work
to the kind's hook of the same name (:mod:`libero_data.perturb.kinds`), a no-op where the kind
does not define it, or to a LIBERO-Plus task's (:mod:`libero_data.perturb.plus_hooks`). The simulator
never names a kind.

- :func:`prepare_build` once, before the scene is built (a LIBERO-Plus task's added objects:
  their models made known to LIBERO's object registry);
- :func:`apply_scene` once, after the scene is built (e.g. ``camera``, ``lighting``,
  ``texture``: only what cameras see changes, physics is untouched);
- :func:`start_robot` after each reset (e.g. ``robot_init``): says whether it moved anything, so
  the simulator makes the state canonical again only then;
- :func:`observe` on each observation (e.g. ``noise``; the state stays clean).
"""

from __future__ import annotations

from typing import Any

from libero_data.perturb.kinds import get_kind
from libero_data.perturb.kinds.base import Kind
from libero_data.perturb.plus_hooks import KIND as PLUS
from libero_data.perturb.spec import Perturbation


def prepare_build(p: Perturbation) -> None:
    """Make ready what building a scene with ``p`` needs (before LIBERO builds it)."""
    _hooks(p.kind).prepare_build(p)


def apply_scene(raw: Any, p: Perturbation) -> None:
    """Change the built scene of ``raw`` (robosuite's env) as ``p`` says."""
    _hooks(p.kind).apply_scene(raw, p)


def start_robot(raw: Any, p: Perturbation, reset_seed: int) -> bool:
    """Move the arm's start for this reset as ``p`` says; whether it moved it (a kind without the
    hook never does; a hook that returns False did not this time)."""
    hooks = _hooks(p.kind)
    if type(hooks).start_robot is Kind.start_robot:
        return False
    return hooks.start_robot(raw, p, reset_seed) is not False


def observe(obs: dict[str, Any], p: Perturbation, cameras: tuple[str, ...]) -> None:
    """Change the observation ``obs`` in place as ``p`` says (its ``sim_state`` stays clean)."""
    _hooks(p.kind).observe(obs, p, cameras)


def _hooks(name: str) -> Any:
    """The hooks of a kind: one of ours, or a LIBERO-Plus task's (libero_data.perturb.plus_hooks)."""
    if name == PLUS:
        from libero_data.perturb.plus_hooks import HOOKS

        return HOOKS
    return get_kind(name)
