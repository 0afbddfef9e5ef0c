"""Steps recorded after the goal (``generate --after-goal``): LIBERO's human demonstrations go on
10 steps after it (robosuite's collection loop), ours ended at it, a release then being an
episode's last 3 frames."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np


class _Env:
    """A stand-in for LiberoEnv: a state that counts the actions it was given, a goal that holds
    while fewer than ``lost_after`` of them were."""

    def __init__(self, lost_after: int = 1000) -> None:
        self.given: list[np.ndarray] = []
        self.lost_after = lost_after

    def get_state(self) -> np.ndarray:
        return np.array([float(len(self.given)), 0.0])

    def advance(self, action: np.ndarray) -> bool:
        self.given.append(np.array(action))
        return self.success()

    def success(self) -> bool:
        return len(self.given) < self.lost_after


def _episode(steps: int) -> Any:
    from libero_data.experts.expert import Episode

    actions = np.full((steps, 7), 0.3, dtype=np.float32)
    actions[-3:, 6] = -1.0  # a release
    states = np.arange(2 * steps, dtype=np.float64).reshape(steps, 2)
    return Episode(True, actions, states, np.zeros(2), 0, 0, phases={"place_on: release": steps})


def test_the_steps_after_the_goal_hold_the_arm_and_the_gripper_as_it_was() -> None:
    from libero_data.pipeline.sources.scripted import after_goal

    env = _Env()
    kept = after_goal(env, _episode(20), 5)  # type: ignore[arg-type]
    assert kept is not None and kept.length == 25
    np.testing.assert_array_equal(kept.actions[20:], np.tile([0, 0, 0, 0, 0, 0, -1], (5, 1)))
    np.testing.assert_array_equal(kept.actions[:20], _episode(20).actions)
    assert [s[0] for s in kept.states[20:]] == [0, 1, 2, 3, 4]  # each before its action
    assert kept.final_state[0] == 5 and kept.phases["after the goal"] == 5
    assert sum(kept.phases.values()) == kept.length
    assert after_goal(_Env(lost_after=3), _episode(20), 5) is None  # type: ignore[arg-type]


def test_a_dataset_with_steps_after_the_goal_counts_the_steps_to_it(tmp_path: Path) -> None:
    """Turning on the stove (about 95 steps) under a 110-step bound, 4 steps recorded after the
    goal: each episode ends with them, its goal still holds (rendering checks it), and the card
    and metadata count the steps to the goal against the limit and the bound."""
    from libero_data.pipeline.generate import generate
    from libero_data.pipeline.resolve import resolve_request
    from tests.pipeline.conftest import data_table

    request = resolve_request(
        "libero_goal", ["7"], episodes_per_task=1, image_size=32, seed=5, max_length=110, after_goal=4
    ).replace(cameras=("agentview",))
    out = tmp_path / "after"
    progress = generate(request, out)
    assert progress.done == 1
    (row,) = [json.loads(line) for line in (out / "meta" / "libero_episodes.jsonl").read_text().splitlines()]
    assert row["length"] == row["goal_step"] + 4 and row["goal_step"] <= 110
    actions = np.array(data_table(out)["action"].to_pylist())
    assert len(actions) == row["length"]
    np.testing.assert_array_equal(actions[-4:, :6], 0.0)
    assert len(set(actions[-5:, 6].tolist())) == 1  # the gripper as the last step to the goal left it
    meta = json.loads((out / "meta" / "libero.json").read_text())
    assert meta["request"]["after_goal"] == 4
    assert meta["tasks"][0]["within_standard_limit"] == 1
    card = (out / "README.md").read_text()
    assert "| steps after the goal | 4 (`--after-goal 4`)" in card
    from libero_data.pipeline.rerender import _records, rerender_request

    again = rerender_request(out, image_size=32, features="libero-data", cameras=("agentview",))
    records = _records(out, again)
    (record,) = records.values()  # a re-render keeps them, and still counts the steps to the goal
    assert record.goal_step == row["goal_step"] and len(record.trajectory()[1]) == row["length"]
