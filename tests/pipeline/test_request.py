"""What ``generate`` is asked for: where episodes start, checked settings, old folders."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from libero_data.errors import InputError, SettingsChanged
from libero_data.pipeline.request import GenerateRequest
from libero_data.pipeline.sources.scripted import start_note
from libero_data.runtime.folder import WorkFolder
from libero_data.sim.arm import ARM_INIT_NOISE


def test_demonstrations_start_from_the_sampler_unless_stored_starts_are_asked_for() -> None:
    default = GenerateRequest("libero_goal", (0,))
    assert default.starts == "sampler"
    assert [default.stored_start(k, 50) for k in (0, 1, 49, 50)] == [None] * 4
    stored = GenerateRequest("libero_goal", (0,), starts="stored")
    assert [stored.stored_start(k, 50) for k in (0, 1, 49, 50)] == [0, 1, 49, None]
    assert stored.stored_start(12, 10) is None  # a suite folder with 10 sampled init states
    with pytest.raises(InputError) as bad:
        GenerateRequest("libero_goal", (0,), starts="random")
    assert bad.value.field == "starts"


def test_the_card_says_where_episodes_started() -> None:
    assert "No episode starts from LIBERO's 50 stored init states" in start_note(
        "sampler", 50, ARM_INIT_NOISE
    )
    assert "has seen its starts in training" in start_note("stored", 50, ARM_INIT_NOISE)
    assert "Further episodes start from placements drawn" in start_note("stored", 60, ARM_INIT_NOISE)


def test_a_dataset_begun_before_starts_existed_continues_with_stored_starts(tmp_path: Path) -> None:
    old = GenerateRequest("libero_goal", (0,), starts="stored").to_dict()
    del old["starts"]
    (tmp_path / "request.json").write_text(json.dumps(old))
    folder = WorkFolder(tmp_path, "dataset")
    stored = GenerateRequest("libero_goal", (0,), starts="stored").to_dict()
    assert folder.claim(stored, name="request.json", legacy=GenerateRequest.legacy) is not None
    with pytest.raises(SettingsChanged, match=r"\(starts\)"):
        folder.claim(
            GenerateRequest("libero_goal", (0,)).to_dict(), name="request.json", legacy=GenerateRequest.legacy
        )


def test_sampler_starts_get_the_stored_states_arm_noise_unless_asked_otherwise() -> None:
    assert GenerateRequest("libero_goal", (0,)).arm_noise == 0.02
    assert "Gaussian noise of 0.02 rad" in start_note("sampler", 50, 0.02)
    assert "with the arm at LIBERO's initial pose" in start_note("sampler", 50, 0.0)
    with pytest.raises(InputError) as bad:
        GenerateRequest("libero_goal", (0,), arm_noise=-0.1)
    assert bad.value.field == "arm_noise"


def test_a_dataset_begun_before_arm_noise_existed_continues_without_it(tmp_path: Path) -> None:
    # Its episodes began from LIBERO's one arm pose; new ones must too, or the dataset mixes two
    # kinds of start. Continuing needs --arm-noise 0; the default is refused, naming the setting.
    old = GenerateRequest("libero_goal", (0,)).to_dict()
    del old["arm_noise"]
    (tmp_path / "request.json").write_text(json.dumps(old))
    folder = WorkFolder(tmp_path, "dataset")
    with pytest.raises(SettingsChanged, match=r"\(arm_noise\); arm_noise 0.0 there, 0.02 asked"):
        folder.claim(
            GenerateRequest("libero_goal", (0,)).to_dict(), name="request.json", legacy=GenerateRequest.legacy
        )
    fixed = GenerateRequest("libero_goal", (0,), arm_noise=0.0).to_dict()
    assert folder.claim(fixed, name="request.json", legacy=GenerateRequest.legacy) is not None


def test_the_cli_default_arm_noise_is_the_stored_states() -> None:
    import inspect

    from libero_data.cli.generate import generate_cmd

    default = inspect.signature(generate_cmd).parameters["arm_noise"].default
    assert default == ARM_INIT_NOISE == GenerateRequest("libero_goal", (0,)).arm_noise


def test_the_length_bound_is_each_tasks_standard_limit_unless_asked_otherwise() -> None:
    from libero_data.pipeline.request import parse_max_length
    from libero_data.tasks import get_suite

    goal, spatial = get_suite("libero_goal").tasks[3], get_suite("libero_spatial").tasks[0]
    default = GenerateRequest("libero_goal", (3,))
    assert default.max_length == "standard" and default.length_bound(goal) == 300
    assert GenerateRequest("libero_spatial", (0,)).length_bound(spatial) == 220
    assert GenerateRequest("libero_goal", (3,), max_length=150).length_bound(goal) == 150
    assert GenerateRequest("libero_goal", (3,), max_length=None).length_bound(goal) is None
    assert [parse_max_length(t) for t in ("250", " standard ", "none", "None")] == [
        250,
        "standard",
        None,
        None,
    ]
    for bad in ("0", "-5", "forever", "2.5", ""):
        with pytest.raises(InputError, match="the length bound is a positive number of steps") as error:
            parse_max_length(bad)
        assert error.value.field == "max_length"
    for value in (0, True, "suite", 2.5):
        with pytest.raises(InputError):
            GenerateRequest("libero_goal", (3,), max_length=value)  # type: ignore[arg-type]


def test_a_dataset_begun_before_the_length_bound_existed_continues_without_one(tmp_path: Path) -> None:
    # Its episodes were kept however long; new ones must be too, or the dataset mixes two rules.
    old = GenerateRequest("libero_goal", (0,)).to_dict()
    del old["max_length"]
    assert GenerateRequest.from_dict(old).max_length is None
    (tmp_path / "request.json").write_text(json.dumps(old))
    folder = WorkFolder(tmp_path, "dataset")
    with pytest.raises(SettingsChanged, match=r"\(max_length\)"):
        folder.claim(
            GenerateRequest("libero_goal", (0,)).to_dict(), name="request.json", legacy=GenerateRequest.legacy
        )
    unbounded = GenerateRequest("libero_goal", (0,), max_length=None).to_dict()
    assert folder.claim(unbounded, name="request.json", legacy=GenerateRequest.legacy) is not None


def test_resuming_with_another_length_bound_is_refused(tmp_path: Path) -> None:
    # What `generate` checks before it writes anything into a folder it began before.
    from libero_data.pipeline.generate import check_output
    from libero_data.runtime.folder import DATASET_WORK

    begun = GenerateRequest("libero_goal", (0,), max_length=200)
    WorkFolder(tmp_path / DATASET_WORK, "dataset").claim(begun.to_dict(), name="request.json")
    for other in (150, "standard", None):
        with pytest.raises(SettingsChanged, match=r"different settings \(max_length\)"):
            check_output(begun.replace(max_length=other), tmp_path)
    assert check_output(begun, tmp_path) is None  # the same bound continues


def test_the_cli_default_length_bound_is_the_standard_limit() -> None:
    import inspect

    from libero_data.cli.generate import generate_cmd
    from libero_data.pipeline.request import parse_max_length

    default = inspect.signature(generate_cmd).parameters["max_length"].default
    assert parse_max_length(default) == GenerateRequest("libero_goal", (0,)).max_length == "standard"


def test_the_expert_records_ten_steps_after_the_goal_unless_told_and_other_sources_none() -> None:
    """``generate``'s default: 10 steps after the goal for the expert (as LIBERO's human collection
    records them); a source that keeps its episodes as recorded takes 0 and refuses any other."""
    import inspect

    from libero_data.cli.generate import generate_cmd
    from libero_data.pipeline.request import AFTER_GOAL
    from libero_data.pipeline.resolve import resolve_request

    assert AFTER_GOAL == 10
    assert inspect.signature(generate_cmd).parameters["after_goal"].default is None
    assert resolve_request("libero_goal", ["0"]).after_goal == AFTER_GOAL
    assert resolve_request("libero_goal", ["0"], source="scripted").after_goal == AFTER_GOAL
    assert resolve_request("libero_goal", ["0"], after_goal=0).after_goal == 0
    assert resolve_request("libero_goal", ["0"], source="libero_hdf5").after_goal == 0
    with pytest.raises(InputError, match="records no steps after the goal") as error:
        resolve_request("libero_goal", ["0"], after_goal=5, source="libero_hdf5")
    assert error.value.field == "after_goal"


def test_steps_after_the_goal_are_checked_and_a_request_without_them_reads_as_before(tmp_path: Path) -> None:
    # `--after-goal` is written only when set: a folder begun before it existed resumes unchanged.
    assert "after_goal" not in GenerateRequest("libero_goal", (0,)).to_dict()
    assert GenerateRequest("libero_goal", (0,), after_goal=10).to_dict()["after_goal"] == 10
    assert GenerateRequest.from_dict(GenerateRequest("libero_goal", (0,)).to_dict()).after_goal == 0
    for bad in (-1, 101, 2.5, True):
        with pytest.raises(InputError) as error:
            GenerateRequest("libero_goal", (0,), after_goal=bad)  # type: ignore[arg-type]
        assert error.value.field == "after_goal"
    (tmp_path / "request.json").write_text(json.dumps(GenerateRequest("libero_goal", (0,)).to_dict()))
    folder = WorkFolder(tmp_path, "dataset")
    with pytest.raises(SettingsChanged, match=r"\(after_goal\)"):
        folder.claim(
            GenerateRequest("libero_goal", (0,), after_goal=10).to_dict(),
            name="request.json",
            legacy=GenerateRequest.legacy,
        )
