"""A policy served elsewhere, over openpi's websocket protocol (:mod:`~libero_bench.rollouts.wire`).

:class:`RemoteActor` rolls out here what a server runs on its own machine (a GPU host, another
virtual environment: openpi's JAX models, OpenVLA-OFT, GR00T, or ``libero-bench serve``). Each
episode opens its own connection (a server that keeps per-episode state starts afresh with it) and
reads the server's metadata; each slot whose actions have run out sends its observation, all
waiting slots at once (a batching server answers them in one pass), and executes the first
``replan_steps`` actions of the chunk it gets back (openpi's LIBERO client: 5).

The observation sent, as openpi's LIBERO example builds it:

=============================  =============================================================
``observation/image``          agentview camera, upright, uint8 (S, S, 3): rendered at the
                               evaluation's image size, resized with padding to ``image_size``
``observation/wrist_image``    eye-in-hand camera, the same way
``observation/state``          float32 (8,): end-effector position, axis-angle, gripper qpos
``prompt``                     the task's instruction
``observation/joint_position`` float32 (7,), arm joints (DROID's name; LIBERO servers ignore it)
``observation/gripper_position`` float32 (2,), gripper fingers (likewise)
``rollout_key``                the rollout's key (``libero-bench serve`` seeds sampling with it)
=============================  =============================================================

A server that cannot be reached, answers with an error (a text frame: its traceback), answers
nothing within ``timeout`` seconds or closes the connection is a
:class:`~libero_data.errors.PolicyServerError` naming the server and the rollout; the evaluation
folder then resumes from the rollouts that finished.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from libero_bench.rollouts.actors import ActionQueues, BatchActor, Observations, Start
from libero_bench.rollouts.wire import pack, unpack
from libero_data.errors import PolicyServerError

IMAGE, WRIST_IMAGE, STATE, PROMPT = (
    "observation/image",
    "observation/wrist_image",
    "observation/state",
    "prompt",
)
JOINTS, GRIPPER, ROLLOUT_KEY = "observation/joint_position", "observation/gripper_position", "rollout_key"


def resize_with_pad(image: np.ndarray, size: int) -> np.ndarray:
    """``image`` (H, W, 3) uint8 scaled to fit ``size`` x ``size`` (bilinear), centred on black
    padding, as openpi's client resizes camera images."""
    from PIL import Image

    h, w = image.shape[:2]
    if (h, w) == (size, size):
        return np.ascontiguousarray(image, dtype=np.uint8)
    scale = size / max(h, w)
    nh, nw = max(1, round(h * scale)), max(1, round(w * scale))
    resized = np.asarray(
        Image.fromarray(np.asarray(image, dtype=np.uint8)).resize((nw, nh), Image.Resampling.BILINEAR)
    )
    out = np.zeros((size, size, 3), dtype=np.uint8)
    top, left = (size - nh) // 2, (size - nw) // 2
    out[top : top + nh, left : left + nw] = resized
    return out


def request(obs: dict[str, Any] | Any, language: str, key: str, image_size: int) -> dict[str, Any]:
    """The message a slot sends for an environment observation (see the module docstring)."""
    return {
        IMAGE: resize_with_pad(obs["agentview"], image_size),
        WRIST_IMAGE: resize_with_pad(obs["eye_in_hand"], image_size),
        STATE: np.asarray(obs["state"], dtype=np.float32),
        PROMPT: language,
        JOINTS: np.asarray(obs["joint_pos"], dtype=np.float32),
        GRIPPER: np.asarray(obs["gripper_state"], dtype=np.float32),
        ROLLOUT_KEY: key,
    }


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


def _reason(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return text[-1] if text else type(exc).__name__


class RemoteActor(BatchActor):
    """Slots acting through the policy server at ``url`` (see the module docstring)."""

    def __init__(
        self, url: str, *, image_size: int = 224, replan_steps: int = 5, timeout: float = 60.0
    ) -> None:
        super().__init__()
        if replan_steps < 1:
            raise ValueError("replan_steps must be at least 1")
        self.url = url
        self.image_size = image_size
        self.timeout = timeout
        self.queues = ActionQueues(replan_steps)
        probe, self.metadata = connect(url, timeout)  # unreachable: one sentence before any rollout
        probe.close()
        self._connections: dict[int, Any] = {}
        self._start: dict[int, Start] = {}

    def begin(self, slot: int, start: Start) -> None:
        self.end(slot)
        self._connections[slot], _ = connect(self.url, self.timeout)
        self._start[slot] = start
        self.queues.clear(slot)

    def end(self, slot: int) -> None:
        connection = self._connections.pop(slot, None)
        if connection is not None:
            connection.close()
        self._start.pop(slot, None)
        self.queues.drop(slot)

    def close(self) -> None:
        for slot in list(self._connections):
            self.end(slot)

    def act(self, observations: Observations) -> dict[int, np.ndarray]:
        from websockets.exceptions import ConnectionClosed

        slots = sorted(observations)
        waiting = self.queues.waiting(slots)
        sent = []
        try:
            for slot in waiting:  # every waiting slot's request is out before any answer is read
                start = self._start[slot]
                message = request(observations[slot], start.language, start.key, self.image_size)
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
        return {s: np.asarray(self.queues.pop(s), dtype=np.float32).reshape(-1)[:7] for s in slots}

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
        actions = np.asarray(actions, dtype=np.float32)
        if actions.ndim == 1:
            actions = actions[None]
        if actions.ndim != 2 or actions.shape[1] < 7 or not np.all(np.isfinite(actions)):
            raise PolicyServerError(
                f"the policy server at {self.url} answered rollout {key} with actions of shape "
                f"{list(actions.shape)}; a chunk of 7-D finite actions (H, 7) is needed"
            )
        return actions

    def describe(self) -> dict[str, Any]:
        return {
            "actor": "server",
            "url": self.url,
            "image_size": self.image_size,
            "replan_steps": self.queues.steps,
            "server_metadata": {
                k: v for k, v in self.metadata.items() if isinstance(v, str | int | float | bool)
            },
        }
