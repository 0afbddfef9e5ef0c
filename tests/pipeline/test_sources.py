"""Demonstration sources: each registered source is asked in order, records keep their saved
form, and a source added in one file (here a throw-away one, in this file) drives ``generate``:
its records, its card and its episodes' details, with no pipeline file edited."""

from __future__ import annotations

import dataclasses
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
    """A throw-away source: an arm held still for a few steps from a seeded placement; made in
    the workers, as the expert's episodes are, for requests that name it (the default ``claims``)."""

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
            details={"demonstrator": "nobody", "held_steps": STEPS},
        )

    def card(self, request: GenerateRequest, suite: str, infos: list[dict[str, Any]]) -> CardPart:
        # the default card (the docstring, the goal checked on each episode) with rows of its own
        return dataclasses.replace(
            super().card(request, suite, infos),
            settings={"demonstrations": "none: the arm held still", "starts": "LIBERO's sampler"},
            not_applicable=("seed", "expert code"),
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
    assert source_of(plain.replace(imported=("a_demo.hdf5",), rerender_of="/data/x")).name == "stored_states"
    # A request names its source; one added in a file makes only the requests that name it.
    assert source_of(plain.replace(source="held_still")).name == "held_still"
    assert source_of(plain.replace(source="scripted", imported=("a_demo.hdf5",))).name == "scripted"
    # A re-render is made from stored states whatever source made them.
    assert source_of(plain.replace(source="held_still", rerender_of="/data/x")).name == "stored_states"


def test_a_named_source_is_known_and_can_make_the_request() -> None:
    from libero_data.errors import InputError
    from libero_data.pipeline.resolve import resolve_request

    plain = GenerateRequest(suite="libero_goal", tasks=(7,))
    with pytest.raises(
        InputError, match=r"unknown demonstration source 'replay'; choose among stored_states, "
    ):
        source_of(plain.replace(source="replay"))
    with pytest.raises(
        InputError, match="'libero_hdf5' cannot make this request: it needs LIBERO HDF5 files"
    ):
        source_of(plain.replace(source="libero_hdf5"))
    assert resolve_request("libero_goal", ["7"], source="held_still").source == "held_still"


def test_generate_names_a_source_it_does_not_know_in_one_sentence(tmp_path: Path) -> None:
    from tests.pipeline.conftest import run_cli

    out = tmp_path / "d"
    result = run_cli(
        "generate", "--suite", "libero_goal", "--tasks", "7", "--source", "replay", "--out", str(out)
    )
    assert result.returncode != 0 and "Traceback" not in result.stderr
    assert "unknown demonstration source 'replay'; choose among stored_states, libero_hdf5, " in result.stderr
    assert not out.exists()


def test_requests_written_before_sources_had_names_read_the_same() -> None:
    # `source` held the dataset a re-render was made from; a request that names no source and
    # re-renders nothing writes what it wrote before (no new key).
    old = GenerateRequest(suite="libero_goal", tasks=(7,)).to_dict()
    assert old["source"] == "" and "rerender_of" not in old
    assert GenerateRequest.from_dict(old) == GenerateRequest(suite="libero_goal", tasks=(7,))
    rerendered = {**old, "source": "/data/libero_goal"}
    back = GenerateRequest.from_dict(rerendered)
    assert (back.source, back.rerender_of) == ("", "/data/libero_goal")
    assert back.to_dict()["rerender_of"] == "/data/libero_goal"
    named = GenerateRequest.from_dict({**old, "source": "held_still"})
    assert (named.source, named.rerender_of) == ("held_still", "")


def test_a_folder_begun_before_sources_had_names_resumes(tmp_path: Path) -> None:
    from libero_data.runtime.files import write_json
    from libero_data.runtime.folder import WorkFolder

    now = GenerateRequest(suite="libero_goal", tasks=(7,), rerender_of="/data/libero_goal")
    before = {**now.to_dict(), "source": "/data/libero_goal"}
    del before["rerender_of"]
    write_json(tmp_path / "request.json", before)
    folder = WorkFolder(tmp_path, "dataset")
    assert folder.claim(now.to_dict(), name="request.json", upgrade=GenerateRequest.upgrade) is not None


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
        suite="libero_goal", tasks=(7,), episodes_per_task=1, image_size=32, source="held_still"
    )
    out = tmp_path / "held"
    progress = generate(request, out)
    assert (progress.done, progress.failed) == (1, 0)
    card = (out / "README.md").read_text()
    assert "| demonstrations | none: the arm held still |" in card and "| seed |" not in card
    # The card speaks for the source: its name and docstring, not the expert's words, and the
    # kept episode counted by its goal (four still steps never reach it), not as a success.
    assert "made by the demonstration source `held_still`" in card
    assert "A throw-away source: an arm held still for a few steps from a seeded placement;" in card
    assert "scripted expert" not in card.lower() and "expert success" not in card
    assert "| episodes | goal reached | within the standard limit |" in card
    assert "| 1 | 0% (0/1) | 0% (0/1) |" in card and "**All tasks:** goal reached 0/1" in card
    assert "- demonstrations\n" in card  # the kind tag of a source that names none
    row = json.loads((out / "meta" / "libero_episodes.jsonl").read_text().splitlines()[0])
    assert (row["demonstrator"], row["held_steps"], row["expert_code"]) == ("nobody", STEPS, "held still")
    assert row["success"] is False
    meta = json.loads((out / "meta" / "libero.json").read_text())
    assert (meta["tasks"][0]["attempts"], meta["tasks"][0]["successes"]) == (1, 0)
    info = json.loads((out / "meta" / "info.json").read_text())
    assert info["total_frames"] == STEPS


def test_a_source_that_describes_nothing_gets_a_neutral_card() -> None:
    class Quiet(DemoSource):
        pass

    class Told(DemoSource):
        """Replays fixed actions.

        More detail the card leaves out."""

    class Said(Told):
        description = "Reads actions from a CSV file"

    infos = [{"init_index": 3}, {"init_index": -1}]
    request = GenerateRequest(suite="libero_goal", tasks=(7,))
    part = Quiet("quiet").card(request, "libero_goal", infos)
    sections = part.card_sections()
    assert sections["kind_tag"] == "demonstrations" and part.success.header == "goal reached"
    assert "`quiet`" in sections["how_made"] and "it does not say how." in sections["how_made"]
    assert not any("expert" in text.lower() for text in (*sections.values(), part.summary, part.start_note))
    assert "1 of them began from LIBERO's stored init states (3)" in part.start_note
    assert Told("told").describe() == "Replays fixed actions."
    assert Said("said").describe() == "Reads actions from a CSV file."
