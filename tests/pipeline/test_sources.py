"""Demonstration sources: each registered source is asked in order, records keep their saved
form, and a source added in one file (here a throw-away one, in this file) drives ``generate``:
its records, its card and its episodes' details, with no pipeline file edited."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from libero_data.pipeline.episodes import expert_env
from libero_data.pipeline.request import GenerateRequest, Slot
from libero_data.pipeline.sources import (
    CardPart,
    DemoSource,
    EpisodeRecord,
    demo_sources,
    register_source,
    source_of,
)
from libero_data.runtime.jobs import WorkerCache

STEPS = 4


class HeldStill(DemoSource):
    """A throw-away source: logs (files ending ``.stilllog``) of an arm held still for a few
    steps from a seeded placement; made in the workers, as the expert's episodes are."""

    order = 10  # before LIBERO's HDF5 files, which claim any imported files

    def claims(self, request: GenerateRequest) -> bool:
        return any(name.endswith(".stilllog") for name in request.imported)

    def search(self, cache: WorkerCache, task: Any, request: GenerateRequest, slot: Slot) -> EpisodeRecord:
        env, _expert = expert_env(cache, task, request.image_size, tuple(request.cameras))
        env.reset(seed=slot.k, render=False)
        actions = np.zeros((STEPS, 7))
        states = []
        for action in actions:
            states.append(env.get_state())
            env.advance(action)
        return EpisodeRecord(
            success=True,
            attempts=1,
            code="held still",
            reset_seed=slot.k,
            actions=actions,
            states=np.asarray(states),
            final_state=np.asarray(env.get_state()),
            details={"demonstrator": "nobody", "source_file": request.imported[0]},
        )

    def card(self, request: GenerateRequest, suite: str, infos: list[dict[str, Any]]) -> CardPart:
        return CardPart(
            summary=f"An arm held still in the LIBERO suite `{suite}`.",
            start_note="Each episode starts from a placement drawn by LIBERO's sampler from its number.",
            settings={"demonstrations": "none: the arm held still", "starts": "LIBERO's sampler"},
            not_applicable=("seed", "expert code"),
            sections={"kind_tag": "held-still"},
        )


register_source(HeldStill("held_still"))


def test_sources_are_asked_in_order_and_the_expert_makes_any_other_request() -> None:
    names = [s.name for s in demo_sources()]
    assert (
        names.index("stored_states") < names.index("libero_hdf5") < names.index("scripted") == len(names) - 1
    )
    plain = GenerateRequest(suite="libero_goal", tasks=(7,))
    assert source_of(plain).name == "scripted"
    assert source_of(plain.replace(imported=("a_demo.hdf5",))).name == "libero_hdf5"
    assert source_of(plain.replace(imported=("a.stilllog",))).name == "held_still"
    assert source_of(plain.replace(imported=("a_demo.hdf5",), source="/data/x")).name == "stored_states"


def test_a_record_keeps_the_saved_form_of_its_source(tmp_path: Path) -> None:
    """What a source yields is saved as the slot's record and read back as it was (resuming
    reads the records earlier versions wrote)."""
    kept = EpisodeRecord(
        success=True,
        attempts=2,
        failures=("slipped",),
        code="abc",
        machine={"numeric_key": "k"},
        init_index=3,
        reset_seed=5,
        expert_seed=6,
        actions=np.zeros((2, 7)),
        states=np.ones((2, 9)),
        plan=("pick x",),
        fixtures={"door": [0.0, 1.0]},
        details={"source_file": "f.hdf5"},
    )
    back = EpisodeRecord.load(kept.save(tmp_path / "kept.npz"))
    assert back.to_dict().keys() == kept.to_dict().keys() and back.final_state is None
    assert (back.attempts, back.failures, back.plan, back.fixtures, back.details) == (
        2,
        ("slipped",),
        ("pick x",),
        {"door": [0.0, 1.0]},
        {"source_file": "f.hdf5"},
    )
    assert np.array_equal(back.trajectory()[1], kept.trajectory()[1])
    given_up = EpisodeRecord(success=False, attempts=1, failures=("no",), code="human")
    assert given_up.to_dict() == {"success": False, "attempts": 1, "failures": ["no"], "expert_code": "human"}
    with pytest.raises(ValueError, match="given up"):
        given_up.trajectory()


class _Attempt:
    """What the search reads of an expert episode, made up: reached the goal or not, its steps."""

    def __init__(self, success: bool, length: int) -> None:
        self.success, self.length = success, length
        self.failure = None if success else "missed the bowl"
        self.actions, self.states = np.zeros((length, 7)), np.zeros((length, 3))
        self.final_state, self.plan = np.zeros(3), ["pick bowl"]


class _MadeUpExpert:
    """An expert whose attempts are given: each call of ``run`` is the next one."""

    def __init__(self, attempts: list[_Attempt]) -> None:
        self.attempts = list(attempts)

    def run(self, init: Any, *, reset_seed: int, seed: int) -> _Attempt:
        return self.attempts.pop(0)


def test_an_attempt_longer_than_the_bound_is_a_failed_attempt_and_the_search_goes_on() -> None:
    from libero_data.pipeline.sources.scripted import search_slot
    from libero_data.tasks import get_task

    task = get_task("libero_goal/7")
    request = GenerateRequest("libero_goal", (7,), max_length=250, max_attempts=4)
    # stopped at the bound (the expert is built to stop there), reached the goal after it (the
    # wait for the goal runs past it), failed short of it, then one within it: kept at attempt 4
    tries = [_Attempt(False, 250), _Attempt(True, 260), _Attempt(False, 90), _Attempt(True, 250)]
    record = search_slot(None, _MadeUpExpert(tries), task, request, Slot(0, 7, 0))  # type: ignore[arg-type]
    assert (
        record.success
        and record.attempts == 4
        and record.too_long == 2
        and len(record.trajectory()[1]) == 250
    )
    assert record.failures == (
        "longer than the 250-step length bound (stopped at step 250 without the goal)",
        "longer than the 250-step length bound (reached the goal after 260 steps)",
        "missed the bowl",
    )
    # without a bound the first success is kept, however long
    unbounded = request.replace(max_length=None)
    kept = search_slot(None, _MadeUpExpert(tries[1:]), task, unbounded, Slot(0, 7, 0))  # type: ignore[arg-type]
    assert kept.success and kept.attempts == 1 and kept.too_long == 0 and len(kept.trajectory()[1]) == 260
    # every attempt too long: given up, the count saved with the record
    given_up = search_slot(None, _MadeUpExpert([_Attempt(True, 400)] * 4), task, request, Slot(0, 7, 1))  # type: ignore[arg-type]
    assert not given_up.success and given_up.too_long == 4
    assert EpisodeRecord.from_dict(given_up.to_dict()).too_long == 4


@pytest.mark.sim
def test_a_source_added_in_one_file_drives_generate(tmp_path: Path) -> None:
    from libero_data.pipeline.generate import generate

    request = GenerateRequest(
        suite="libero_goal", tasks=(7,), episodes_per_task=1, image_size=32, imported=("arm.stilllog",)
    )
    out = tmp_path / "held"
    progress = generate(request, out)
    assert (progress.done, progress.failed) == (1, 0)
    card = (out / "README.md").read_text()
    assert "An arm held still in the LIBERO suite `libero_goal`." in card and "held-still" in card
    assert "| demonstrations | none: the arm held still |" in card and "| seed |" not in card
    row = json.loads((out / "meta" / "libero_episodes.jsonl").read_text().splitlines()[0])
    assert (row["demonstrator"], row["source_file"], row["expert_code"]) == (
        "nobody",
        "arm.stilllog",
        "held still",
    )
    info = json.loads((out / "meta" / "info.json").read_text())
    assert info["total_frames"] == STEPS
