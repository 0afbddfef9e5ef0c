"""The simulator calls every kind's hooks through the registry: a throw-away kind registered here,
with each hook, sees each one called (none is gated on a kind's name in ``libero_data.sim``)."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import pytest

from libero_data.perturb.kinds.base import REGISTRY, Kind


class Probe(Kind):
    """Records each call of its hooks; moves the arm's first joint at reset, marks observations."""

    order = 99
    summary = "a kind that only records its hooks being called"
    magnitudes: ClassVar[dict[str, tuple[Any, ...]]] = {"marker": (1, 2, 3, 4, 5)}

    def __init__(self, name: str) -> None:
        super().__init__(name)
        self.calls: list[str] = []

    def sample(self, m: dict[str, Any], rng: np.random.Generator) -> dict[str, Any]:
        return {"marker": int(m["marker"])}

    def prepare_build(self, p: Any) -> None:
        self.calls.append("prepare_build")

    def apply_scene(self, raw: Any, p: Any) -> None:
        self.calls.append("apply_scene")

    def start_robot(self, raw: Any, p: Any, reset_seed: int) -> None:
        self.calls.append(f"start_robot {reset_seed}")
        robot = raw.robots[0]
        raw.sim.data.qpos[robot._ref_joint_pos_indexes[0]] += 0.1
        raw.sim.forward()

    def observe(self, obs: dict[str, Any], p: Any, cameras: tuple[str, ...]) -> None:
        self.calls.append("observe")
        obs["probe"] = p.params["marker"]


@pytest.fixture
def probe() -> Iterator[Probe]:
    from libero_data.perturb import kinds, levels

    kind = Probe("probe")
    REGISTRY.register("probe")(kind)
    kinds._loaded.cache_clear()
    levels._lists.cache_clear()
    try:
        yield kind
    finally:
        del REGISTRY._entries["probe"]
        kinds._loaded.cache_clear()
        levels._lists.cache_clear()


def test_a_new_kind_s_hooks_are_each_called(probe: Probe, tmp_path: Path) -> None:
    from libero_data.bddl import write
    from libero_data.perturb.levels import ENV_KINDS
    from libero_data.perturb.spec import sample
    from libero_data.sim import EnvConfig, LiberoEnv
    from libero_data.tasks import get_task

    assert "probe" in ENV_KINDS  # the registry's kinds, nothing listed by hand
    task = get_task("libero_object/0")
    drawn = sample("probe", 3, seed=0)
    path = tmp_path / "probe.bddl"
    path.write_text(write(dataclasses.replace(task.problem, perturbation=drawn.to_json())))
    with LiberoEnv(path, EnvConfig(cameras=())) as env, LiberoEnv(task, EnvConfig(cameras=())) as plain:
        assert probe.calls == ["prepare_build", "apply_scene"]  # once before the scene is built, once after
        obs = env.reset(seed=5, render=False)
        assert probe.calls == ["prepare_build", "apply_scene", "start_robot 5", "observe"]
        assert obs["probe"] == 3
        moved = obs["joint_pos"][0] - plain.reset(seed=5, render=False)["joint_pos"][0]
        assert moved == pytest.approx(0.1, abs=1e-5)  # the arm starts where the hook put it
        env.step(np.zeros(7, dtype=np.float32))
        assert probe.calls[-1] == "observe" and len(probe.calls) == 5
