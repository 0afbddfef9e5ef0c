"""What ``generate`` is asked for: the request, checked and resolved, and its slots.

A request names a suite (a shipped one or a suite folder), the tasks in it, how many episodes
each, the image size, the seed and how many attempts an episode may take. Equal requests give
equal datasets. The work is split into *slots*, one per (task, episode number).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any, ClassVar

from libero_data.config import Config
from libero_data.errors import InputError
from libero_data.record.features import CAMERAS, FeatureLayout
from libero_data.sim.arm import ARM_INIT_NOISE, check_arm_noise
from libero_data.sim.env import check_render_quality

#: LIBERO's stored init states per task; with ``starts="stored"``, episode k < 50 of a task
#: starts from init state k.
STORED_INITS = 50
#: ``max_length``'s word for each task's standard limit (:func:`libero_data.tasks.horizons.standard_limit`).
STANDARD = "standard"
#: ``max_length``'s word for no bound, on a command line.
NO_BOUND = "none"

#: Where demonstrations start: placements drawn by LIBERO's sampler from the demonstration seed
#: stream (``sampler``: evaluation never uses them), or LIBERO's stored init states (``stored``:
#: the ones the paper's evaluation uses) and the sampler beyond the 50th episode.
STARTS = ("sampler", "stored")


@dataclass(frozen=True)
class GenerateRequest(Config):
    """What to generate; equal requests give equal datasets."""

    #: What requests made before a field existed did (read from their saved ``request.json``).
    legacy: ClassVar[dict[str, Any]] = {
        "starts": "stored",
        "features": "libero-data",
        "cameras": list(CAMERAS),
        "source": "",
        "render_quality": "full",
        "arm_noise": 0.0,  # sampler starts then began from LIBERO's one arm pose
        "imported": [],
        "import_tolerance": 0.0,
        "drop_noops": False,
        "max_length": None,  # every successful attempt was kept, however long
    }

    suite: str
    tasks: tuple[int, ...]
    episodes_per_task: int = 50
    image_size: int = 128
    seed: int = 0
    max_attempts: int = 8
    repo_id: str = ""
    starts: str = "sampler"
    features: str = "libero-data"  # the naming profile (libero_data.record.features.PROFILES)
    cameras: tuple[str, ...] = CAMERAS
    #: The demonstration source that makes the episodes, by its registered name
    #: (:mod:`libero_data.pipeline.sources`); "": the first that claims the request, in order.
    source: str = ""
    rerender_of: str = ""  # re-rendered from this dataset's stored states (libero-data rerender)
    render_quality: str = "full"  # libero_data.sim.env.RENDER_QUALITIES
    arm_noise: float = ARM_INIT_NOISE  # rad per arm joint on sampler starts (libero_data.sim.arm)
    # Imported demonstrations (libero-data import), read by the demonstration source that claims
    # these files (libero_data.pipeline.sources): the files, one per task in ``tasks`` order;
    # the largest one-step replay deviation kept; no-op frames dropped.
    imported: tuple[str, ...] = ()
    import_tolerance: float = 0.0
    drop_noops: bool = False
    #: The longest episode kept, in control steps: a number, ``"standard"`` (each task's standard
    #: limit) or None (no bound). A searched attempt still going at the bound is stopped there and
    #: counts as failed; sources that do not search keep their episodes (their cards count those over it).
    max_length: int | str | None = STANDARD
    #: Steps recorded after the goal is first reached, the arm held still and the gripper as it was
    #: (open after a release), as robosuite's and LIBERO's human collection records 10; the goal must
    #: still hold after them. The length bound counts the steps to the goal, not these.
    after_goal: int = 0

    #: Fields a request writes only when set: requests made before them read the same.
    written_when_set: ClassVar[tuple[str, ...]] = ("rerender_of", "after_goal")

    @classmethod
    def upgrade(cls, data: Any) -> dict[str, Any]:
        """``data`` as any version wrote it: before a request could name its demonstration
        source, ``source`` held the dataset a re-render was made from (now ``rerender_of``)."""
        data = dict(data)
        named = re.fullmatch(r"[a-z][a-z0-9_]*", str(data.get("source", "")))
        if "rerender_of" not in data and data.get("source") and not named:  # a folder's path
            data["rerender_of"], data["source"] = data["source"], ""
        return {"rerender_of": "", **super().upgrade(data)}

    def to_dict(self) -> dict[str, Any]:
        data = super().to_dict()
        for name in self.written_when_set:
            if data.get(name) in ("", 0):
                del data[name]
        return data

    def __post_init__(self) -> None:
        check_arm_noise(self.arm_noise)
        check_max_length(self.max_length)
        check_after_goal(self.after_goal)
        if self.episodes_per_task < 1:
            raise InputError(
                f"episodes per task must be at least 1, got {self.episodes_per_task}",
                field="episodes_per_task",
            )
        if not 32 <= self.image_size <= 512:
            raise InputError(f"the image size must be in 32..512, got {self.image_size}", field="image_size")
        if self.max_attempts < 1:
            raise InputError(
                f"attempts per episode must be at least 1, got {self.max_attempts}", field="max_attempts"
            )
        if not self.tasks:
            raise InputError("no tasks selected", field="tasks")
        if self.starts not in STARTS:
            raise InputError(f"starts must be {' or '.join(STARTS)}, got {self.starts!r}", field="starts")
        FeatureLayout(self.features, tuple(self.cameras), self.image_size)  # checks profile and cameras
        check_render_quality(self.render_quality)

    @property
    def layout(self) -> FeatureLayout:
        """What the dataset stores of each frame's images."""
        return FeatureLayout(self.features, tuple(self.cameras), self.image_size)

    def length_bound(self, task: Any) -> int | None:
        """The longest episode of ``task`` (of this request's suite) kept, in steps; None: no bound."""
        from libero_data.tasks.horizons import standard_limit

        if self.max_length == STANDARD:
            return standard_limit(self.suite, task.name)
        return None if self.max_length is None else int(self.max_length)

    def stored_start(self, k: int, stored: int) -> int | None:
        """The stored init state episode ``k`` starts from, or None (LIBERO's sampler)."""
        if self.starts == "stored" and k < min(STORED_INITS, stored):
            return k
        return None


def check_max_length(value: object) -> None:
    """:class:`InputError` naming ``max_length`` unless ``value`` is a length bound: a positive
    number of steps, ``"standard"`` or None."""
    if value is None or value == STANDARD:
        return
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise InputError(
            f"the length bound is a positive number of steps, {STANDARD!r} or {NO_BOUND!r}, got {value!r}",
            field="max_length",
        )


#: The most steps ``generate --after-goal`` records after the goal.
MOST_AFTER_GOAL = 100
#: The steps the expert records after the goal unless told otherwise: robosuite's and LIBERO's human
#: collection records 10 (the goal must hold that long). Without them a policy sees a release only in
#: an episode's last 3 frames (benchmarks/RESULTS.md, "The proof by learning").
AFTER_GOAL = 10


def check_after_goal(value: object) -> None:
    """:class:`InputError` naming ``after_goal`` unless ``value`` is a whole number of steps in
    0..:data:`MOST_AFTER_GOAL`."""
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= MOST_AFTER_GOAL:
        raise InputError(
            f"the steps recorded after the goal must be a whole number in 0..{MOST_AFTER_GOAL}, got {value!r}",
            field="after_goal",
        )


def parse_max_length(text: str) -> int | str | None:
    """A length bound as a command line writes it: digits, ``standard`` or ``none``."""
    word = text.strip().lower()
    if word == NO_BOUND:
        return None
    value: int | str = int(word) if word.isdigit() else word
    check_max_length(value)
    return value


@dataclass(frozen=True)
class Slot:
    """One episode to make: the task's place in the request, its suite index, the episode number."""

    position: int
    task_index: int
    k: int

    @property
    def key(self) -> str:
        return f"{self.position:03d}-{self.k:05d}"


def slots_of(request: GenerateRequest) -> list[Slot]:
    """Every slot of the request, task by task (the dataset's episode order)."""
    return [Slot(pos, t, k) for pos, t in enumerate(request.tasks) for k in range(request.episodes_per_task)]


def sim_state_width(request: GenerateRequest) -> int:
    """Widest flattened MuJoCo state among the requested tasks (stored init states tell it)."""
    from libero_data.tasks import get_suite

    suite = get_suite(request.suite)
    widths = []
    for index in request.tasks:
        task = suite.task(index)
        if task.init_states_path is not None:
            widths.append(int(task.init_states().shape[1]))
        else:
            widths.append(state_width(task))
    return max(widths)


def state_width(task: Any) -> int:
    """The width of a task's flattened MuJoCo state (a task, or a BDDL path), from its model."""
    from libero_data.sim import EnvConfig, LiberoEnv

    with LiberoEnv(task, EnvConfig(cameras=())) as env:
        return int(env.state_dim)
