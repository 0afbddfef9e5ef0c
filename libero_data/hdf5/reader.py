"""Reading LIBERO's HDF5 demonstration files (the layout LIBERO's ``create_dataset.py`` writes).

One file per task. The ``data`` group's attributes hold the task: ``problem_info`` (JSON with
``problem_name`` and ``language_instruction``), ``bddl_file_name``, ``bddl_file_content``,
``env_args`` (JSON) and ``macros_image_convention``. Each ``data/demo_<i>`` group holds one
demonstration: ``actions`` (T x 7), ``states`` (T x the flattened MuJoCo state), ``obs/*``
(LIBERO's 128x128 images and proprioception), ``rewards``, ``dones``, and the attributes
``model_file`` (the scene's MuJoCo XML, fixtures where they stood) and ``init_state``.

What that script stores, and so what an import reads: it replays the recorded actions, drops
each demonstration's first 5 steps, and stores at index k the state *before* action k next to
the observation *after* it. ``init_state`` is the first kept state (5 steps in), not where the
demonstration began. An import uses the states and actions only (its images are rendered
again from the states, upright), so each frame's image, state and action are the state before
the action, as in every libero-data dataset.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from libero_data.errors import DatasetError, MissingFileError, first_line

#: Steps LIBERO's ``create_dataset.py`` drops at the start of every demonstration.
DROPPED_AT_START = 5
#: The ``data`` attributes an import needs.
REQUIRED_ATTRS = ("problem_info", "bddl_file_name", "bddl_file_content")


@dataclass(frozen=True)
class LiberoDemo:
    """One demonstration of a file: its key, stored states and actions, model XML."""

    key: str
    actions: np.ndarray
    states: np.ndarray
    model_xml: str
    init_state: np.ndarray | None


@dataclass(frozen=True)
class LiberoFile:
    """What a LIBERO demonstration file says about its task, and its demonstrations' keys."""

    path: Path
    problem_name: str
    language: str
    bddl_file_name: str
    bddl_content: str
    image_convention: str
    demo_keys: tuple[str, ...]

    def demo(self, key: str) -> LiberoDemo:
        """Read one demonstration (its arrays, checked)."""
        with _open(self.path) as f:
            return _read_demo(self.path, f["data"], key)


def libero_files(paths: list[Path]) -> list[Path]:
    """The HDF5 files named, a folder standing for every ``*.hdf5`` under it (sorted)."""
    found: list[Path] = []
    for p in paths:
        if p.is_dir():
            inside = sorted(p.rglob("*.hdf5"))
            if not inside:
                raise MissingFileError(f"folder {p} holds no .hdf5 files")
            found.extend(inside)
        elif p.is_file():
            found.append(p)
        else:
            raise MissingFileError(f"{p} does not exist")
    unique = list(dict.fromkeys(q.resolve() for q in found))
    return unique


def read_libero_file(path: Path) -> LiberoFile:
    """The task and demonstration keys of a LIBERO HDF5 file; one sentence if it is not one."""
    with _open(path) as f:
        if "data" not in f:
            raise DatasetError(f"{path} is not a LIBERO demonstration file: it has no 'data' group")
        data = f["data"]
        attrs = data.attrs
        missing = [a for a in REQUIRED_ATTRS if a not in attrs]
        if missing:
            raise DatasetError(
                f"{path} is not a LIBERO demonstration file: data has no attribute {missing[0]!r}"
            )
        try:
            problem = json.loads(_text(attrs["problem_info"]))
        except ValueError as exc:
            raise DatasetError(
                f"{path}: data.attrs['problem_info'] is not JSON ({first_line(exc)})"
            ) from None
        keys = sorted((k for k in data if re.fullmatch(r"demo_\d+", k)), key=lambda k: int(k[5:]))
        if not keys:
            raise DatasetError(f"{path} holds no demonstrations (no data/demo_<i> groups)")
        return LiberoFile(
            path=path,
            problem_name=str(problem.get("problem_name", "")),
            language=str(problem.get("language_instruction", "")),
            bddl_file_name=_text(attrs["bddl_file_name"]),
            bddl_content=_text(attrs["bddl_file_content"]),
            image_convention=_text(attrs.get("macros_image_convention", "unknown")),
            demo_keys=tuple(keys),
        )


def _read_demo(path: Path, data: Any, key: str) -> LiberoDemo:
    if key not in data:
        raise DatasetError(f"{path} has no demonstration {key!r}")
    group = data[key]
    for name in ("actions", "states"):
        if name not in group:
            raise DatasetError(f"{path}, {key}: no {name!r} dataset")
    try:
        actions = np.asarray(group["actions"][()], dtype=np.float64)
        states = np.asarray(group["states"][()], dtype=np.float64)
    except (OSError, ValueError, KeyError) as exc:
        raise DatasetError(
            f"{path}, {key}: cannot be read ({first_line(exc)}); is the file truncated?"
        ) from None
    if actions.ndim != 2 or actions.shape[1] != 7:
        raise DatasetError(f"{path}, {key}: actions are {actions.shape}, not T x 7")
    if states.ndim != 2 or len(states) != len(actions):
        raise DatasetError(f"{path}, {key}: {len(states)} states for {len(actions)} actions")
    if len(actions) < 2:
        raise DatasetError(f"{path}, {key}: {len(actions)} steps, too short to be a demonstration")
    if not (np.all(np.isfinite(actions)) and np.all(np.isfinite(states))):
        raise DatasetError(f"{path}, {key}: actions or states hold NaN or infinite values")
    if "model_file" not in group.attrs:
        raise DatasetError(f"{path}, {key}: no 'model_file' attribute (the scene's MuJoCo XML)")
    init = group.attrs.get("init_state")
    return LiberoDemo(
        key=key,
        actions=actions,
        states=states,
        model_xml=_text(group.attrs["model_file"]),
        init_state=None if init is None else np.asarray(init, dtype=np.float64).reshape(-1),
    )


class _open:
    """``h5py.File(path, 'r')`` whose failures are one sentence naming the file."""

    def __init__(self, path: Path) -> None:
        self.path = path

    def __enter__(self) -> Any:
        import h5py

        try:
            self.file = h5py.File(self.path, "r")
        except FileNotFoundError:
            raise MissingFileError(f"{self.path} does not exist") from None
        except OSError as exc:
            raise DatasetError(
                f"{self.path} is not a readable HDF5 file ({first_line(exc)}); is it truncated or of another format?"
            ) from None
        return self.file

    def __exit__(self, *exc: object) -> None:
        self.file.close()


def _text(value: Any) -> str:
    if isinstance(value, bytes):
        return value.decode("utf-8")
    if isinstance(value, np.ndarray) and value.shape == ():
        return _text(value[()])
    return str(value)
