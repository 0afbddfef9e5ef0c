"""The layout of a run folder and its JSON files (no torch here: reports read it cheaply).

::

    RUN/
      config.json         what the run is: data, tasks in order, preset, policy, algorithm, seed
                          (paths relative to the run folder)
      training_data.json  where each task's demonstrations started, the states' width: what
                          evaluating the run needs from its data (runs.training_data)
      results.json        success tensor (curve, after), best epochs, losses, every rollout's outcome
      timings.jsonl       seconds per epoch / evaluation round (not part of the results)
      run.log             the library's log (written by the CLI)
      checkpoints/task_NNN.safetensors  policy + algorithm state + RNG after each task (resume
                                point; tensors plus a JSON header, nothing pickled: state_files)
      checkpoints/task_NNN.epoch.safetensors  the same plus optimiser, schedule and results after
                                the last finished epoch of the task in progress (removed when it ends)
      rollouts/           every evaluation rollout as one LeRobot dataset (+ mcap/ per rollout)
      rrd/<key>.rrd       a Rerun recording per rollout
      .work/              shards and scratch files while running (left_behind.json: the
                          rollouts whose shards stayed on another machine, a run carried on)
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from libero_bench.runs.state_files import MIGRATE_HINT
from libero_data.errors import CheckpointError, FileFormatError, InputError, RunError, first_line
from libero_data.runtime.files import read_json, require_fields

CONFIG = "config.json"
RESULTS = "results.json"
TIMINGS = "timings.jsonl"
LOG = "run.log"
CHECKPOINTS = "checkpoints"
ROLLOUTS = "rollouts"
RRD = "rrd"
WORK = ".work"
RUN_FORMAT = "libero-bench-run/1"
#: What every reader of a run's config.json uses (what rebuilds its policy: :data:`POLICY_FIELDS`).
CONFIG_FIELDS = ("format", "tasks", "algo", "policy", "preset", "seed")
POLICY_FIELDS = ("data", "algo_config", "policy_config")

LEARNING, PRUNED, AFTER = "learning", "pruned", "after"
#: Where evaluation rollouts start: LIBERO's stored init states (the paper's protocol), or
#: held-out sampler placements no demonstration started from (``libero_data.seeding``).
STORED, HELDOUT = "stored", "heldout"
STARTS = (STORED, HELDOUT)
#: The standard protocol's start (libero_bench.rollouts.protocol): episode i from stored init state
#: i, its fixtures from LIBERO's i-th reset after seeding with 7. Evaluations only, never a run's rounds.
STANDARD = "standard"
#: Every kind of start an evaluation reports, in the order its tables show them.
START_KINDS = (STORED, HELDOUT, STANDARD)


def rollout_key(
    learned_after: int, phase: str, task: int, rollout: int, epoch: int | None = None, start: str = STORED
) -> str:
    """A rollout's name (``r`` for a stored start, ``h`` for a held-out one); names sort by
    stage, then task, then kind of start."""
    if phase == LEARNING:
        if epoch is None:
            raise ValueError("learning-phase rollouts need an epoch")
        stage = f"e{epoch:03d}"
    elif phase == PRUNED:
        stage = "p"
    elif phase == AFTER:
        stage = "z"
    else:
        raise ValueError(f"unknown evaluation phase {phase!r}")
    if start not in STARTS:
        raise ValueError(f"unknown kind of start {start!r}")
    return f"k{learned_after:03d}-{stage}-t{task:03d}-{'r' if start == STORED else 'h'}{rollout:03d}"


def _nan_to_none(rows: list[list[float]]) -> list[list[float | None]]:
    return [
        [None if (v is None or (isinstance(v, float) and math.isnan(v))) else v for v in row] for row in rows
    ]


def _none_to_nan(rows: list[list[Any]]) -> list[list[float]]:
    return [[math.nan if v is None else float(v) for v in row] for row in rows]


@dataclass
class RunResults:
    """What a run measured; ``curve[k][e]`` and ``after[tau][k]`` as in :mod:`metrics`, from
    LIBERO's stored init states (the paper's protocol), and the same from held-out placements
    (``curve_heldout``, ``after_heldout``, ``pruned_heldout``; NaN where none were run).

    ``stage[k]`` is ``""`` (not started), ``"trained"`` (checkpoint saved, earlier tasks not
    yet re-evaluated) or ``"done"``.
    """

    tasks: list[dict[str, Any]]
    eval_epochs: list[int]
    curve: list[list[float]]
    after: list[list[float]]
    best_epoch: list[int | None]
    losses: list[list[dict[str, float]]]
    post_losses: list[list[dict[str, float]]]
    pruned: list[float | None]
    stage: list[str]
    rollouts: list[dict[str, Any]] = field(default_factory=list)
    complete: bool = False
    curve_heldout: list[list[float]] = field(default_factory=list)
    after_heldout: list[list[float]] = field(default_factory=list)
    pruned_heldout: list[float | None] = field(default_factory=list)

    def kept_index(self, task: int) -> int:
        """The evaluation point whose checkpoint the run kept for ``task`` (its best epoch;
        else the last one measured)."""
        epoch = self.best_epoch[task]
        if epoch is not None and epoch in self.eval_epochs:
            return self.eval_epochs.index(epoch)
        measured = [e for e, v in enumerate(self.curve[task]) if not math.isnan(v)]
        return measured[-1] if measured else len(self.eval_epochs) - 1

    def kept_success(self, task: int, start: str) -> float:
        """The success of the kept checkpoint on the task it learned: the best of the curve on
        stored starts (the paper's ``c_kk``); on held-out starts, the value at the kept point."""
        if start == STORED:
            measured = [v for v in self.curve[task] if not math.isnan(v)]
            return max(measured) if measured else math.nan
        return self.curve_heldout[task][self.kept_index(task)]

    def curve_of(self, start: str) -> list[list[float]]:
        return self.curve if start == STORED else self.curve_heldout

    def after_of(self, start: str) -> list[list[float]]:
        return self.after if start == STORED else self.after_heldout

    def pruned_of(self, start: str) -> list[float | None]:
        return self.pruned if start == STORED else self.pruned_heldout

    @classmethod
    def empty(cls, tasks: list[dict[str, Any]], eval_epochs: list[int]) -> RunResults:
        k, e = len(tasks), len(eval_epochs)
        return cls(
            tasks=tasks,
            eval_epochs=eval_epochs,
            curve=[[math.nan] * e for _ in range(k)],
            after=[[math.nan] * k for _ in range(k)],
            best_epoch=[None] * k,
            losses=[[] for _ in range(k)],
            post_losses=[[] for _ in range(k)],
            pruned=[None] * k,
            stage=[""] * k,
            **_heldout_grids(k, e),
        )

    @property
    def finished_tasks(self) -> int:
        """Tasks fully done, counted from the first."""
        n = 0
        for s in self.stage:
            if s != "done":
                break
            n += 1
        return n

    def to_dict(self) -> dict[str, Any]:
        return {
            "tasks": self.tasks,
            "eval_epochs": self.eval_epochs,
            "curve": _nan_to_none(self.curve),
            "after": _nan_to_none(self.after),
            "best_epoch": self.best_epoch,
            "losses": self.losses,
            "post_losses": self.post_losses,
            "pruned": self.pruned,
            "stage": self.stage,
            "rollouts": self.rollouts,
            "complete": self.complete,
            "curve_heldout": _nan_to_none(self.curve_heldout),
            "after_heldout": _nan_to_none(self.after_heldout),
            "pruned_heldout": self.pruned_heldout,
        }

    @classmethod
    def upgrade(cls, data: Mapping[str, Any]) -> dict[str, Any]:
        """``results.json`` as any version wrote it: results written before held-out starts existed
        get NaN curves from them (the one way results read what earlier versions wrote)."""
        out = dict(data)
        out.setdefault("rollouts", [])
        out.setdefault("complete", False)
        for key, empty in _heldout_grids(len(out["tasks"]), len(out["eval_epochs"])).items():
            if not out.get(key):
                out[key] = empty
        return out

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> RunResults:
        data = cls.upgrade(data)
        return cls(
            tasks=list(data["tasks"]),
            eval_epochs=[int(e) for e in data["eval_epochs"]],
            curve=_none_to_nan(data["curve"]),
            after=_none_to_nan(data["after"]),
            best_epoch=list(data["best_epoch"]),
            losses=list(data["losses"]),
            post_losses=list(data["post_losses"]),
            pruned=list(data["pruned"]),
            stage=list(data["stage"]),
            rollouts=list(data["rollouts"]),
            complete=bool(data["complete"]),
            curve_heldout=_none_to_nan(data["curve_heldout"]),
            after_heldout=_none_to_nan(data["after_heldout"]),
            pruned_heldout=list(data["pruned_heldout"]),
        )


def _heldout_grids(k: int, e: int) -> dict[str, Any]:
    """The held-out results of ``k`` tasks and ``e`` evaluation points, none measured yet."""
    return {
        "curve_heldout": [[math.nan] * e for _ in range(k)],
        "after_heldout": [[math.nan] * k for _ in range(k)],
        "pruned_heldout": [None] * k,
    }


@dataclass(frozen=True)
class RunFolder:
    """Paths inside a run folder."""

    root: Path

    @property
    def config(self) -> Path:
        return self.root / CONFIG

    @property
    def results(self) -> Path:
        return self.root / RESULTS

    @property
    def timings(self) -> Path:
        return self.root / TIMINGS

    @property
    def log(self) -> Path:
        return self.root / LOG

    @property
    def checkpoints(self) -> Path:
        return self.root / CHECKPOINTS

    @property
    def rollouts(self) -> Path:
        return self.root / ROLLOUTS

    @property
    def rrd(self) -> Path:
        return self.root / RRD

    @property
    def work(self) -> Path:
        return self.root / WORK

    @property
    def shards(self) -> Path:
        return self.work / "shards"

    def checkpoint(self, task: int) -> Path:
        return self.checkpoints / f"task_{task:03d}.safetensors"

    def epoch_state(self, task: int) -> Path:
        return self.checkpoints / f"task_{task:03d}.epoch.safetensors"

    def refuse_pickles(self) -> None:
        """One sentence if the run's checkpoints are pickles (``.pt``, from before safetensors)."""
        pickled = sorted(p.name for p in self.checkpoints.glob("*.pt")) if self.checkpoints.is_dir() else []
        if pickled:
            shown = ", ".join(pickled[:3]) + (", ..." if len(pickled) > 3 else "")
            raise CheckpointError(f"{self.checkpoints} holds pickled checkpoints ({shown}); {MIGRATE_HINT}")

    def shard(self, key: str) -> Path:
        return self.shards / key

    @property
    def left_behind(self) -> Path:
        """The rollouts whose shards stayed on the machine a run in progress was carried from
        (their outcomes are in ``results.json``; the joined dataset goes without them)."""
        return self.work / "left_behind.json"

    def rrd_file(self, key: str) -> Path:
        return self.rrd / f"{key}.rrd"

    def is_run(self) -> bool:
        """Whether the folder holds a libero-bench run (a LeRobot policy folder has a config.json too)."""
        if not self.config.is_file():
            return False
        try:
            return bool(json.loads(self.config.read_text()).get("format") == RUN_FORMAT)
        except (OSError, ValueError, AttributeError):  # not JSON, not text, not an object
            return False

    def read_config(self, needs: tuple[str, ...] = ()) -> dict[str, Any]:
        """The run's ``config.json``, checked for the fields every reader uses and ``needs``."""
        if not self.config.is_file():
            raise RunError(f"{self.root} is not a libero-bench run folder (no {CONFIG})")
        data = read_json(self.config)
        if not isinstance(data, dict) or data.get("format") != RUN_FORMAT:
            raise RunError(f"{self.config} is not a {RUN_FORMAT} config")
        require_fields(data, CONFIG_FIELDS + needs, self.config)
        self.refuse_pickles()  # a shared run with pickled checkpoints is converted before any use
        tasks = data["tasks"]
        if not isinstance(tasks, list) or not all(isinstance(t, dict) and "name" in t for t in tasks):
            raise FileFormatError(f"{self.config}: 'tasks' is not a list of tasks with their names")
        for key in ("policy_config", "algo_config", "preset"):
            if key in data and not isinstance(data[key], dict):
                raise FileFormatError(f"{self.config}: {key!r} is not an object")
        return dict(data)

    def read_results(self) -> RunResults:
        if not self.results.is_file():
            raise RunError(f"{self.root} has no results yet ({RESULTS} is missing)")
        data = read_json(self.results)
        try:
            return RunResults.from_dict(data)
        except (KeyError, TypeError, ValueError, AttributeError) as exc:
            what = f"field {exc.args[0]!r} missing" if isinstance(exc, KeyError) else first_line(exc)
            raise FileFormatError(f"{self.results} is not a libero-bench results file ({what})") from None

    def rollout_recording(
        self, task: Mapping[str, Any], rollouts: list[dict[str, Any]], index: int
    ) -> tuple[dict[str, Any], Path]:
        """The ``index``-th of a task's rollout records and its Rerun recording."""
        if not 0 <= index < len(rollouts):
            raise InputError(
                f"task {task['name']} has rollouts 0..{len(rollouts) - 1}, not {index}", field="rollout"
            )
        record = rollouts[index]
        source = self.rrd_file(record["key"])
        if not source.is_file():
            raise RunError(f"the recording {source} is missing")
        return record, source

    def append_timing(self, record: Mapping[str, Any]) -> None:
        with self.timings.open("a") as f:
            f.write(json.dumps(dict(record), sort_keys=True) + "\n")


def find_task(config: Mapping[str, Any], ref: str) -> dict[str, Any]:
    """A task of a run (its ``config.json``) by name or by position in the run."""
    tasks = config["tasks"]
    for t in tasks:
        if t["name"] == ref:
            return dict(t)
    if ref.strip().isdigit():
        i = int(ref)
        if 0 <= i < len(tasks):
            return dict(tasks[i])
    names = ", ".join(f"{t['position']}:{t['name']}" for t in tasks)
    raise InputError(f"the run has no task {ref!r}; its tasks are {names}", field="task")


def task_rollouts(folder: RunFolder, ref: str) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """A task of the run (by name or position) and its rollouts' records, in run order."""
    chosen = find_task(folder.read_config(), ref)
    results = folder.read_results()
    mine = sorted(
        (r for r in results.rollouts if r["task_position"] == chosen["position"]), key=lambda r: r["key"]
    )
    if not mine:
        raise RunError(f"task {chosen['name']} has no rollouts in {folder.root} yet")
    return chosen, mine
