"""What a demonstration source is: where a dataset's episodes come from (the scripted expert,
LIBERO's HDF5 files, another dataset's stored states), and the typed record each one yields.

A source is one module of :mod:`libero_data.pipeline.sources` holding one :class:`DemoSource`
subclass, registered with :func:`register_source`. ``generate`` asks every source, in its
``order``, whether it ``claims`` a request; the first that does makes the request's episodes:

- ``search`` makes a slot's :class:`EpisodeRecord` in a worker (the expert searches there); a
  source whose records are written before ``generate`` starts (an import checks each
  demonstration in the driver) returns None, and a missing record is then an error;
- ``set_scene`` puts the environment where an episode's states are drawn in (the fixtures'
  placement), before its frames are rendered from them;
- ``card`` says what the dataset's card says of the demonstrations (:class:`CardPart`): by
  default the source's ``description`` (or its class docstring) and, in the task table, the
  share of episodes whose goal holds after their last action, checked while they are rendered;
  a source's own verdict on its episodes is never shown as a success rate unless it says what
  it counts (the expert's ``expert success``).

To add a source, copy the module of the source most like it (``scripted.py`` for one that makes
its episodes in the workers, ``libero_hdf5.py`` for one that reads them before) and a test
(``tests/pipeline/test_sources.py``).
"""

from __future__ import annotations

import inspect
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from libero_data.cards.card import GOAL_REACHED, UNDESCRIBED_SECTIONS, SuccessColumn
from libero_data.registry import Registry
from libero_data.runtime.files import load_record, save_record

if TYPE_CHECKING:
    from libero_data.pipeline.request import GenerateRequest, Slot
    from libero_data.runtime.jobs import WorkerCache


@dataclass(frozen=True)
class EpisodeRecord:
    """One slot's episode as a source made it: kept (``success``, with its states and actions)
    or given up (``failures`` say why), saved as the slot's search record.

    ``details`` are what the source tells of each episode beside its frames
    (``meta/libero_episodes.jsonl``); ``fixtures`` where the scene's fixtures stood, for sources
    whose episodes were recorded in a scene laid out elsewhere.
    """

    success: bool
    attempts: int
    failures: tuple[str, ...] = ()
    code: str = "unknown"  # the code that made it: the expert's code hash, "human", ...
    machine: dict[str, Any] | None = None  # the numeric path it was made on
    init_index: int = -1  # the stored init state it started from (-1: none)
    reset_seed: int = 0
    expert_seed: int = -1
    actions: np.ndarray | None = None
    states: np.ndarray | None = None
    final_state: np.ndarray | None = None  # the state after the last action (None: stepped again)
    plan: tuple[str, ...] = ()
    fixtures: dict[str, Any] | None = None
    details: dict[str, Any] = field(default_factory=dict)
    #: of the attempts, those stopped at the request's length bound (failed for being too long)
    too_long: int = 0
    #: the steps to the goal where steps were recorded after it (0: the goal came at the last action)
    goal_step: int = 0

    def to_dict(self) -> dict[str, Any]:
        """The saved form (the search record's keys; a given-up episode keeps only why)."""
        data: dict[str, Any] = {
            "success": self.success,
            "attempts": self.attempts,
            "failures": list(self.failures),
        }
        if self.too_long:
            data["too_long"] = self.too_long
        if self.success:
            data.update(
                init_index=self.init_index,
                reset_seed=self.reset_seed,
                expert_seed=self.expert_seed,
                actions=self.actions,
                states=self.states,
            )
            if self.final_state is not None:
                data["final_state"] = self.final_state
            data["plan"] = list(self.plan)
            if self.goal_step:
                data["goal_step"] = self.goal_step
        data["expert_code"] = self.code
        if self.machine is not None:
            data["machine"] = self.machine
        if self.fixtures is not None:
            data["fixtures"] = self.fixtures
        if self.details:
            data["imported"] = self.details  # the key records have always had (work folders resume)
        return data

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> EpisodeRecord:
        """Inverse of :meth:`to_dict` (records written by any earlier version)."""
        final = data.get("final_state")
        return cls(
            success=bool(data["success"]),
            attempts=int(data["attempts"]),
            failures=tuple(data.get("failures", ())),
            code=str(data.get("expert_code", "unknown")),
            machine=data.get("machine"),
            init_index=int(data.get("init_index", -1)),
            reset_seed=int(data.get("reset_seed", 0)),
            expert_seed=int(data.get("expert_seed", -1)),
            actions=data.get("actions"),
            states=data.get("states"),
            final_state=None if final is None else np.asarray(final),
            plan=tuple(data.get("plan", ())),
            fixtures=data.get("fixtures"),
            details=dict(data.get("imported", {})),
            too_long=int(data.get("too_long", 0)),
            goal_step=int(data.get("goal_step", 0)),
        )

    def trajectory(self) -> tuple[np.ndarray, np.ndarray]:
        """(states, actions) of a kept episode (``states[t]`` the state ``actions[t]`` was taken in)."""
        if self.states is None or self.actions is None:
            raise ValueError("an episode given up has no states or actions")
        return self.states, self.actions

    def save(self, path: Path) -> Path:
        return save_record(path, self.to_dict())

    @classmethod
    def load(cls, path: Path) -> EpisodeRecord:
        return cls.from_dict(load_record(path))


@dataclass(frozen=True)
class CardPart:
    """What a source puts in a dataset's card: the summary, where the episodes started, the
    settings rows it replaces or adds (after the common ones) and those that say nothing of its
    episodes, ``render_card``'s sections (``kind_tag``, ``how_made``, ``task_note``,
    ``reproducibility``; one left out says the source does not describe it) and what the task
    table's success column counts."""

    summary: str
    start_note: str
    settings: dict[str, str] = field(default_factory=dict)
    not_applicable: tuple[str, ...] = ()
    sections: dict[str, str] = field(default_factory=dict)
    success: SuccessColumn = GOAL_REACHED

    def card_sections(self) -> dict[str, str]:
        """``render_card``'s sections, those the source leaves out saying so."""
        return {**UNDESCRIBED_SECTIONS, **self.sections}

    def apply(self, common: dict[str, str]) -> dict[str, str]:
        """The card's settings rows: ``common`` with this source's rows."""
        rows = {**common, **self.settings}
        return {k: v for k, v in rows.items() if k not in self.not_applicable}


class DemoSource:
    """One demonstration source (see the module docstring)."""

    #: where it is asked (lower first): a source that claims any request (the expert) is last
    order: ClassVar[int] = 50
    #: what a request needs for this source to make it, in a few words (the error where a
    #: request names the source without it)
    needs: ClassVar[str] = ""
    #: how its demonstrations are made, for the card (default: the class docstring's first paragraph)
    description: ClassVar[str] = ""
    #: whether it records ``--after-goal``'s steps after an episode's goal (the expert does; a source
    #: that keeps episodes as they were recorded does not)
    records_after_goal: ClassVar[bool] = False

    def __init__(self, name: str) -> None:
        self.name = name

    def claims(self, request: GenerateRequest) -> bool:
        """Whether this source makes the request's episodes: by default, where the request names
        it (``GenerateRequest.source``); the shipped sources also claim requests by what they hold."""
        return request.source == self.name

    def search(
        self, cache: WorkerCache, task: Any, request: GenerateRequest, slot: Slot
    ) -> EpisodeRecord | None:
        """The slot's record, made in a worker; None where the source wrote it before."""
        return None

    def set_scene(self, env: Any, record: EpisodeRecord) -> None:
        """Put ``env`` where the episode's states are drawn in (before its frames are rendered)."""
        env.reset(seed=record.reset_seed, render=False)  # the episode's fixture placement

    def card(self, request: GenerateRequest, suite: str, infos: list[dict[str, Any]]) -> CardPart:
        """What the card of ``request``'s dataset (of ``suite``) says of its episodes, from each
        episode's ``episode.json`` (``infos``). By default: the source's name and ``description``,
        where the episodes began as recorded, and the goal checked on every episode."""
        began = stored_starts(infos)
        where = (
            f"{len(began)} of them began from LIBERO's stored init states ({', '.join(map(str, began))}), the "
            "states the paper's evaluation starts from: a policy evaluated on those has seen its starts in training"
            if began
            else "none of them began from LIBERO's stored init states"
        )
        return CardPart(
            summary=(
                f"Demonstrations of the LIBERO suite `{suite}` made by the demonstration source `{self.name}`, "
                "written with libero-data in LeRobot v3 format."
            ),
            start_note=(
                "Each episode's start is the source's; `meta/libero_episodes.jsonl` lists its init state "
                f"(`init_index`, -1 where it is none of LIBERO's stored init states) and seeds: {where}."
            ),
            sections={
                "how_made": (
                    f"The demonstration source `{self.name}` (`{type(self).__module__}.{type(self).__qualname__}`) "
                    f"made these episodes: {self.describe()} Each kept episode's images are rendered frame by "
                    "frame from its stored MuJoCo states."
                )
            },
        )

    def describe(self) -> str:
        """How the source's demonstrations are made, in a sentence or two (``description``, or
        the first paragraph of the class docstring)."""
        text = self.description or inspect.cleandoc(type(self).__doc__ or "").split("\n\n")[0]
        text = " ".join(text.split())
        if not text:
            return "it does not say how."
        return text if text.endswith(".") else f"{text}."


def stored_starts(infos: list[dict[str, Any]]) -> list[int]:
    """The LIBERO stored init states that a dataset's episodes (their ``episode.json``) began from."""
    return sorted({int(i["init_index"]) for i in infos if int(i.get("init_index", -1)) >= 0})


DEMO_SOURCES: Registry[DemoSource] = Registry("demonstration source")


def register_source(source: DemoSource) -> DemoSource:
    """Register a demonstration source (each module of this package calls it once)."""
    DEMO_SOURCES.register(source.name)(source)
    return source
