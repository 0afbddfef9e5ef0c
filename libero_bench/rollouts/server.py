"""``libero-bench serve``: our policies and LeRobot's behind openpi's websocket protocol.

A GPU machine serves while CPU machines roll out (``libero-bench eval --server``), or any client
that speaks openpi's protocol (:mod:`~libero_bench.rollouts.wire`), openpi's own LIBERO client
among them, acts with the policy. Requests that arrive together, from any number of connections,
go through one batched forward pass. Two kinds of client:

- **openpi's** (its LIBERO client, and ``libero-bench eval --protocol standard --server``): one
  connection for many episodes, each framed by ``episode_start`` / ``episode_end`` control
  messages (acknowledged ``{"__ack__": ...}`` as openpi's server does; an episode boundary resets
  the policy's history), requests of openpi's four entries. The reply holds the policy's action
  chunk (``{"actions": (H, 7), "server_timing": {...}}``). A policy that predicts one action per
  step is refused in one sentence (openpi's loop executes 5 of each chunk), as is a request that
  lacks an entry the policy reads beyond openpi's four (our runs' policies read the arm joints);
  the metadata sent at connection says both (``action_horizon``, ``needs``).
- **libero-bench's** (``libero-bench eval --server`` under its default protocol; its requests
  carry ``rollout_key``): each connection is one episode, and each reply is the one action the
  policy takes now (``(1, 7)``), so a client that executes every action it gets acts exactly as
  the policy does in a local evaluation.

Requests are read by :func:`~libero_bench.rollouts.observations.environment_observation`; a
request that cannot be served gets a text reply (openpi's way of sending an error: one sentence,
or the traceback of an unexpected failure), and the connection stays open.
"""

from __future__ import annotations

import asyncio
import itertools
import logging
import time
import uuid
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from libero_bench.rollouts.actors import BatchActor, Start
from libero_bench.rollouts.observations import (
    EXTRA_ENTRIES,
    OPENPI_KEYS,
    environment_observation,
    extra_needs,
)
from libero_bench.rollouts.remote import ACK, CONTROL, EPISODE_END, EPISODE_START
from libero_bench.rollouts.wire import pack, unpack
from libero_data.errors import InputError, LiberoDataError

log = logging.getLogger(__name__)

#: The largest message (bytes) a server reads by default: two 512 px images and the rest with
#: room (openpi's request at 224 px is ~0.3 MB); a larger one closes its connection unread (1009).
MAX_MESSAGE_BYTES = 8 * 1024 * 1024


@dataclass
class Pending:
    """A request waiting for the next batch; ``chunk``: the client executes chunks (openpi's)."""

    slot: int
    observation: dict[str, Any]
    prompt: str
    key: str
    chunk: bool
    reply: asyncio.Future[Any]


class PolicyServer:
    """A :class:`~libero_bench.rollouts.actors.BatchActor` behind openpi's websocket protocol (see
    the module docstring).

    ``embed`` turns a prompt into the task embedding libero-bench's policies read (None for
    policies that read the instruction itself); ``image_size`` is the camera size the policy
    reads (images of another size are resized with padding); ``needs`` are the observations it
    reads beyond openpi's four entries."""

    def __init__(
        self,
        actor: BatchActor,
        metadata: dict[str, Any],
        *,
        embed: Callable[[str], np.ndarray] | None = None,
        image_size: int | None = None,
        needs: tuple[str, ...] = (),
        gather_s: float = 0.002,
        max_message_bytes: int = MAX_MESSAGE_BYTES,
    ) -> None:
        self.actor = actor
        self.embed = embed
        self.image_size = image_size
        self.needs = needs
        self.metadata = {
            **metadata,
            "action_horizon": int(actor.chunk_size),
            "inputs": [*OPENPI_KEYS, *(EXTRA_ENTRIES[k] for k in needs)],
        }
        if needs:
            self.metadata["needs"] = (
                f"this policy also reads {', '.join(EXTRA_ENTRIES[k] for k in needs)}, beyond openpi's LIBERO "
                "request; requests without it are refused"
            )
        self.gather_s = gather_s
        self.max_message_bytes = max_message_bytes
        self._ids = itertools.count()
        self._pending: list[Pending] = []
        self._ended: list[int] = []
        self._begun: set[int] = set()
        self._wake: asyncio.Event | None = None
        self.batches: list[int] = []  # the size of every batch served

    async def handler(self, websocket: Any) -> None:
        from websockets.exceptions import ConnectionClosed

        assert self._wake is not None
        slot = next(self._ids)  # one episode's history: a new one at each episode_start
        loop = asyncio.get_running_loop()
        peer = _peer(websocket)
        served = refused = 0
        per_step = False  # the client executes one action of each chunk (its episode_start says)
        log.info("%s connected", peer)
        try:
            await websocket.send(pack(self.metadata))
            async for message in websocket:
                try:
                    request = _request(message)
                    if isinstance(request, dict) and CONTROL in request:
                        kind = request[CONTROL]
                        if kind not in (EPISODE_START, EPISODE_END):
                            raise InputError(
                                f"{CONTROL} must be {EPISODE_START!r} or {EPISODE_END!r}, not {kind!r}"
                            )
                        self._ended.append(slot)  # the episode's history goes with it
                        slot = next(self._ids)
                        if kind == EPISODE_START:
                            # libero-bench eval --replan-steps 1 says so: it asks at every step
                            per_step = request.get("__replan_steps__") == 1
                        await websocket.send(pack({ACK: kind}))
                        continue
                    obs, prompt, key = environment_observation(request, self.image_size, self.needs)
                    chunk = key is None  # openpi's client: no rollout key, chunks executed
                    if chunk and self.actor.chunk_size < 2 and not per_step:
                        raise InputError(
                            "this policy predicts one action per step, and openpi's LIBERO client executes 5 "
                            "of each chunk; evaluate it with libero-bench eval --server URL --protocol standard "
                            "--replan-steps 1 (asked at every step), or locally with --protocol standard"
                        )
                except (InputError, LiberoDataError) as exc:
                    refused += 1
                    log.warning("%s: refused a request: %s", peer, exc)
                    await websocket.send(f"{type(exc).__name__}: {exc}")
                    continue
                except Exception:
                    refused += 1
                    await websocket.send(_internal_error(f"reading a request from {peer}"))
                    continue
                pending = Pending(slot, obs, prompt, key or f"connection-{slot}", chunk, loop.create_future())
                self._pending.append(pending)
                self._wake.set()
                await websocket.send(await pending.reply)
                served += 1
        except ConnectionClosed as exc:
            if exc.sent is not None and exc.sent.code == 1009:  # websockets' reply to a message too big
                log.warning(
                    "%s: refused a message over %d bytes (--max-message-mb)", peer, self.max_message_bytes
                )
        finally:
            self._ended.append(slot)
            log.info("%s disconnected after %d request(s) served, %d refused", peer, served, refused)

    async def batcher(self) -> None:
        """Serve the waiting requests, all that arrived together in one pass."""
        assert self._wake is not None
        while True:
            await self._wake.wait()
            count, rounds = -1, 0
            while count != len(self._pending) and rounds < 25:  # gather: until none came for gather_s
                count, rounds = len(self._pending), rounds + 1
                await asyncio.sleep(self.gather_s)
            self._wake.clear()
            batch, self._pending = self._pending, []
            if not batch:
                continue
            started = time.perf_counter()
            try:
                chunks = await asyncio.to_thread(self._infer, batch)
            except Exception:
                text = _internal_error(f"a forward pass of {len(batch)} request(s)")
                for p in batch:
                    p.reply.set_result(text)
                continue
            infer_ms = (time.perf_counter() - started) * 1000
            self.batches.append(len(batch))
            for p in batch:
                reply = {"actions": chunks[p.slot], "server_timing": {"infer_ms": infer_ms}}
                p.reply.set_result(pack(reply))

    def _infer(self, batch: list[Pending]) -> dict[int, np.ndarray]:
        """Runs in a thread, one batch at a time: every call on the actor happens here. A client
        that executes chunks gets the whole chunk; libero-bench's gets the one action taken now."""
        ended, self._ended = self._ended, []
        for slot in ended:
            if slot in self._begun:
                self._begun.discard(slot)
                self.actor.end(slot)
        for p in batch:
            if p.slot not in self._begun:
                emb = self.embed(p.prompt) if self.embed is not None else None
                self.actor.begin(p.slot, Start(p.key, p.prompt, emb))
                self._begun.add(p.slot)
        out: dict[int, np.ndarray] = {}
        chunked = {p.slot: p.observation for p in batch if p.chunk}
        single = {p.slot: p.observation for p in batch if not p.chunk}
        if chunked:
            out.update(self.actor.act_chunks(chunked))
        if single:
            out.update({slot: np.asarray(a)[None] for slot, a in self.actor.act(single).items()})
        return out

    def warm_up(self) -> float:
        """One forward pass on a blank observation before the first client's (the first pass
        builds kernels and caches: 12 s for a run's policy on a CPU, on a client's time before);
        the seconds it took."""
        size = self.image_size or int(self.metadata.get("image_size") or 224)
        image = np.zeros((size, size, 3), dtype=np.uint8)
        obs = {
            "agentview": image,
            "eye_in_hand": image,
            "state": np.zeros(8, dtype=np.float32),
            "joint_pos": np.zeros(7, dtype=np.float32),
            "gripper_state": np.zeros(2, dtype=np.float32),
        }
        started = time.perf_counter()
        slot = -1  # no client's: their slots count up from 0
        prompt = "warm up"
        self.actor.begin(
            slot, Start("warm-up", prompt, self.embed(prompt) if self.embed is not None else None)
        )
        try:
            if self.actor.chunk_size >= 2:
                self.actor.act_chunks({slot: obs})
            else:
                self.actor.act({slot: obs})
        finally:
            self.actor.end(slot)
        self.actor.forwards, self.actor.rows = 0, 0
        seconds = time.perf_counter() - started
        log.info("warmed up in %.1f s", seconds)
        return seconds

    async def serve(self, host: str, port: int, ready: Callable[[int], None] | None = None) -> None:
        """Serve until cancelled; ``ready`` gets the port listened on (``port`` 0: one the system chose)."""
        from websockets.asyncio.server import serve

        self._wake = asyncio.Event()
        await asyncio.to_thread(self.warm_up)
        batcher = asyncio.create_task(self.batcher())
        try:
            async with serve(
                self.handler, host, port, compression=None, max_size=self.max_message_bytes
            ) as server:
                if ready is not None:
                    ready(int(next(iter(server.sockets)).getsockname()[1]))
                await server.serve_forever()
        finally:
            batcher.cancel()


def _peer(websocket: Any) -> str:
    address = getattr(websocket, "remote_address", None)
    if isinstance(address, tuple) and len(address) >= 2:
        return f"client {address[0]}:{address[1]}"
    return "a client"


def _request(message: Any) -> Any:
    """A message as a request, or :class:`InputError` in one sentence (text, or bytes that are
    not openpi's msgpack)."""
    if isinstance(message, str):
        raise InputError("requests are binary msgpack messages, not text")
    try:
        return unpack(message)
    except InputError:
        raise
    except Exception as exc:
        raise InputError(
            f"the message is not openpi's msgpack ({type(exc).__name__}); send a map of numpy arrays and strings "
            "as openpi-client's msgpack_numpy packs it"
        ) from None


def _internal_error(what: str) -> str:
    """Log the current exception in full under a new id; the one sentence the client gets."""
    ident = uuid.uuid4().hex[:8]
    log.exception("error %s while %s", ident, what)
    return f"InternalError: the server failed on this request (error {ident}; its log has the details)"


def served_policy(
    path: str, device: str, view_task: int | None = None, max_message_bytes: int = MAX_MESSAGE_BYTES
) -> PolicyServer:
    """What ``libero-bench serve`` serves: a libero-bench run folder (its final checkpoint, in the
    evaluation view of the task at ``view_task``, default its last) or a LeRobot
    ``pretrained_model/`` folder (:func:`~libero_bench.rollouts.policy_kinds.policy_source`)."""
    from libero_bench.rollouts.policy_kinds import RUN, policy_source
    from libero_data.runtime.versions import versions

    source = policy_source(path)
    if source.kind != RUN and view_task is not None:
        raise InputError("--view-task is for a run folder's tasks", field="view_task")
    actor = source.open(device, view_task)
    metadata: dict[str, Any] = {
        "server": "libero-bench",
        "policy_type": source.policy_type,
        "image_size": source.render_size,
        "policy": source.ref,
        "versions": versions(),
    }
    embed = source.embed
    needs = tuple(extra_needs(source.reads))
    return PolicyServer(
        actor,
        metadata,
        embed=(lambda prompt: embed([prompt])[0]) if embed is not None else None,
        image_size=source.render_size if source.kind == RUN else None,
        needs=needs,
        max_message_bytes=max_message_bytes,
    )
