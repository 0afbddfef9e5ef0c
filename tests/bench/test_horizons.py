"""Evaluation step limits that fit the task: LeRobot's per-suite limits, an explicit number
everywhere a rollout is made (presets, eval, robustness, the LeRobot plugin), recorded with
every rollout and in every report, and a rollout cut by its own task's limit counted as cut.

Function calls only: no simulation (the plugin's environment is built, not reset).
"""

from __future__ import annotations

import numpy as np
import pytest
from typer.testing import CliRunner

from libero_bench.evaluation.eval_report import eval_markdown, summarize_eval
from libero_bench.evaluation.policy_eval import EvalRequest
from libero_bench.robustness.cells import SweepRequest
from libero_bench.rollouts.jobs import EvalTask, make_job
from libero_bench.train.presets import PAPER, QUICK, SMOKE, TrainPreset
from libero_data.errors import InputError
from libero_data.rollout import RolloutSettings
from libero_data.tasks.horizons import (
    HUMAN_LONGEST,
    OTHER_LIMIT,
    SUITE,
    SUITE_LIMITS,
    check_step_limit,
    parse_step_limit,
    step_limit,
)


def test_each_suite_limit_leaves_room_beyond_its_longest_human_demonstration() -> None:
    assert set(SUITE_LIMITS) == set(HUMAN_LONGEST)
    for suite, limit in SUITE_LIMITS.items():
        assert HUMAN_LONGEST[suite] < limit <= 1.5 * HUMAN_LONGEST[suite], suite
    assert SUITE_LIMITS["libero_10"] == 520 and SUITE_LIMITS["libero_spatial"] == 280


def test_a_limit_is_a_number_or_the_suites() -> None:
    assert step_limit(123, "libero_10") == 123
    assert step_limit(SUITE, "libero_goal") == 300
    assert step_limit(SUITE, "my_procedural_suite") == OTHER_LIMIT
    assert parse_step_limit(" suite ") == SUITE and parse_step_limit("64") == 64
    for bad in (0, -5, True, "sweet", 2.5, None):
        with pytest.raises(InputError, match="positive number of steps or 'suite'"):
            check_step_limit(bad)
    with pytest.raises(InputError):
        parse_step_limit("0")


def test_presets_keep_their_limits_and_accept_the_suites() -> None:
    assert PAPER.eval_max_steps == 600  # LIBERO's protocol
    assert isinstance(SMOKE.eval_max_steps, int)
    assert QUICK.eval_max_steps == SUITE  # each suite's limit: LeRobot's, a little over the human longest
    assert PAPER.with_overrides(["eval_max_steps=suite"]).eval_max_steps == SUITE
    assert PAPER.with_overrides(["eval_max_steps=250"]).eval_max_steps == 250
    preset = PAPER.replace(eval_max_steps=SUITE)
    assert TrainPreset.from_dict(preset.to_dict()) == preset
    for bad in ("forever", 0, True):
        with pytest.raises(ValueError, match=r"TrainPreset\.eval_max_steps"):
            PAPER.replace(eval_max_steps=bad)


def _task(suite: str, name: str = "t") -> EvalTask:
    return EvalTask(name, "do it", 0, "x.bddl", np.zeros(1, np.float32), heldout=(7,), suite=suite)


@pytest.mark.parametrize(("suite", "limit", "expected"), [("libero_10", SUITE, 520), ("libero_10", 90, 90)])
def test_a_rollout_takes_its_tasks_limit_and_records_it(suite: str, limit: object, expected: int) -> None:
    job = make_job(
        _task(suite),
        0,
        key="k",
        settle=0,
        max_steps=limit,  # type: ignore[arg-type]
        image_size=32,
        sim_state_width=9,
        shard_dir="s",
        rrd_path="r.rrd",
        tags={},
        start="heldout",
    )
    assert job.max_steps == expected and job.tags["max_steps"] == expected


def test_eval_and_robustness_default_to_the_suites_limits() -> None:
    assert EvalRequest("p", ("libero_10/0",)).max_steps == SUITE
    with pytest.raises(InputError):
        EvalRequest("p", ("libero_10/0",), max_steps=0)
    sweep = SweepRequest(tasks=("libero_10/0", "libero_spatial/1"), kinds=("camera",))
    limits = sweep.step_limits()
    assert sorted(limits.values()) == [280, 520]
    assert SweepRequest(tasks=("libero_10/0",), kinds=("camera",), max_steps=77).step_limits() == {
        next(iter(limits)): 77
    }


def test_the_report_states_each_tasks_limit_and_counts_cuts_against_it() -> None:
    settings = {
        "request": {"policy": "p", "max_steps": SUITE},
        "policy_type": "act",
        "training_data": "d",
        "tasks": [
            {"position": 0, "name": "long", "language": "a", "max_steps": 520},
            {"position": 1, "name": "short", "language": "b", "max_steps": 280},
        ],
    }

    def record(position: int, success: bool, steps: int) -> dict[str, object]:
        return {
            "task_position": position,
            "start": "heldout",
            "success": success,
            "steps": steps,
            "init_index": -1,
        }

    # 300 steps is a cut for the 280-step task, not for the 520-step one.
    records = [record(0, False, 300), record(0, False, 520), record(1, False, 300), record(1, True, 200)]
    summary = summarize_eval(settings, records, {})
    rows = {row["task"]: row for row in summary["tasks"]}
    assert (rows["long"]["max_steps"], rows["long"]["cut"]) == (520, 1)
    assert (rows["short"]["max_steps"], rows["short"]["cut"]) == (280, 1)
    assert summary["all"]["cut"] == 2 and summary["max_steps"] == SUITE
    text = eval_markdown(summary)
    assert "each task's suite limit" in text and "| 520 |" in text and "| 280 |" in text


def test_an_evaluation_folder_made_before_per_task_limits_reads_its_one_limit() -> None:
    settings = {
        "request": {"policy": "p", "max_steps": 300},
        "policy_type": "act",
        "training_data": "d",
        "tasks": [{"position": 0, "name": "t", "language": "a"}],
    }
    records = [{"task_position": 0, "start": "heldout", "success": False, "steps": 300, "init_index": -1}]
    assert summarize_eval(settings, records, {})["tasks"][0]["max_steps"] == 300


def test_the_lerobot_plugin_takes_the_suites_limit_unless_told() -> None:
    from lerobot_env_libero_data.config import LiberoDataEnvConfig
    from lerobot_env_libero_data.env import LiberoDataGymEnv

    assert LiberoDataEnvConfig().episode_length is None
    assert LiberoDataGymEnv("libero_10/0")._max_episode_steps == 520
    assert LiberoDataGymEnv("libero_object/0", rollout=RolloutSettings(max_steps=33))._max_episode_steps == 33
    with pytest.raises(ValueError, match="episode_length"):
        LiberoDataEnvConfig(episode_length=0)
    # the plugin's flags are the rollout settings every evaluation shares
    config = LiberoDataEnvConfig(episode_length=90, settle=3, render_quality="fast")
    assert config.gym_kwargs["rollout"] == RolloutSettings(max_steps=90, settle=3, render_quality="fast")
    assert LiberoDataEnvConfig().rollout_settings() == RolloutSettings()


def test_one_rollout_settings_config_serves_every_evaluation() -> None:
    settings = RolloutSettings(max_steps=123, settle=4, render_quality="fast")
    assert (
        QUICK.replace(eval_max_steps=123, eval_settle=4, eval_render_quality="fast").rollout_settings()
        == settings
    )
    request = EvalRequest("p", ("libero_10/0",), max_steps=123, settle=4, render_quality="fast")
    sweep = SweepRequest(
        tasks=("libero_10/0",), kinds=("camera",), max_steps=123, settle=4, render_quality="fast"
    )
    assert request.rollout_settings() == sweep.rollout_settings() == settings
    for bad in ({"settle": -1}, {"render_quality": "ultra"}, {"max_steps": 0}):
        with pytest.raises(InputError):
            RolloutSettings(**bad)
        with pytest.raises(InputError):
            EvalRequest("p", ("libero_10/0",), **bad)


@pytest.mark.parametrize("command", ["eval", "robustness"])
def test_a_bad_step_limit_is_one_sentence(command: str, tmp_path) -> None:
    from libero_bench.cli import app

    args = [command, str(tmp_path / "policy"), "--tasks", "libero_object/0", "--out", str(tmp_path / "o")]
    result = CliRunner().invoke(app, [*args, "--max-steps", "forever"])
    assert result.exit_code == 2, result.output
    assert "positive number of steps or 'suite'" in result.output
    assert "Traceback" not in result.output and not (tmp_path / "o").exists()
