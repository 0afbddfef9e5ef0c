"""``libero-bench serve``: our policies and LeRobot's behind openpi's websocket protocol.

A GPU machine serves while CPU machines roll out (``libero-bench eval --server``), or any client
that speaks openpi's protocol (:mod:`~libero_bench.rollouts.wire`) acts with the policy. Each
connection is one episode: the server keeps its history (a transformer's frames, an LSTM state,
a chunk's remaining actions, Diffusion Policy's last observations) until the connection closes.
Requests that arrive together, from any number of connections, go through one batched forward
pass; each reply is ``{"actions": (1, 7), "server_timing": {...}}``, the action the policy takes
now, so a client that executes every action it gets (``--replan-steps`` of 1 or more) acts exactly
as the policy does in a local evaluation.

Requests are read as :mod:`~libero_bench.rollouts.remote` sends them (openpi's LIBERO keys, plus
the arm joints and gripper where a policy reads them); a request that cannot be served gets a text
reply, openpi's way of sending an error, and the connection stays open.
"""

from __future__ import annotations

import asyncio
import itertools
import logging
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from libero_bench.rollouts.actors import BatchActor, Start
from libero_bench.rollouts.remote import (
    GRIPPER,
    IMAGE,
    JOINTS,
    PROMPT,
    ROLLOUT_KEY,
    STATE,
    WRIST_IMAGE,
    resize_with_pad,
)
from libero_bench.rollouts.wire import pack, unpack
from libero_data.errors import InputError

log = logging.getLogger(__name__)

#: Request entries -> the environment observation a policy actor reads.
OBSERVATION_KEYS = {
    IMAGE: "agentview",
    WRIST_IMAGE: "eye_in_hand",
    STATE: "state",
    JOINTS: "joint_pos",
    GRIPPER: "gripper_state",
}


@dataclass
class Pending:
    """A request waiting for the next batch."""

    slot: int
    observation: dict[str, Any]
    prompt: str
    key: str
    reply: asyncio.Future[Any]


def environment_observation(message: Any, image_size: int | None) -> tuple[dict[str, Any], str, str | None]:
    """(observation, prompt, rollout key) of a request; :class:`InputError` naming what is missing."""
    if not isinstance(message, dict):
        raise InputError("a request must be a map of observation entries")
    missing = [k for k in (IMAGE, WRIST_IMAGE, STATE, PROMPT) if k not in message]
    if missing:
        raise InputError(f"the request lacks {', '.join(missing)}")
    obs: dict[str, Any] = {}
    for entry, key in OBSERVATION_KEYS.items():
        if entry in message:
            value = np.asarray(message[entry])
            if (
                key in ("agentview", "eye_in_hand")
                and image_size
                and value.shape[:2] != (image_size, image_size)
            ):
                value = resize_with_pad(value, image_size)
            obs[key] = value
    rollout = message.get(ROLLOUT_KEY)
    return obs, str(message[PROMPT]), None if rollout is None else str(rollout)


class PolicyServer:
    """A :class:`~libero_bench.rollouts.actors.BatchActor` behind openpi's websocket protocol.

    ``embed`` turns a prompt into the task embedding libero-bench's policies read (None for
    policies that read the instruction itself); ``image_size`` is the camera size the policy
    reads (images of another size are resized with padding)."""

    def __init__(
        self,
        actor: BatchActor,
        metadata: dict[str, Any],
        *,
        embed: Callable[[str], np.ndarray] | None = None,
        image_size: int | None = None,
        gather_s: float = 0.002,
    ) -> None:
        self.actor = actor
        self.metadata = metadata
        self.embed = embed
        self.image_size = image_size
        self.gather_s = gather_s
        self._ids = itertools.count()
        self._pending: list[Pending] = []
        self._ended: list[int] = []
        self._begun: set[int] = set()
        self._wake: asyncio.Event | None = None
        self.batches: list[int] = []  # the size of every batch served

    async def handler(self, websocket: Any) -> None:
        from websockets.exceptions import ConnectionClosed

        assert self._wake is not None
        slot = next(self._ids)
        loop = asyncio.get_running_loop()
        try:
            await websocket.send(pack(self.metadata))
            async for message in websocket:
                try:
                    if isinstance(message, str):
                        raise InputError("requests are binary msgpack messages")
                    obs, prompt, key = environment_observation(unpack(message), self.image_size)
                except Exception:
                    await websocket.send(traceback.format_exc())
                    continue
                pending = Pending(slot, obs, prompt, key or f"connection-{slot}", loop.create_future())
                self._pending.append(pending)
                self._wake.set()
                await websocket.send(await pending.reply)
        except ConnectionClosed:
            pass
        finally:
            self._ended.append(slot)

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
                actions = await asyncio.to_thread(self._infer, batch)
            except Exception:
                text = traceback.format_exc()
                log.error("inference failed: %s", text)
                for p in batch:
                    p.reply.set_result(text)
                continue
            infer_ms = (time.perf_counter() - started) * 1000
            self.batches.append(len(batch))
            for p in batch:
                reply = {"actions": actions[p.slot][None], "server_timing": {"infer_ms": infer_ms}}
                p.reply.set_result(pack(reply))

    def _infer(self, batch: list[Pending]) -> dict[int, np.ndarray]:
        """Runs in a thread, one batch at a time: every call on the actor happens here."""
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
        return self.actor.act({p.slot: p.observation for p in batch})

    async def serve(self, host: str, port: int, ready: Callable[[int], None] | None = None) -> None:
        """Serve until cancelled; ``ready`` gets the port listened on (``port`` 0: one the system chose)."""
        from websockets.asyncio.server import serve

        self._wake = asyncio.Event()
        batcher = asyncio.create_task(self.batcher())
        try:
            async with serve(self.handler, host, port, compression=None, max_size=None) as server:
                if ready is not None:
                    ready(int(next(iter(server.sockets)).getsockname()[1]))
                await server.serve_forever()
        finally:
            batcher.cancel()


def served_policy(
    path: str, device: str, view_task: int | None = None
) -> tuple[BatchActor, dict[str, Any], Callable[[str], np.ndarray] | None, int | None]:
    """(actor, metadata, prompt embedding, camera size) of what ``libero-bench serve`` serves: a
    libero-bench run folder (its final checkpoint, in the evaluation view of the task at
    ``view_task``, default its last) or a LeRobot ``pretrained_model/`` folder."""
    from pathlib import Path

    from libero_bench.runs.folder import RunFolder
    from libero_data.runtime.versions import versions

    folder = Path(path).resolve()
    metadata: dict[str, Any] = {"server": "libero-bench", "actions_per_request": 1, "versions": versions()}
    if RunFolder(folder).is_run():
        from libero_bench.data.language import encode_tasks
        from libero_bench.rollouts.actors import PolicyActor
        from libero_bench.runs.summary import load_run
        from libero_bench.train.checkpoints import kept_checkpoint, policy_from_checkpoint

        summary = load_run(folder)
        config = summary.config
        last = summary.tasks_done - 1
        position = last if view_task is None else view_task
        if not 0 <= position <= last:
            raise InputError(
                f"run {folder} has learned tasks 0..{last}; no view of task {position}", field="view_task"
            )
        policy, _algo = policy_from_checkpoint(
            config, kept_checkpoint(RunFolder(folder), config, last), position
        )
        policy = policy.to(device)
        encoder = config["preset"]["language_encoder"]
        size = int(policy.config.image_size)
        metadata.update(
            policy_type=f"{config['algo']} + {config['policy']}", image_size=size, run=str(folder)
        )
        return PolicyActor(policy), metadata, lambda prompt: encode_tasks([prompt], encoder)[0], size
    from libero_bench.rollouts.lerobot_actor import LeRobotActor

    actor = LeRobotActor(folder, device)
    metadata.update(policy_type=actor.config.type, image_size=actor.inputs.render_size, policy=str(folder))
    return actor, metadata, None, None
