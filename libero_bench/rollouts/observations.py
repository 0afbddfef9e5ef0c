"""What a policy is sent: the observation mappings of the evaluation protocols
(:mod:`libero_bench.rollouts.protocol`), the same for a served policy and a local one.

openpi's LIBERO request (``examples/libero/main.py`` in openpi), the standard protocol's:

=============================  =============================================================
``observation/image``          agentview camera, upright (LIBERO's image turned by 180°),
                               uint8, resized with padding to 224 (openpi-client's
                               ``image_tools.resize_with_pad``: PIL bilinear, zero padding)
``observation/wrist_image``    eye-in-hand camera, the same way
``observation/state``          float64 (8,): end-effector position, robosuite's
                               ``quat2axisangle`` of LIBERO's quaternion, gripper qpos
``prompt``                     the task's instruction
=============================  =============================================================

libero-bench's request (the default protocol's) sends the same four entries (the state in our
datasets' convention, float32) and also ``observation/joint_position`` (7), ``observation/
gripper_position`` (2) and ``rollout_key`` (``libero-bench serve`` seeds sampling with it).

Under the standard protocol a local policy acts on what a server would receive:
:class:`RequestView` turns each observation into openpi's request and back
(:func:`environment_observation`, which ``libero-bench serve`` uses too), adding only the entries
the policy reads beyond openpi's four (our runs' policies read the arm's joints), which the
evaluation's report names.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from libero_bench.rollouts.actors import BatchActor, Observations, Start
from libero_data.errors import InputError

IMAGE, WRIST_IMAGE, STATE, PROMPT = (
    "observation/image",
    "observation/wrist_image",
    "observation/state",
    "prompt",
)
JOINTS, GRIPPER, ROLLOUT_KEY = "observation/joint_position", "observation/gripper_position", "rollout_key"
#: openpi's LIBERO request, entry for entry.
OPENPI_KEYS = (IMAGE, WRIST_IMAGE, STATE, PROMPT)
#: Request entries -> the environment observation they carry.
OBSERVATION_KEYS = {
    IMAGE: "agentview",
    WRIST_IMAGE: "eye_in_hand",
    STATE: "state",
    JOINTS: "joint_pos",
    GRIPPER: "gripper_state",
}
#: Our observations -> the request entry that carries each beyond openpi's four.
EXTRA_ENTRIES = {"joint_pos": JOINTS, "gripper_state": GRIPPER}


def extra_needs(reads: Sequence[str]) -> list[str]:
    """Of the observations a policy reads, those openpi's four entries do not carry (the arm's
    joints; the gripper's fingers come from openpi's state)."""
    return [k for k in reads if k in EXTRA_ENTRIES and k != "gripper_state"]


#: The shape each vector entry of a request must have: openpi's state (end-effector position,
#: axis-angle, the gripper's two finger joints), the arm's seven joints, the two finger joints.
VECTOR_SHAPES = {STATE: (8,), JOINTS: (7,), GRIPPER: (2,)}
#: The sides (px) a request's camera image may have: LIBERO's policies read 64-256 px, openpi's
#: client sends 224; a side outside these is a mistake (a 1 x 1 image) or a burden (3000 x 3000).
IMAGE_SIDES = (16, 1024)
#: The longest instruction (characters) a request may carry; LIBERO's longest has 127.
PROMPT_LENGTH = 1000


def _shape(value: Any) -> str:
    if isinstance(value, np.ndarray):
        return f"an array of {value.dtype} {tuple(value.shape)}"
    return f"a {type(value).__name__}"


def checked_entry(entry: str, value: Any) -> Any:
    """A request's entry as the server reads it, or :class:`InputError`: one sentence naming the
    entry, what it must be, and what came (images uint8 (H, W, 3) with sides within
    ``IMAGE_SIDES``; the vectors finite numbers of their ``VECTOR_SHAPES``; the prompt a string)."""
    if entry in (IMAGE, WRIST_IMAGE):
        low, high = IMAGE_SIDES
        if (
            not isinstance(value, np.ndarray)
            or value.dtype != np.uint8
            or value.ndim != 3
            or value.shape[2] != 3
            or not (low <= value.shape[0] <= high and low <= value.shape[1] <= high)
        ):
            raise InputError(
                f"{entry} must be a uint8 image of shape (H, W, 3) with sides of {low} to {high} px, "
                f"not {_shape(value)}"
            )
        return value
    if entry in VECTOR_SHAPES:
        shape = VECTOR_SHAPES[entry]
        array = value if isinstance(value, np.ndarray) else None
        if isinstance(value, list | tuple) and all(isinstance(x, int | float) for x in value):
            array = np.asarray(value, dtype=np.float64)
        if array is None or array.dtype.kind not in "fiu" or array.shape != shape:
            raise InputError(f"{entry} must be {shape[0]} numbers, not {_shape(value)}")
        if not np.all(np.isfinite(array)):
            raise InputError(f"{entry} must be finite, but holds NaN or infinity")
        return array
    if entry == PROMPT:
        if not isinstance(value, str):
            raise InputError(f"prompt must be a string (the task's instruction), not {_shape(value)}")
        if len(value) > PROMPT_LENGTH:
            raise InputError(f"prompt must be at most {PROMPT_LENGTH} characters, not {len(value)}")
        return value
    if entry == ROLLOUT_KEY:
        if not isinstance(value, str):
            raise InputError(f"rollout_key must be a string, not {_shape(value)}")
        return value
    return value


def resize_with_pad(image: np.ndarray, size: int) -> np.ndarray:
    """``image`` (H, W, 3) uint8 scaled to fit ``size`` x ``size`` (PIL bilinear), pasted on black at
    the offsets openpi-client's ``image_tools.resize_with_pad`` computes (sizes truncated): pixel for
    pixel that function (tested against openpi-client 0.1.2's wheel, which pins numpy<2 and so is not
    a dependency here; :mod:`libero_bench.rollouts.wire`)."""
    from PIL import Image

    h, w = image.shape[:2]
    if (h, w) == (size, size):
        return np.asarray(image)
    ratio = max(w / size, h / size)
    nh, nw = max(1, int(h / ratio)), max(1, int(w / ratio))
    resized = np.asarray(
        Image.fromarray(np.asarray(image, dtype=np.uint8)).resize((nw, nh), Image.Resampling.BILINEAR)
    )
    out = np.zeros((size, size, 3), dtype=np.uint8)
    top, left = max(0, int((size - nh) / 2)), max(0, int((size - nw) / 2))
    out[top : top + nh, left : left + nw] = resized
    return out


def openpi_request(
    obs: Mapping[str, Any], prompt: str, size: int = 224, extra: Sequence[str] = ()
) -> dict[str, Any]:
    """openpi's LIBERO request for an observation (see the module docstring); ``extra`` names
    observations sent beyond it (``joint_pos``, ``gripper_state``: a local policy that reads them)."""
    message: dict[str, Any] = {
        IMAGE: np.ascontiguousarray(resize_with_pad(obs["agentview"], size)),
        WRIST_IMAGE: np.ascontiguousarray(resize_with_pad(obs["eye_in_hand"], size)),
        STATE: np.asarray(obs["state"]),
        PROMPT: str(prompt),
    }
    for key in extra:
        message[EXTRA_ENTRIES[key]] = np.asarray(obs[key])
    return message


def libero_bench_request(obs: Mapping[str, Any], prompt: str, key: str, size: int) -> dict[str, Any]:
    """libero-bench's request for an observation (see the module docstring)."""
    return {
        IMAGE: resize_with_pad(obs["agentview"], size),
        WRIST_IMAGE: resize_with_pad(obs["eye_in_hand"], size),
        STATE: np.asarray(obs["state"], dtype=np.float32),
        PROMPT: prompt,
        JOINTS: np.asarray(obs["joint_pos"], dtype=np.float32),
        GRIPPER: np.asarray(obs["gripper_state"], dtype=np.float32),
        ROLLOUT_KEY: key,
    }


def environment_observation(
    message: Any, image_size: int | None, needs: Sequence[str] = ()
) -> tuple[dict[str, Any], str, str | None]:
    """(observation, prompt, rollout key) of a request, images resized with padding to
    ``image_size`` (None: as sent); :class:`InputError` naming what is missing, including any of
    ``needs`` (observations the policy reads that openpi's four entries do not carry), or an entry
    that is not what it must be (:func:`checked_entry`)."""
    if not isinstance(message, dict):
        raise InputError("a request must be a map of observation entries")
    missing = [k for k in OPENPI_KEYS if k not in message]
    if missing:
        raise InputError(f"the request lacks {', '.join(missing)}")
    obs: dict[str, Any] = {}
    for entry, key in OBSERVATION_KEYS.items():
        if entry in message:
            value = checked_entry(entry, message[entry])
            if key in ("agentview", "eye_in_hand") and image_size and value.shape[:2] != (image_size,) * 2:
                value = resize_with_pad(value, image_size)
            obs[key] = value
    if "gripper_state" not in obs:  # the state (checked: 8 entries) ends with the two fingers
        obs["gripper_state"] = obs["state"][6:8]
    lacking = [EXTRA_ENTRIES.get(k, k) for k in needs if k not in obs]
    if lacking:
        raise InputError(
            f"this policy also reads {', '.join(lacking)}, which the request lacks (openpi's LIBERO client "
            f"sends {', '.join(OPENPI_KEYS)} only)"
        )
    prompt = checked_entry(PROMPT, message[PROMPT])
    rollout = message.get(ROLLOUT_KEY)
    return obs, prompt, None if rollout is None else checked_entry(ROLLOUT_KEY, rollout)


class RequestView(BatchActor):
    """A local actor that acts on openpi's request, as it would served (see the module docstring):
    images sent at ``sent_size``, turned back into an observation at the actor's ``image_size``;
    ``needs`` are the observations it reads beyond openpi's four."""

    def __init__(
        self, actor: BatchActor, *, sent_size: int, image_size: int | None, needs: Sequence[str] = ()
    ) -> None:
        super().__init__()
        self.actor = actor
        self.sent_size = sent_size
        self.image_size = image_size
        self.needs = tuple(needs)
        self._prompt: dict[int, str] = {}

    def begin(self, slot: int, start: Start) -> None:
        self._prompt[slot] = start.language
        self.actor.begin(slot, start)

    def end(self, slot: int, success: bool | None = None) -> None:
        self._prompt.pop(slot, None)
        self.actor.end(slot, success)

    def act(self, observations: Observations) -> dict[int, np.ndarray]:
        seen = {}
        for slot, obs in observations.items():
            message = openpi_request(obs, self._prompt[slot], self.sent_size, self.needs)
            seen[slot], _prompt, _key = environment_observation(message, self.image_size, self.needs)
        actions = self.actor.act(seen)
        self.forwards, self.rows = self.actor.forwards, self.actor.rows
        return actions

    def looks(self, slot: int) -> bool:
        return self.actor.looks(slot)

    def ahead(self, slot: int) -> list[np.ndarray]:
        return self.actor.ahead(slot)

    def describe(self) -> dict[str, Any]:
        return {
            **self.actor.describe(),
            "request": "openpi",
            "sent_image_size": self.sent_size,
            "beyond_openpi": [EXTRA_ENTRIES.get(k, k) for k in self.needs],
        }

    def close(self) -> None:
        self.actor.close()
