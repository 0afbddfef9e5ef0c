"""A policy served elsewhere, over openpi's websocket protocol (:mod:`~libero_bench.rollouts.wire`).

:class:`RemoteActor` rolls out here what a server runs on its own machine (a GPU host, another
virtual environment: openpi's JAX models, OpenVLA-OFT, GR00T, or ``libero-bench serve``). Each
slot whose actions have run out sends its observation, all waiting slots at once (a batching
server answers them in one pass), and executes the first ``replan_steps`` actions of the chunk it
gets back (openpi's LIBERO client: 5). What is sent is the protocol's request
(:mod:`~libero_bench.rollouts.observations`):

- ``libero-bench`` (the default protocol's): each episode opens its own connection (a server that
  keeps per-episode state starts afresh with it); the request carries the rollout's key;
- ``openpi`` (the standard protocol's): as openpi's current LIBERO client, one connection per slot
  for every episode, each episode framed by openpi's control messages (``episode_start`` with the
  suite, the instruction and the episode's number; ``episode_end`` with its success), the request
  openpi's four entries and those the server's metadata names among its ``inputs`` (``libero-bench
  serve`` of a run: the arm's joints), and a chunk shorter than ``replan_steps`` an error (openpi
  asserts it) named before any rollout, with what to do.

A server that cannot be reached, answers with an error (a text frame: its traceback), answers
nothing within ``timeout`` seconds or closes the connection is a
:class:`~libero_data.errors.PolicyServerError` naming the server and the rollout; the evaluation
folder then resumes from the rollouts that finished.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from libero_bench.rollouts.actors import ActionQueues, BatchActor, Observations, Start
from libero_bench.rollouts.observations import EXTRA_ENTRIES, libero_bench_request, openpi_request
from libero_bench.rollouts.wire import pack, unpack
from libero_data.errors import PolicyServerError

#: openpi's episode control messages (openpi-client's ``episode_start`` / ``episode_end``).
CONTROL, ACK = "__ctrl__", "__ack__"
EPISODE_START, EPISODE_END = "episode_start", "episode_end"


def connect(url: str, timeout: float) -> tuple[Any, dict[str, Any]]:
    """An open connection to the server at ``url`` and the metadata it sent."""
    from websockets.exceptions import InvalidHandshake, InvalidURI, WebSocketException
    from websockets.sync.client import connect as ws_connect

    try:
        # legacy=True: a plain connection, not websockets' context manager (closed in end())
        connection = ws_connect(url, compression=None, max_size=None, open_timeout=timeout, legacy=True)
    except InvalidURI as exc:
        raise PolicyServerError(f"{url!r} is not a websocket address (ws://HOST:PORT)") from exc
    except (OSError, TimeoutError, InvalidHandshake, WebSocketException) as exc:
        raise PolicyServerError(f"cannot reach the policy server at {url}: {_reason(exc)}") from exc
    try:
        first = connection.recv(timeout=timeout)
        metadata = unpack(first) if isinstance(first, bytes) else first
    except Exception as exc:
        connection.close()
        raise PolicyServerError(
            f"the policy server at {url} sent no metadata on connect: {_reason(exc)}"
        ) from exc
    if not isinstance(metadata, dict):
        connection.close()
        raise PolicyServerError(
            f"the policy server at {url} did not open with openpi's metadata message: {str(metadata)[:200]}"
        )
    return connection, metadata


def check_chunks(url: str, metadata: dict[str, Any], replan_steps: int) -> None:
    """:class:`PolicyServerError` in one sentence, saying what to do, if the server at ``url``
    answers fewer actions per request than openpi's loop executes of each chunk."""
    horizon = metadata.get("action_horizon")
    if isinstance(horizon, int) and horizon < replan_steps:
        raise PolicyServerError(
            f"the policy server at {url} answers {horizon} action(s) per request, fewer than the "
            f"{replan_steps} of each chunk openpi's LIBERO loop executes; add --replan-steps {horizon} "
            f"(the policy is then asked every {horizon} step(s), a deviation the report names) or evaluate "
            "the policy here with libero-bench eval POLICY --protocol standard"
        )


def served_extras(metadata: dict[str, Any]) -> list[str]:
    """The observations (``joint_pos``, ``gripper_state``) to send beyond openpi's four entries:
    those the server's metadata lists among its ``inputs``."""
    inputs = metadata.get("inputs")
    named = set(inputs) if isinstance(inputs, list) else set()
    return [key for key, entry in EXTRA_ENTRIES.items() if entry in named]


def _reason(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return text[-1] if text else type(exc).__name__


class RemoteActor(BatchActor):
    """Slots acting through the policy server at ``url`` (see the module docstring)."""

    def __init__(
        self,
        url: str,
        *,
        image_size: int = 224,
        replan_steps: int = 5,
        timeout: float = 60.0,
        request: str = "libero-bench",
    ) -> None:
        super().__init__()
        if replan_steps < 1:
            raise ValueError("replan_steps must be at least 1")
        self.url = url
        self.image_size = image_size
        self.timeout = timeout
        self.openpi = request == "openpi"
        self.queues = ActionQueues(replan_steps)
        probe, self.metadata = connect(url, timeout)  # unreachable: one sentence before any rollout
        probe.close()
        if self.openpi:
            check_chunks(url, self.metadata, replan_steps)
        #: What is sent beyond openpi's four entries: what the server's metadata says its policy
        #: reads (libero-bench serve of a run: the arm's joints), as a local standard evaluation does.
        self.extra = served_extras(self.metadata) if self.openpi else []
        self._connections: dict[int, Any] = {}
        self._start: dict[int, Start] = {}

    def begin(self, slot: int, start: Start) -> None:
        if not self.openpi:
            self._disconnect(slot)
        if slot not in self._connections:
            self._connections[slot], _ = connect(self.url, self.timeout)
        self._start[slot] = start
        self.queues.clear(slot)
        if self.openpi:
            self._control(
                slot,
                {
                    CONTROL: EPISODE_START,
                    "__experiment__": start.experiment,
                    "__task__": start.language,
                    "__episode_id__": start.episode,
                    # Only when asking at every step (a deviation from openpi's loop, whose messages
                    # are sent as they are otherwise): libero-bench serve then answers a policy that
                    # predicts one action per step (openpi's servers ignore the entry).
                    **({"__replan_steps__": 1} if self.queues.steps == 1 else {}),
                },
            )

    def end(self, slot: int, success: bool | None = None) -> None:
        if self.openpi and slot in self._start and slot in self._connections:
            self._control(slot, {CONTROL: EPISODE_END, "__success__": bool(success)})
        else:
            self._disconnect(slot)
        self._start.pop(slot, None)
        self.queues.drop(slot)

    def close(self) -> None:
        for slot in list(self._connections):
            self._disconnect(slot)

    def _disconnect(self, slot: int) -> None:
        connection = self._connections.pop(slot, None)
        if connection is not None:
            connection.close()

    def _control(self, slot: int, message: dict[str, Any]) -> None:
        """Send an episode control message and read its acknowledgement, as openpi's client does."""
        from websockets.exceptions import ConnectionClosed

        key = self._start[slot].key
        try:
            self._connections[slot].send(pack(message))
            reply = self._connections[slot].recv(timeout=self.timeout)
        except TimeoutError as exc:
            raise PolicyServerError(
                f"the policy server at {self.url} did not acknowledge {message[CONTROL]} of rollout {key} "
                f"within {self.timeout:g} s"
            ) from exc
        except (ConnectionClosed, OSError) as exc:
            raise PolicyServerError(
                f"the policy server at {self.url} closed the connection at {message[CONTROL]} of rollout {key} "
                f"({_reason(exc)})"
            ) from exc
        if isinstance(reply, str):
            raise PolicyServerError(
                f"the policy server at {self.url} failed on {message[CONTROL]} of rollout {key}: "
                f"{_reason(Exception(reply))}"
            )

    def act(self, observations: Observations) -> dict[int, np.ndarray]:
        from websockets.exceptions import ConnectionClosed

        slots = sorted(observations)
        waiting = self.queues.waiting(slots)
        sent = []
        try:
            for slot in waiting:  # every waiting slot's request is out before any answer is read
                start = self._start[slot]
                if self.openpi:
                    message = openpi_request(observations[slot], start.language, self.image_size, self.extra)
                else:
                    message = libero_bench_request(
                        observations[slot], start.language, start.key, self.image_size
                    )
                self._connections[slot].send(pack(message))
                sent.append(slot)
            for slot in sent:
                self.queues.fill(
                    slot, self._actions(slot, self._connections[slot].recv(timeout=self.timeout))
                )
        except TimeoutError as exc:
            raise PolicyServerError(
                f"the policy server at {self.url} did not answer within {self.timeout:g} s "
                f"(rollout {self._start[slot].key})"
            ) from exc
        except (ConnectionClosed, OSError) as exc:
            raise PolicyServerError(
                f"the policy server at {self.url} closed the connection during rollout "
                f"{self._start[slot].key} ({_reason(exc)})"
            ) from exc
        if sent:
            self.counted(len(sent))
        return {s: np.asarray(self.queues.pop(s), dtype=np.float64).reshape(-1)[:7] for s in slots}

    def _actions(self, slot: int, reply: bytes | str) -> np.ndarray:
        key = self._start[slot].key
        if isinstance(reply, str):
            raise PolicyServerError(
                f"the policy server at {self.url} failed on rollout {key}: {_reason(Exception(reply))}"
            )
        message = unpack(reply)
        actions = message.get("actions") if isinstance(message, dict) else None
        if actions is None:
            raise PolicyServerError(f"the policy server at {self.url} answered rollout {key} without actions")
        actions = np.asarray(actions, dtype=np.float64)
        if actions.ndim == 1:
            actions = actions[None]
        if actions.ndim != 2 or actions.shape[1] < 7 or not np.all(np.isfinite(actions)):
            raise PolicyServerError(
                f"the policy server at {self.url} answered rollout {key} with actions of shape "
                f"{list(actions.shape)}; a chunk of 7-D finite actions (H, 7) is needed"
            )
        steps = self.queues.steps or 1
        if self.openpi and actions.shape[0] < steps:
            raise PolicyServerError(
                f"the policy server at {self.url} answered rollout {key} with {actions.shape[0]} action(s); "
                f"openpi's LIBERO loop executes {steps} of each chunk"
            )
        return actions

    def looks(self, slot: int) -> bool:
        return self.queues.empty(slot)

    def ahead(self, slot: int) -> list[np.ndarray]:
        return [np.asarray(a, dtype=np.float64).reshape(-1)[:7] for a in self.queues.take(slot)]

    def describe(self) -> dict[str, Any]:
        return {
            "actor": "server",
            "url": self.url,
            "request": "openpi" if self.openpi else "libero-bench",
            "image_size": self.image_size,
            "replan_steps": self.queues.steps,
            **({"beyond_openpi": [EXTRA_ENTRIES[k] for k in self.extra]} if self.openpi else {}),
            "server_metadata": {
                k: v for k, v in self.metadata.items() if isinstance(v, str | int | float | bool)
            },
        }
