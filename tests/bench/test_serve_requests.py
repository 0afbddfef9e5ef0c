"""``libero-bench serve`` on a network (issue 75): every request it cannot serve is answered with one
sentence naming the entry and what it must be, never a traceback or a path; an unexpected failure
is one sentence with an id that the server's log holds in full; a message over the size bound
closes its connection unread; the policy is warmed up before the server listens; and the server
answers a valid request after every bad one, and dozens of clients at once."""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import msgpack
import numpy as np
import pytest
from bench_helpers import on_loopback

import libero_bench
from libero_bench.rollouts.actors import BatchActor, Start
from libero_bench.rollouts.remote import connect
from libero_bench.rollouts.server import PolicyServer
from libero_bench.rollouts.wire import pack, unpack

#: Substrings no reply may carry: a traceback, the server's files.
LEAKS = ("Traceback", 'File "', ".py", "site-packages", str(Path(libero_bench.__file__).parents[1]))


class Chunks(BatchActor):
    """A policy that answers a chunk of 5 zero actions, counting its passes; ``fail``: it raises."""

    chunk_size = 5

    def __init__(self, fail: bool = False) -> None:
        super().__init__()
        self.fail = fail
        self.slots: list[int] = []
        self.passes = 0  # every forward pass, the warm-up's too

    def begin(self, slot: int, start: Start) -> None:
        self.slots.append(slot)

    def act(self, observations: Any) -> dict[int, np.ndarray]:
        return {s: c[0] for s, c in self.act_chunks(observations).items()}

    def act_chunks(self, observations: Any) -> dict[int, np.ndarray]:
        if self.fail:
            raise RuntimeError("the model's weights are on fire")
        self.passes += 1
        self.forwards += 1
        self.rows += len(observations)
        return {slot: np.zeros((5, 7)) for slot in observations}


def valid() -> dict[str, Any]:
    return {
        "observation/image": np.zeros((224, 224, 3), np.uint8),
        "observation/wrist_image": np.zeros((224, 224, 3), np.uint8),
        "observation/state": np.zeros(8),
        "prompt": "put the bowl on the plate",
    }


def ask(port: int, message: bytes | str) -> Any:
    """``message`` on a connection of its own: the reply (a dict, or the text of a refusal)."""
    connection, _metadata = connect(f"ws://127.0.0.1:{port}", timeout=30)
    try:
        connection.send(message)
        reply = connection.recv(timeout=30)
    finally:
        connection.close()
    return reply if isinstance(reply, str) else unpack(reply)


def entry(**changes: Any) -> bytes:
    request = valid()
    for key, value in changes.items():
        name = {
            "image": "observation/image",
            "wrist": "observation/wrist_image",
            "state": "observation/state",
        }
        request[name.get(key, key)] = value
    return pack(request)


#: The corpus: a bad request, and what its one sentence must say.
BAD = {
    "not msgpack": (b"\xc1\xc1 these bytes are not msgpack", "not openpi's msgpack"),
    "text frame": ("hello", "binary msgpack"),
    "not a map": (pack([1, 2, 3]), "map of observation entries"),
    "no image": (
        pack({k: v for k, v in valid().items() if k != "observation/image"}),
        "lacks observation/image",
    ),
    "image as a string": (entry(image="a picture"), "observation/image must be a uint8 image"),
    "four channels": (entry(image=np.zeros((224, 224, 4), np.uint8)), "not an array of uint8 (224, 224, 4)"),
    "one pixel": (entry(wrist=np.zeros((1, 1, 3), np.uint8)), "sides of 16 to 1024 px"),
    "1500 px": (entry(image=np.zeros((1500, 1500, 3), np.uint8)), "not an array of uint8 (1500, 1500, 3)"),
    "float image of NaN": (entry(image=np.full((224, 224, 3), np.nan, np.float32)), "float32"),
    "state too short": (entry(state=np.zeros(7)), "observation/state must be 8 numbers"),
    "state of NaN": (entry(state=np.full(8, np.nan)), "observation/state must be finite"),
    "state as text": (entry(state="0 0 0"), "observation/state must be 8 numbers, not a str"),
    "prompt a number": (entry(prompt=42), "prompt must be a string"),
    "prompt too long": (entry(prompt="x" * 5000), "at most 1000 characters"),
    "unknown control": (
        pack({"__ctrl__": "reboot"}),
        "__ctrl__ must be 'episode_start' or 'episode_end', not 'reboot'",
    ),
    "forged array": (
        msgpack.packb({b"__ndarray__": True, b"data": b"", b"dtype": "|O", b"shape": (0,)}),
        "refused",
    ),
    "array of the wrong size": (
        msgpack.packb({b"__ndarray__": True, b"data": b"abc", b"dtype": "<f8", b"shape": (8,)}),
        "not openpi's msgpack",
    ),
}


def test_every_bad_request_gets_its_sentence_and_the_server_answers_the_next(
    caplog: pytest.LogCaptureFixture,
) -> None:
    caplog.set_level(logging.INFO, logger="libero_bench.rollouts.server")
    server = PolicyServer(Chunks(), {"policy_type": "chunks"})
    with on_loopback(server) as port:
        for name, (message, says) in BAD.items():
            reply = ask(port, message)
            assert isinstance(reply, str), f"{name}: served as if valid ({reply})"
            assert says in reply, f"{name}: {reply!r}"
            assert "\n" not in reply and not any(leak in reply for leak in LEAKS), f"{name}: {reply!r}"
            assert ask(port, pack(valid()))["actions"].shape == (5, 7), f"after {name}"
    refusals = [r for r in caplog.records if "refused a request" in r.getMessage()]
    assert len(refusals) == len(BAD)
    assert sum(r.getMessage().endswith(" connected") for r in caplog.records) == 2 * len(BAD)
    assert sum(
        "disconnected after 0 request(s) served, 1 refused" in r.getMessage() for r in caplog.records
    ) == len(BAD)


def test_an_unexpected_failure_is_one_sentence_with_an_id_the_log_holds_in_full(
    caplog: pytest.LogCaptureFixture,
) -> None:
    caplog.set_level(logging.INFO, logger="libero_bench.rollouts.server")
    failing = Chunks()
    server = PolicyServer(failing, {"policy_type": "chunks"})
    with on_loopback(server) as port:
        failing.fail = True  # after the warm-up
        reply = ask(port, pack(valid()))
        failing.fail = False
        assert ask(port, pack(valid()))["actions"].shape == (5, 7)
    assert isinstance(reply, str) and reply.startswith("InternalError:") and "\n" not in reply
    assert not any(leak in reply for leak in LEAKS) and "on fire" not in reply
    ident = reply.split("error ")[1].split(";")[0]
    logged = [r for r in caplog.records if ident in r.getMessage()]
    assert len(logged) == 1 and logged[0].exc_info is not None
    assert "on fire" in str(logged[0].exc_info[1])


def test_a_message_over_the_bound_closes_its_connection_unread(caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.INFO, logger="libero_bench.rollouts.server")
    server = PolicyServer(Chunks(), {"policy_type": "chunks"}, max_message_bytes=1024 * 1024)
    big = entry(image=np.zeros((1024, 1024, 3), np.uint8))  # 3 MiB
    with on_loopback(server) as port:
        connection, _ = connect(f"ws://127.0.0.1:{port}", timeout=30)
        connection.send(big)
        from websockets.exceptions import ConnectionClosed

        with pytest.raises(ConnectionClosed) as closed:
            connection.recv(timeout=30)
        assert closed.value.rcvd is not None and closed.value.rcvd.code == 1009
        assert ask(port, pack(valid()))["actions"].shape == (5, 7)
    assert any("over 1048576 bytes" in r.getMessage() for r in caplog.records)
    # Two 512 px images and the rest fit the default bound.
    two = entry(image=np.zeros((512, 512, 3), np.uint8), wrist=np.zeros((512, 512, 3), np.uint8))
    assert len(two) < PolicyServer(Chunks(), {}).max_message_bytes / 4


def test_the_policy_is_warmed_up_before_the_server_listens() -> None:
    actor = Chunks()
    server = PolicyServer(actor, {"policy_type": "chunks", "image_size": 64})
    with on_loopback(server) as port:  # yields once the server listens
        assert actor.slots == [-1] and actor.passes == 1  # the warm-up's pass, before any client
        assert ask(port, pack(valid()))["actions"].shape == (5, 7)
    assert actor.passes == 2 and actor.forwards == 1  # the warm-up's pass is not counted as a client's


def _rss_mib() -> float:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    raise AssertionError("no VmRSS in /proc/self/status")


def test_dozens_of_clients_at_once_are_all_answered_and_memory_stays_steady() -> None:
    """24 clients x 5 requests at once, four rounds (a bounded load: 480 requests of 0.3 MB, each
    answered within the client's 60 s): every request answered, batched across connections, and the
    server's memory (this process's: it runs in a thread here) flat after the first round."""
    from concurrent.futures import ThreadPoolExecutor

    actor = Chunks()
    server = PolicyServer(actor, {"policy_type": "chunks"})
    clients, requests, rounds = 24, 5, 4
    with on_loopback(server) as port:

        def client(i: int) -> int:
            connection, _ = connect(f"ws://127.0.0.1:{port}", timeout=30)
            answered = 0
            try:
                for _ in range(requests):
                    connection.send(pack(valid()))
                    answered += unpack(connection.recv(timeout=60))["actions"].shape == (5, 7)
            finally:
                connection.close()
            return answered

        resident = []
        with ThreadPoolExecutor(clients) as pool:
            for _ in range(rounds):
                assert list(pool.map(client, range(clients))) == [requests] * clients
                resident.append(_rss_mib())
    assert actor.rows == clients * requests * rounds and actor.forwards < actor.rows  # batched
    assert resident[-1] - resident[0] < 20, f"resident memory by round (MiB): {resident}"
