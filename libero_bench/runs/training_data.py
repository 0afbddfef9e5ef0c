"""What evaluating a run needs from its training data, kept in the run folder.

A run's held-out evaluation starts must avoid every start its demonstrations began from (the
stored init states and the sampler's reset seeds, mixed datasets included), and its rollout
dataset records simulator states as wide as its training data's. Both used to be read from the
datasets named in ``config.json``, so a run folder copied without them (a committed run, a run
shared with a colleague) could not be evaluated from held-out starts or swept. A run now
writes them into ``training_data.json`` when it is created; older runs fall back to their
datasets, and ``libero-bench migrate RUN`` records the file while the datasets are still there.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from libero_data.errors import FileFormatError, MissingFileError

TRAINING_DATA = "training_data.json"
FORMAT = "libero-bench-training-data/1"


def resolve(root: Path, path: str) -> Path:
    """A path a run's ``config.json`` names: relative to the run folder (absolute in older runs)."""
    named = Path(path)
    return named if named.is_absolute() else Path(root) / named


def relative(root: Path, path: Path) -> str:
    """How a run folder names ``path``: relative to it, so that the two can move together."""
    return os.path.relpath(Path(path).resolve(), Path(root).resolve())


@dataclass(frozen=True)
class TrainingData:
    """Per task of a run, where its demonstrations started (stored init indices, sampler seeds),
    and how wide its simulator states are."""

    datasets: tuple[str, ...]
    sim_state_width: int
    starts: dict[str, tuple[frozenset[int], frozenset[int]]]
    #: How the starts were found where not read from the datasets (a committed run's record).
    note: str = ""

    def to_dict(self) -> dict[str, Any]:
        return {
            "format": FORMAT,
            "datasets": list(self.datasets),
            "sim_state_width": self.sim_state_width,
            "tasks": {
                name: {"stored_inits": sorted(stored), "reset_seeds": sorted(seeds)}
                for name, (stored, seeds) in sorted(self.starts.items())
            },
            **({"note": self.note} if self.note else {}),
        }

    @classmethod
    def from_dict(cls, data: Any, where: Path) -> TrainingData:
        try:
            if data.get("format") != FORMAT:
                raise ValueError(f"format {data.get('format')!r}, not {FORMAT!r}")
            starts = {
                str(name): (
                    frozenset(int(i) for i in entry["stored_inits"]),
                    frozenset(int(s) for s in entry["reset_seeds"]),
                )
                for name, entry in data["tasks"].items()
            }
            datasets = tuple(str(d) for d in data["datasets"])
            return cls(datasets, int(data["sim_state_width"]), starts, str(data.get("note", "")))
        except (AttributeError, KeyError, TypeError, ValueError) as e:
            raise FileFormatError(f"{where} is not a run's training-data record ({e})") from None


def read_training_data(root: Path) -> TrainingData | None:
    """The run's ``training_data.json``; None where the run predates it."""
    path = Path(root) / TRAINING_DATA
    if not path.is_file():
        return None
    try:
        data = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise FileFormatError(f"{path} is not readable JSON ({e})") from None
    return TrainingData.from_dict(data, path)


def from_datasets(root: Path, config: dict[str, Any]) -> TrainingData:
    """What ``training_data.json`` holds, read from the datasets the run's ``config.json`` names
    (every episode of each task counts, mixed ones included)."""
    from libero_bench.data.dataset import DemoDataset
    from libero_bench.data.mixing import mixed_seeds

    folder = resolve(root, str(config["data"]))
    if not (folder / "meta").is_dir():
        raise MissingFileError(
            f"the run {root} was trained on the dataset folder {folder}, which does not exist, and the run "
            f"does not record where its demonstrations started ({TRAINING_DATA}): give the dataset back at "
            "that path and run `libero-bench migrate` on the run, or evaluate from stored starts only (--heldout 0)"
        )
    source = DemoDataset(folder)
    mixed = mixed_seeds(config, root)
    starts: dict[str, tuple[frozenset[int], frozenset[int]]] = {}
    for task in config["tasks"]:
        name = task["name"]
        found = source.training_starts(source.task(name))
        stored, seeds = found if found is not None else (set(), set())
        starts[name] = (frozenset(stored), frozenset(set(seeds) | mixed.get(name, set())))
    named = [str(config["data"]), *(str(d["data"]) for d in config.get("mix", {}).get("datasets", []))]
    datasets = [relative(root, resolve(root, n)) for n in named]
    return TrainingData(tuple(datasets), int(source.sim_state_width), starts)


def run_training_data(root: Path, config: dict[str, Any]) -> TrainingData:
    """The run's record where it has one, else its datasets' (a sentence where they are gone)."""
    return read_training_data(root) or from_datasets(root, config)


def write_training_data(root: Path, config: dict[str, Any]) -> Path:
    """Record ``training_data.json`` in the run folder from its datasets."""
    from libero_data.runtime.files import write_text

    data = from_datasets(root, config)
    return write_text(Path(root) / TRAINING_DATA, json.dumps(data.to_dict(), indent=1) + "\n")


def with_relative_paths(config: dict[str, Any], root: Path) -> dict[str, Any]:
    """``config`` with the paths an older run named absolutely (its dataset, mixed datasets,
    initial checkpoint) named relative to its folder ``root``, as runs name them now."""

    def rel(path: str | None) -> str | None:
        return relative(root, Path(path)) if path and Path(path).is_absolute() else path

    out = {**config, "data": rel(config.get("data"))}
    if "init_checkpoint" in config:
        out["init_checkpoint"] = rel(config["init_checkpoint"])
    if config.get("mix"):
        mix = config["mix"]
        out["mix"] = {**mix, "datasets": [{**d, "data": rel(d["data"])} for d in mix["datasets"]]}
    return out
