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

#: The order variants, defaults and drawn seeds have always used; a new kind goes last.
ORDER = ("layout", "distractors", "swap", "language", "camera", "robot_init", "lighting", "texture", "noise")


def test_every_module_is_one_kind_in_the_published_order() -> None:
    modules = {m.name for m in pkgutil.iter_modules(kinds_package.__path__)} - set(SHARED)
    found = all_kinds()
    assert {k.name for k in found} == modules
    assert KINDS == ORDER == tuple(k.name for k in found)
    assert [k.order for k in found] == list(range(len(found)))
    assert ORDER[:4] == SCENE_KINDS and ORDER[4:] == ENV_KINDS
    assert all(type(k).__module__ == f"libero_data.perturb.kinds.{k.name}" for k in found)
    with pytest.raises(UnknownNameError, match="unknown robustness kind 'fog'"):
        get_kind("fog")


@pytest.mark.parametrize("name", ORDER)
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
