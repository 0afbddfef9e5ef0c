"""Bringing a run folder of an earlier libero-bench version up to date: its pickled checkpoints
converted to safetensors, and the record of where its demonstrations started
(:mod:`libero_bench.runs.training_data`) written while its datasets are still there.

Before checkpoints were safetensors (:mod:`libero_bench.runs.state_files`), a run folder kept
``checkpoints/task_NNN.pt`` and ``task_NNN.epoch.pt`` written by ``torch.save``. Those are
pickles. They are read here, and only here, with torch's restricted loader
(``weights_only=True``): it builds tensors, numbers, strings and containers, plus the NumPy
arrays and dtypes our random-stream states hold, and refuses every other global, so a pickle
that would run code is refused rather than run. Even so it parses a pickle: the command says so,
and converts only what it is pointed at.
"""

from __future__ import annotations

import logging
import re
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from libero_bench.runs.folder import CHECKPOINTS, RUN_FORMAT, RunFolder
from libero_bench.runs.saved_policy import CHECKPOINT, EPOCH_STATE
from libero_bench.runs.state_files import SUFFIX, load_state, load_weights, save_state
from libero_bench.runs.training_data import TRAINING_DATA, resolve, write_training_data
from libero_data.errors import CheckpointError, MissingFileError

logger = logging.getLogger(__name__)

WARNING = (
    "these were pickles, read with torch's restricted loader (weights_only=True: tensors, numbers, "
    "strings and NumPy arrays only); convert only files you trust"
)


@dataclass(frozen=True)
class Converted:
    """One pickled file and the safetensors file that replaced it."""

    source: Path
    target: Path
    kind: str


def migrate(path: Path, out: Path | None = None) -> list[Converted]:
    """Bring a run folder up to date (each pickled ``.pt`` replaced by its ``.safetensors``; its
    ``training_data.json`` recorded from its datasets) or convert one pickled checkpoint or state
    dict (to ``out``, default: beside it)."""
    path = Path(path)
    if path.is_dir():
        if out is not None:
            raise CheckpointError(
                f"{path} is a run folder: its checkpoints are converted in place, without --out"
            )
        pickled = sorted((path / CHECKPOINTS).glob("*.pt"))
        recorded = (path / TRAINING_DATA).is_file()
        if not pickled and recorded:
            raise MissingFileError(
                f"{path / CHECKPOINTS} holds no pickled checkpoints (*.pt) to convert and the run records "
                f"its training data ({TRAINING_DATA}) already: nothing to migrate"
            )
        done = [_convert(p, p.with_name(p.name[: -len(".pt")] + SUFFIX), remove=True) for p in pickled]
        if not recorded:  # a run from before runs recorded where their demonstrations started
            config = RunFolder(path).read_config()
            try:
                written = write_training_data(path, config)
            except MissingFileError:
                if not done:
                    raise  # its datasets are gone and there was nothing else to do: say so
            else:
                done.append(Converted(resolve(path, str(config["data"])), written, "training data"))
        return done
    if not path.is_file():
        raise MissingFileError(f"{path} does not exist")
    target = out if out is not None else path.with_suffix(SUFFIX)
    if target.exists():
        raise CheckpointError(f"{target} exists already; choose another --out")
    return [_convert(path, target, remove=False)]


def read_torch_save(path: Path) -> Any:
    """A ``torch.save`` file's content, read with the restricted loader and NumPy's array globals."""
    import importlib
    import pickle

    import numpy as np
    import torch

    reconstruct = importlib.import_module("numpy._core.multiarray")._reconstruct
    array_globals: list[Any] = [
        reconstruct,
        (reconstruct, "numpy.core.multiarray._reconstruct"),  # pickles made with NumPy 1.x
        np.ndarray,
        np.dtype,
        *(type(np.dtype(t)) for t in (np.uint8, np.uint32, np.int64, np.float32, np.float64, np.bool_)),
    ]
    try:
        with torch.serialization.safe_globals(array_globals), warnings.catch_warnings():
            warnings.simplefilter("ignore")  # torch's note on pickle protocols: the refusal says enough
            return torch.load(path, map_location="cpu", weights_only=True)
    except (pickle.UnpicklingError, RuntimeError, EOFError, ValueError) as exc:
        text = str(exc)
        found = re.search(r"GLOBAL ([\w.]+)", text)
        # torch's message: boilerplate, then the reason, then a pointer to its documentation
        parts = [
            p.strip() for p in text.split("\n\n")[1:] if p.strip() and not p.strip().startswith("Check the")
        ]
        detail = " ".join(" ".join(parts).split())[:200] or type(exc).__name__
        why = f"it would call {found.group(1)}" if found else detail
        raise CheckpointError(
            f"{path} cannot be read as a checkpoint of tensors, numbers and arrays ({why}); it was not converted"
        ) from None


def _convert(source: Path, target: Path, *, remove: bool) -> Converted:
    data = read_torch_save(source)
    if isinstance(data, dict) and data.get("format") == RUN_FORMAT:
        kind = EPOCH_STATE if "positions" in data else CHECKPOINT
        save_state(target, data, kind=kind)
        load_state(target, kind=kind)  # it reads back before the pickle goes
    elif isinstance(data, dict) and data and all(_is_tensor(v) for v in data.values()):
        from safetensors.torch import save

        from libero_data.runtime.files import write_bytes

        kind = "weights"
        write_bytes(target, save({str(k): v.contiguous().clone() for k, v in data.items()}))
        load_weights(target)
    else:
        raise CheckpointError(
            f"{source} is neither a libero-bench checkpoint nor a state dict of tensors; it was not converted"
        )
    if remove:
        source.unlink()
    logger.info("converted %s to %s", source, target)
    return Converted(source, target, kind)


def _is_tensor(value: Any) -> bool:
    import torch

    return isinstance(value, torch.Tensor)
