"""Checkpoints and training states stored so that opening one runs no code.

One safetensors file holds every tensor and NumPy array of a state; its header's metadata holds
the state's structure as JSON (dicts with their key types, lists, tuples, numbers, strings, and
which stored tensor sits where). Loading parses the header's JSON and builds tensors from
bytes: nothing is unpickled, whoever made the file.

Pickled torch checkpoints (``torch.save``: an earlier libero-bench's ``.pt`` files, or another
tool's) are recognised by their first bytes and refused with one sentence;
:mod:`libero_bench.runs.migrate` converts the ones a user trusts.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from libero_data.errors import CheckpointError, first_line
from libero_data.runtime.files import write_bytes

if TYPE_CHECKING:
    import torch

#: The header's metadata keys.
KIND_KEY, TREE_KEY = "libero_bench_kind", "libero_bench_tree"
SUFFIX = ".safetensors"
#: A torch.save file is a zip archive (PK..) or, in the legacy format, a pickle (0x80, protocol).
_ZIP, _PICKLE = b"PK\x03\x04", b"\x80"
MIGRATE_HINT = (
    "pickled files can run code when opened, so libero-bench does not open them; "
    "convert a run folder or checkpoint you trust with `libero-bench migrate PATH`"
)


def is_pickle(path: Path) -> bool:
    """Whether ``path`` starts like a ``torch.save`` file or a pickle. A safetensors file starts
    with its header's length (8 bytes, little-endian, whose first byte may be 0x80 too) and then
    the header's ``{``: that is never taken for a pickle."""
    try:
        with Path(path).open("rb") as f:
            head = f.read(9)
    except OSError:
        return False
    if head[8:9] == b"{":
        return False
    return head[:4] == _ZIP or head[:1] == _PICKLE


def save_state(path: Path, state: Any, *, kind: str) -> Path:
    """Write ``state`` (dicts, lists, tuples, numbers, strings, tensors, arrays) atomically."""
    from safetensors.torch import save

    tensors: dict[str, torch.Tensor] = {}
    tree = _encode(state, tensors)
    metadata = {KIND_KEY: kind, TREE_KEY: json.dumps(tree, separators=(",", ":"), allow_nan=False)}
    return write_bytes(path, canonical_header(save(tensors, metadata=metadata)))


def canonical_header(blob: bytes) -> bytes:
    """``blob`` (a safetensors file) with its header's keys in sorted order: safetensors writes
    the metadata from a hash map, whose order changes from one process to the next, so the same
    state gave other bytes. Offsets count from the data, which stays as it is."""
    size = int.from_bytes(blob[:8], "little")
    header = json.loads(blob[8 : 8 + size])
    ordered: dict[str, Any] = {}
    if "__metadata__" in header:
        ordered["__metadata__"] = dict(sorted(header.pop("__metadata__").items()))
    ordered.update(sorted(header.items()))
    text = json.dumps(ordered, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 8)  # the data starts 8-byte aligned, as safetensors pads it
    return len(text).to_bytes(8, "little") + text + blob[8 + size :]


def load_state(path: Path, *, kind: str, device: str = "cpu") -> Any:
    """The state :func:`save_state` wrote as ``kind``; one sentence for anything else."""
    from safetensors import SafetensorError, safe_open

    path = Path(path)
    if not path.is_file():
        raise CheckpointError(f"the checkpoint {path} does not exist")
    if is_pickle(path):
        raise CheckpointError(f"{path} is a pickled torch checkpoint; {MIGRATE_HINT}")
    try:
        with safe_open(str(path), framework="pt", device=device) as f:
            metadata = f.metadata() or {}
            tensors = {name: f.get_tensor(name) for name in f.keys()}  # noqa: SIM118 (not a dict)
    except (SafetensorError, OSError, ValueError) as exc:
        raise CheckpointError(f"{path} is not a safetensors file ({first_line(exc)})") from None
    found = metadata.get(KIND_KEY)
    if found != kind:
        what = f"a {found}" if found else "bare weights"
        raise CheckpointError(f"{path} holds {what}, not a {kind}")
    try:
        return _decode(json.loads(metadata[TREE_KEY]), tensors)
    except (KeyError, TypeError, ValueError, json.JSONDecodeError) as exc:
        raise CheckpointError(f"{path} has a damaged {kind} header ({first_line(exc)})") from None


def load_weights(path: Path, *, device: str = "cpu") -> dict[str, torch.Tensor]:
    """A policy's weights: a libero-bench checkpoint's ``policy``, or a bare safetensors state
    dict (LeRobot's ``model.safetensors``, anyone's ``save_file``)."""
    from safetensors import SafetensorError, safe_open

    path = Path(path)
    if is_pickle(path):
        raise CheckpointError(f"{path} is a pickled torch checkpoint; {MIGRATE_HINT}")
    try:
        with safe_open(str(path), framework="pt", device=device) as f:
            kind = (f.metadata() or {}).get(KIND_KEY)
            if kind is None:
                return {name: f.get_tensor(name) for name in f.keys()}  # noqa: SIM118
    except (SafetensorError, OSError, ValueError) as exc:
        raise CheckpointError(f"{path} is not a safetensors file ({first_line(exc)})") from None
    state = load_state(path, kind=kind, device=device)
    weights = state.get("policy") if isinstance(state, dict) else None
    if not isinstance(weights, dict):
        raise CheckpointError(f"{path} is a {kind} without policy weights")
    return weights


# -- the structure as JSON ---------------------------------------------------------------------------
def _encode(value: Any, tensors: dict[str, Any]) -> Any:
    import torch

    if value is None or isinstance(value, (bool, str)):
        return value
    if isinstance(value, (int, np.integer)) and not isinstance(value, np.bool_):
        return int(value)
    if isinstance(value, (float, np.floating)):
        value = float(value)
        return value if math.isfinite(value) else {"$float": repr(value)}
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, torch.Tensor):
        name = f"t{len(tensors)}"
        tensors[name] = value.detach().to("cpu").contiguous().clone()
        return {"$tensor": name}
    if isinstance(value, np.ndarray):
        if value.dtype.hasobject or value.dtype.kind not in "biufc":
            raise TypeError(f"arrays of {value.dtype} cannot be stored")
        name = f"t{len(tensors)}"
        raw = np.ascontiguousarray(value).view(np.uint8).reshape(-1)
        tensors[name] = torch.from_numpy(raw.copy())
        return {"$array": name, "dtype": value.dtype.str, "shape": list(value.shape)}
    if isinstance(value, dict):
        return {"$dict": [[_encode(k, tensors), _encode(v, tensors)] for k, v in value.items()]}
    if isinstance(value, tuple):
        return {"$tuple": [_encode(v, tensors) for v in value]}
    if isinstance(value, list):
        return {"$list": [_encode(v, tensors) for v in value]}
    raise TypeError(f"a {type(value).__name__} cannot be stored in a checkpoint")


def _decode(node: Any, tensors: dict[str, Any]) -> Any:
    if node is None or isinstance(node, (bool, int, float, str)):
        return node
    if not isinstance(node, dict) or len(node) not in (1, 3):
        raise ValueError(f"unexpected node {str(node)[:60]}")
    if "$tensor" in node:
        return tensors[node["$tensor"]]
    if "$array" in node:
        dtype = np.dtype(node["dtype"])
        if dtype.hasobject or dtype.kind not in "biufc":
            raise ValueError(f"arrays of {dtype} are not stored here")
        raw = tensors[node["$array"]].numpy()
        return raw.view(dtype).reshape([int(n) for n in node["shape"]]).copy()
    if "$float" in node:
        return float(node["$float"])
    if "$dict" in node:
        return {_decode(k, tensors): _decode(v, tensors) for k, v in node["$dict"]}
    if "$tuple" in node:
        return tuple(_decode(v, tensors) for v in node["$tuple"])
    if "$list" in node:
        return [_decode(v, tensors) for v in node["$list"]]
    raise ValueError(f"unexpected node {str(node)[:60]}")
