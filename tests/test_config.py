"""The one config base: what earlier versions wrote is read through each config's declared
``legacy`` (and results through their ``upgrade``), nowhere else."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import pytest

from libero_data.config import Config
from libero_data.errors import ConfigError


@dataclass(frozen=True)
class Example(Config):
    legacy: ClassVar[dict[str, Any]] = {"quality": "full"}

    size: int = 1
    quality: str = "fast"


def test_fields_an_old_file_lacks_take_their_declared_meaning() -> None:
    assert Example.from_dict({"size": 2}) == Example(2, "full")  # written before `quality`
    assert Example.from_dict({"size": 2, "quality": "fast"}) == Example(2, "fast")
    assert Example.from_dict(Example(3).to_dict()) == Example(3)  # today's files round-trip
    with pytest.raises(ConfigError, match="no field"):
        Example.from_dict({"size": 2, "colour": "red"})


def test_the_project_declares_what_its_old_files_meant() -> None:
    from libero_bench.runs.folder import RunResults
    from libero_bench.train.presets import QUICK, TrainPreset
    from libero_data.pipeline.request import GenerateRequest
    from libero_data.procedural.suite import ProceduralSettings

    old_request = {
        k: v for k, v in GenerateRequest("libero_goal", (0,)).to_dict().items() if k != "arm_noise"
    }
    assert GenerateRequest.from_dict(old_request).arm_noise == 0.0  # made before arm noise
    assert ProceduralSettings.upgrade({"n": 2})["levels"] == [1]
    old_preset = {k: v for k, v in QUICK.to_dict().items() if k != "augment"}
    assert TrainPreset.from_dict(old_preset).augment is None
    fresh = RunResults.empty([{"name": "a"}, {"name": "b"}], [0, 1, 2]).to_dict()
    for key in ("curve_heldout", "after_heldout", "pruned_heldout", "rollouts", "complete"):
        del fresh[key]
    old = RunResults.from_dict(fresh)  # written before held-out starts existed
    assert len(old.curve_heldout) == 2 and all(math.isnan(v) for row in old.curve_heldout for v in row)
    assert old.pruned_heldout == [None, None] and old.rollouts == [] and not old.complete
