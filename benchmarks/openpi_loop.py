"""openpi's LIBERO client loop, rebuilt for tests and benchmarks from its documented steps (openpi's
``examples/libero/main.py`` and openpi-client's ``image_tools`` and ``websocket_client_policy``),
with LIBERO's own ``OffScreenRenderEnv`` and robosuite's own ``quat2axisangle``; and a policy
server that records every request and answers with scripted chunks whatever it sees.

Written apart from libero-bench's code on purpose: the standard protocol is checked against this,
not against itself.
"""

from __future__ import annotations

import asyncio
import collections
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np

from libero_bench.rollouts.wire import pack, unpack

WAIT = [0.0] * 6 + [-1.0]


def openpi_resize(image: np.ndarray, size: int) -> np.ndarray:
    """openpi-client's resize_with_pad for one uint8 image: fit by the larger side (sizes truncated),
    bilinear, pasted on black at the truncated centre offsets."""
    from PIL import Image

    if image.shape[:2] == (size, size):
        return image
    picture = Image.fromarray(image)
    width, height = picture.size
    ratio = max(width / size, height / size)
    new_w, new_h = int(width / ratio), int(height / ratio)
    canvas = Image.new(picture.mode, (size, size), 0)
    canvas.paste(
        picture.resize((new_w, new_h), resample=Image.Resampling.BILINEAR),
        (max(0, int((size - new_w) / 2)), max(0, int((size - new_h) / 2))),
    )
    return np.asarray(canvas)


class Client:
    """openpi-client's websocket policy client (metadata on connect, infer, episode messages)."""

    def __init__(self, url: str) -> None:
        from websockets.sync.client import connect

        self.ws = connect(url, compression=None, max_size=None, legacy=True)
        first = self.ws.recv()
        assert isinstance(first, bytes), first
        self.metadata = unpack(first)

    def _call(self, message: dict[str, Any]) -> Any:
        self.ws.send(pack(message))
        reply = self.ws.recv()
        if isinstance(reply, str):
            raise RuntimeError(f"Error in inference server:\n{reply}")
        return unpack(reply)

    def infer(self, obs: dict[str, Any]) -> Any:
        return self._call(obs)

    def episode_start(self, experiment: str, task: str, episode_id: int) -> Any:
        return self._call(
            {
                "__ctrl__": "episode_start",
                "__experiment__": experiment,
                "__task__": task,
                "__episode_id__": episode_id,
            }
        )

    def episode_end(self, success: bool) -> Any:
        return self._call({"__ctrl__": "episode_end", "__success__": success})

    def close(self) -> None:
        self.ws.close()


def run_openpi_loop(
    url: str, task: Any, episodes: int, max_steps: int, *, replan: int = 5, wait: int = 10, seed: int = 7
) -> list[dict[str, Any]]:
    """openpi's loop on one task (its first ``episodes`` init states); each episode's outcome,
    the actions it executed and the acknowledgements it got."""
    from libero.libero.envs import OffScreenRenderEnv
    from robosuite.utils.transform_utils import quat2axisangle

    from libero_data.sim.imports import import_libero

    import_libero()  # robosuite's logging and matplotlib's config folder kept out of the home folder
    client = Client(url)
    np.random.seed(seed)
    env = OffScreenRenderEnv(bddl_file_name=str(task.bddl_path), camera_heights=256, camera_widths=256)
    env.seed(seed)
    initial_states = task.init_states()
    out = []
    try:
        for episode in range(episodes):
            acks = [client.episode_start(experiment=task.suite, task=str(task.language), episode_id=episode)]
            env.reset()
            plan: collections.deque[np.ndarray] = collections.deque()
            obs = env.set_init_state(initial_states[episode])
            t, done, executed = 0, False, []
            while t < max_steps + wait:
                if t < wait:
                    obs, _reward, done, _info = env.step(WAIT)
                    t += 1
                    continue
                image = openpi_resize(np.ascontiguousarray(obs["agentview_image"][::-1, ::-1]), 224)
                wrist = openpi_resize(np.ascontiguousarray(obs["robot0_eye_in_hand_image"][::-1, ::-1]), 224)
                if not plan:
                    element = {
                        "observation/image": image,
                        "observation/wrist_image": wrist,
                        "observation/state": np.concatenate(
                            (
                                obs["robot0_eef_pos"],
                                quat2axisangle(obs["robot0_eef_quat"]),
                                obs["robot0_gripper_qpos"],
                            )
                        ),
                        "prompt": str(task.language),
                    }
                    chunk = client.infer(element)["actions"]
                    assert len(chunk) >= replan, f"only {len(chunk)} actions, replanning every {replan}"
                    plan.extend(chunk[:replan])
                action = plan.popleft()
                executed.append(np.asarray(action, dtype=np.float64))
                obs, _reward, done, _info = env.step(action.tolist())
                if done:
                    break
                t += 1
            acks.append(client.episode_end(success=bool(done)))
            out.append({"success": bool(done), "actions": np.asarray(executed), "acks": acks})
    finally:
        env.close()
        client.close()
    return out


class RecordingServer:
    """openpi's server protocol: metadata on connect, control messages acknowledged, every request
    recorded (by episode id) and answered with scripted chunks of ``chunk`` actions."""

    def __init__(self, chunk: int = 5) -> None:
        self.chunk = chunk
        self.requests: dict[int, list[dict[str, Any]]] = collections.defaultdict(list)
        self.controls: list[dict[str, Any]] = []
        self.url = ""

    def script(self, episode: int, request: int) -> np.ndarray:
        """The chunk answering an episode's ``request``-th request, whatever it saw."""
        rng = np.random.default_rng([episode, request])
        actions = rng.uniform(-0.6, 0.6, size=(self.chunk, 7))
        actions[:, 6] = np.where(rng.uniform(size=self.chunk) < 0.5, -1.0, 1.0)
        return actions

    async def _handler(self, websocket: Any) -> None:
        from websockets.exceptions import ConnectionClosed

        episode = -1
        await websocket.send(pack({"server": "recording"}))
        try:
            async for message in websocket:
                request = unpack(message)
                if "__ctrl__" in request:
                    self.controls.append(request)
                    if request["__ctrl__"] == "episode_start":
                        episode = int(request["__episode_id__"])
                    await websocket.send(pack({"__ack__": request["__ctrl__"]}))
                    continue
                seen = self.requests[episode]
                seen.append(request)
                await websocket.send(pack({"actions": self.script(episode, len(seen) - 1)}))
        except ConnectionClosed:
            pass

    @contextmanager
    def running(self) -> Iterator[RecordingServer]:
        from websockets.asyncio.server import serve

        ready = threading.Event()
        loop = asyncio.new_event_loop()
        stop = loop.create_future()

        async def main() -> None:
            async with serve(self._handler, "127.0.0.1", 0, compression=None, max_size=None) as server:
                self.url = f"ws://127.0.0.1:{next(iter(server.sockets)).getsockname()[1]}"
                ready.set()
                await stop

        thread = threading.Thread(target=loop.run_until_complete, args=(main(),), daemon=True)
        thread.start()
        ready.wait(30)
        try:
            yield self
        finally:
            loop.call_soon_threadsafe(stop.set_result, None)
            thread.join(30)
