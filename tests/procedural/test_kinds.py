"""The robustness kinds' registry: one module per kind, each complete, in a stable order."""

from __future__ import annotations

import pkgutil

import numpy as np
import pytest

import libero_data.perturb.kinds as kinds_package
from libero_data.errors import UnknownNameError
from libero_data.perturb.kinds import SHARED, all_kinds, get_kind
from libero_data.perturb.kinds.base import Kind
from libero_data.perturb.levels import ENV_KINDS, KINDS, LEVELS, MAGNITUDES, SCENE_KINDS

#: The kinds that existed when variants were first drawn, in their order: a drawn variant's seed
#: follows its kind's place, so these keep theirs and a new kind goes after them.
FIRST = ("layout", "distractors", "swap", "language", "camera", "robot_init", "lighting", "texture", "noise")


def test_every_module_is_one_kind_in_the_published_order() -> None:
    modules = {m.name for m in pkgutil.iter_modules(kinds_package.__path__)} - set(SHARED)
    found = all_kinds()
    assert {k.name for k in found} == modules
    assert tuple(k.name for k in found) == KINDS and KINDS[: len(FIRST)] == FIRST
    assert [k.order for k in found] == list(range(len(found)))
    assert SCENE_KINDS == tuple(k.name for k in found if k.rewrites_task) == FIRST[:4]
    assert tuple(k.name for k in found if not k.rewrites_task) == ENV_KINDS
    assert all(type(k).__module__ == f"libero_data.perturb.kinds.{k.name}" for k in found)
    with pytest.raises(UnknownNameError, match="unknown robustness kind 'fog'"):
        get_kind("fog")


@pytest.mark.parametrize("name", [k.name for k in all_kinds()])
def test_each_kind_is_complete(name: str) -> None:
    kind = get_kind(name)
    assert kind.summary and kind.magnitudes
    assert all(len(values) == len(LEVELS) for values in kind.magnitudes.values())
    assert MAGNITUDES[name] == kind.magnitudes
    if kind.rewrites_task:  # draws nothing for the simulator
        assert type(kind).vary is not Kind.vary
        with pytest.raises(NotImplementedError):
            kind.sample({}, np.random.default_rng(0))
    else:  # draws JSON-ready values the simulator applies, and changes something there
        m = {p: values[2] for p, values in kind.magnitudes.items()}
        drawn = kind.sample(m, np.random.default_rng(0))
        assert drawn and drawn == kind.sample(m, np.random.default_rng(0))
        hooks = ("apply_scene", "start_robot", "observe")
        assert any(getattr(type(kind), h) is not getattr(Kind, h) for h in hooks)
        assert kind.keeps_layout


def test_every_registered_kind_has_its_contact_sheet() -> None:
    # docs/procedural-and-robustness.md shows cards/robustness/<kind>.jpg for every kind.
    from pathlib import Path

    sheets = Path(__file__).resolve().parents[2] / "cards" / "robustness"
    missing = [k.name for k in all_kinds() if not (sheets / f"{k.name}.jpg").is_file()]
    assert not missing, (
        f"no contact sheet for {', '.join(missing)}: make it with `libero-data contact-sheet libero_object "
        f"--kind {','.join(missing)} --format jpg --out cards/robustness`"
    )
