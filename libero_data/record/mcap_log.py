"""One MCAP log per episode: both cameras, state, action, language and success.

Every channel carries JSON messages described by a JSON schema. Camera frames use the
field layout of Foxglove's ``foxglove.CompressedImage`` (JPEG bytes, base64 in JSON), so
the logs open in Foxglove Studio as image panels.
"""

from __future__ import annotations

import base64
import io
import json
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from libero_data.runtime.files import write_bytes

_TIME = {"type": "object", "properties": {"sec": {"type": "integer"}, "nsec": {"type": "integer"}}}
SCHEMAS: dict[str, dict[str, Any]] = {
    "foxglove.CompressedImage": {
        "type": "object",
        "title": "foxglove.CompressedImage",
        "properties": {
            "timestamp": _TIME,
            "frame_id": {"type": "string"},
            "data": {"type": "string", "contentEncoding": "base64"},
            "format": {"type": "string"},
        },
    },
    "libero_data.State": {
        "type": "object",
        "title": "libero_data.State",
        "properties": {
            "timestamp": _TIME,
            "frame_index": {"type": "integer"},
            "state": {
                "type": "array",
                "items": {"type": "number"},
                "description": "eef pos (3), axis-angle (3), gripper qpos (2)",
            },
            "joint_positions": {"type": "array", "items": {"type": "number"}},
            "gripper_state": {"type": "array", "items": {"type": "number"}},
            "eef_pose": {"type": "array", "items": {"type": "number"}, "description": "x y z qx qy qz qw"},
        },
    },
    "libero_data.Action": {
        "type": "object",
        "title": "libero_data.Action",
        "properties": {
            "timestamp": _TIME,
            "frame_index": {"type": "integer"},
            "action": {
                "type": "array",
                "items": {"type": "number"},
                "description": "OSC delta pose (6) + gripper (1)",
            },
        },
    },
    "libero_data.Language": {
        "type": "object",
        "title": "libero_data.Language",
        "properties": {"timestamp": _TIME, "task": {"type": "string"}, "instruction": {"type": "string"}},
    },
    "libero_data.Success": {
        "type": "object",
        "title": "libero_data.Success",
        "properties": {
            "timestamp": _TIME,
            "frame_index": {"type": "integer"},
            "success": {"type": "boolean"},
        },
    },
}
CHANNELS = {
    "/camera/agentview": "foxglove.CompressedImage",
    "/camera/eye_in_hand": "foxglove.CompressedImage",
    "/state": "libero_data.State",
    "/action": "libero_data.Action",
    "/language": "libero_data.Language",
    "/success": "libero_data.Success",
}


def _stamp(ns: int) -> dict[str, int]:
    return {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}


def _jpeg(image: np.ndarray, quality: int = 90) -> bytes:
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(np.asarray(image, dtype=np.uint8)).save(buf, format="JPEG", quality=quality)
    return buf.getvalue()


def once_per_image[T](encode: Callable[[np.ndarray], T]) -> Callable[[np.ndarray], T]:
    """``encode`` with its result kept per image array, for one episode's frames.

    An image held over several frames (a rollout draws only where its policy looks, and holds
    the images between) is the same array in each: it is encoded once. Keyed by the array's
    identity, which is unique while the caller keeps the frames (and so every array) alive, and
    images are never changed in place once observed (each draw makes a new array).
    """
    done: dict[int, T] = {}

    def encoded(image: np.ndarray) -> T:
        if id(image) not in done:
            done[id(image)] = encode(image)
        return done[id(image)]

    return encoded


def episode_jpegs() -> Callable[[np.ndarray], bytes]:
    """One JPEG (quality 90) per image array of an episode, shared by every log that stores the
    episode's images (its MCAP log and, for a rollout, its Rerun recording)."""
    return once_per_image(_jpeg)


def write_episode_mcap(
    path: str | Path,
    *,
    frames: list[dict[str, Any]],
    task: str,
    instruction: str,
    success: list[bool],
    fps: int = 20,
    metadata: dict[str, str] | None = None,
    jpegs: Callable[[np.ndarray], bytes] | None = None,
) -> Path:
    """Write one episode; ``frames[t]`` holds ``agentview``/``eye_in_hand`` images, ``state``,
    ``joint_pos``, ``gripper_state``, ``eef_pos``, ``eef_quat`` and ``action``. ``jpegs``: the
    episode's :func:`episode_jpegs`, where another log stores the same images.

    The file appears atomically (written to a temporary name, then renamed).
    """
    from mcap.writer import Writer

    step_ns = 1_000_000_000 // fps
    with io.BytesIO() as stream:
        writer = Writer(stream)
        writer.start(profile="", library="libero-data")
        schema_ids = {
            name: writer.register_schema(name=name, encoding="jsonschema", data=json.dumps(schema).encode())
            for name, schema in SCHEMAS.items()
        }
        channel = {
            topic: writer.register_channel(topic=topic, message_encoding="json", schema_id=schema_ids[schema])
            for topic, schema in CHANNELS.items()
        }
        if metadata:
            writer.add_metadata("libero_data", {k: str(v) for k, v in metadata.items()})

        def emit(topic: str, ns: int, message: dict[str, Any]) -> None:
            writer.add_message(
                channel[topic], log_time=ns, publish_time=ns, data=json.dumps(message).encode()
            )

        emit("/language", 0, {"timestamp": _stamp(0), "task": task, "instruction": instruction})
        encoded = jpegs or episode_jpegs()
        jpeg = once_per_image(lambda image: base64.b64encode(encoded(image)).decode())
        for t, frame in enumerate(frames):
            ns = t * step_ns
            for camera in ("agentview", "eye_in_hand"):
                if camera in frame:
                    emit(
                        f"/camera/{camera}",
                        ns,
                        {
                            "timestamp": _stamp(ns),
                            "frame_id": camera,
                            "data": jpeg(frame[camera]),
                            "format": "jpeg",
                        },
                    )
            emit(
                "/state",
                ns,
                {
                    "timestamp": _stamp(ns),
                    "frame_index": t,
                    "state": [float(v) for v in frame["state"]],
                    "joint_positions": [float(v) for v in frame["joint_pos"]],
                    "gripper_state": [float(v) for v in frame["gripper_state"]],
                    "eef_pose": [float(v) for v in np.concatenate([frame["eef_pos"], frame["eef_quat"]])],
                },
            )
            emit(
                "/action",
                ns,
                {"timestamp": _stamp(ns), "frame_index": t, "action": [float(v) for v in frame["action"]]},
            )
            emit("/success", ns, {"timestamp": _stamp(ns), "frame_index": t, "success": bool(success[t])})
        writer.finish()
        return write_bytes(Path(path), stream.getvalue())


def read_mcap(path: str | Path) -> Iterator[tuple[str, int, dict[str, Any]]]:
    """(topic, log time in ns, decoded JSON message) for every message of a log."""
    from mcap.reader import make_reader

    with Path(path).open("rb") as stream:
        reader = make_reader(stream)
        for _schema, channel, message in reader.iter_messages():
            yield channel.topic, message.log_time, json.loads(message.data)


def count_messages(path: str | Path, topic: str) -> int:
    """Number of messages on ``topic`` (read from the log's summary when it has one)."""
    from mcap.reader import make_reader

    with Path(path).open("rb") as stream:
        reader = make_reader(stream)
        summary = reader.get_summary()
        if summary is not None and summary.statistics is not None:
            ids = [cid for cid, ch in summary.channels.items() if ch.topic == topic]
            return sum(summary.statistics.channel_message_counts.get(cid, 0) for cid in ids)
    return sum(1 for t, _, _ in read_mcap(path) if t == topic)
