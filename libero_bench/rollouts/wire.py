"""openpi's policy-server messages: msgpack with NumPy arrays, nothing that runs code.

The websocket protocol of openpi's ``WebsocketPolicyServer`` (and its ``openpi-client``), which
openpi's own LIBERO evaluation speaks and many VLA code bases copy:

- the connection is a plain websocket, binary frames, no compression;
- on connect the server sends one message: its *metadata* (a dict, possibly empty);
- each request is one observation, a dict (``observation/image``, ``observation/wrist_image``,
  ``observation/state``, ``prompt``, ...); each reply is a dict holding ``actions``, a chunk
  (H, action dim), and usually ``server_timing``;
- a reply that is a text frame instead is the server's traceback: the request failed.

NumPy arrays travel as maps ``{b"__ndarray__": True, b"data": bytes, b"dtype": dtype.str,
b"shape": shape}`` and NumPy scalars as ``{b"__npgeneric__": True, b"data": value, b"dtype": ...}``;
object, void and complex arrays are refused. Decoding builds arrays from bytes only: no pickle.

openpi's own package, ``openpi-client`` (PyPI 0.1.2), carries this format (``msgpack_numpy``), but
it pins ``numpy<2`` and pulls in ``dm-tree``: it cannot be installed beside this project's NumPy 2.
So the format is written here, and tested against the package itself, byte for byte both ways
(``tests/bench/test_openpi_client.py`` loads its module from its wheel). Beyond it, decoding here
refuses object/void/complex dtypes itself and returns writable copies.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from libero_data.errors import InputError

_REFUSED_KINDS = ("O", "V", "c")


def _encode(obj: Any) -> Any:
    if isinstance(obj, np.ndarray | np.generic) and obj.dtype.kind in _REFUSED_KINDS:
        raise InputError(f"arrays of dtype {obj.dtype} cannot be sent to a policy server")
    if isinstance(obj, np.ndarray):
        return {b"__ndarray__": True, b"data": obj.tobytes(), b"dtype": obj.dtype.str, b"shape": obj.shape}
    if isinstance(obj, np.generic):
        return {b"__npgeneric__": True, b"data": obj.item(), b"dtype": obj.dtype.str}
    return obj


def _decode(obj: dict[Any, Any]) -> Any:
    if b"__ndarray__" in obj:
        dtype = np.dtype(obj[b"dtype"])
        if dtype.kind in _REFUSED_KINDS:
            raise InputError(f"a policy server sent an array of dtype {dtype}, which is refused")
        return np.frombuffer(obj[b"data"], dtype=dtype).reshape(obj[b"shape"]).copy()
    if b"__npgeneric__" in obj:
        return np.dtype(obj[b"dtype"]).type(obj[b"data"])
    return obj


def pack(message: Any) -> bytes:
    """A message (dicts, lists, numbers, strings, NumPy arrays) as msgpack bytes."""
    import msgpack

    data: bytes = msgpack.packb(message, default=_encode, use_bin_type=True)
    return data


def unpack(data: bytes) -> Any:
    """A message from msgpack bytes (arrays come back as NumPy arrays)."""
    import msgpack

    return msgpack.unpackb(data, object_hook=_decode, raw=False, strict_map_key=False)
