"""LeRobot's policies (ACT, Diffusion Policy, SmolVLA, pi0 ...) acting for a batch of environments.

The policy is loaded once, on the device asked for, with its own processor pipelines. Each control
step every running slot's observation goes through the pre-processor together (normalisation,
tokenisation, device), and the slots whose action queue is empty go through one
``predict_action_chunk`` together; the post-processor turns the chunks into actions, and each slot
executes ``n_action_steps`` of its chunk (the policy's own setting) before it is asked again. This
is what LeRobot's ``select_action`` does for one environment, kept per slot, so slots may start and
end their episodes at different steps:

- a policy that reads ``n_obs_steps > 1`` observations (Diffusion Policy) gets each slot's last
  ones, the first repeated to fill the window at the start of an episode, as LeRobot does;
- a policy that samples (Diffusion Policy's noise) draws its initial noise per slot from the
  rollout and the chunk (``libero_data.seeding.policy_noise_seed``), so with a deterministic
  sampler (DDIM) a rollout's draws do not depend on the other rollouts in its batch; a sampler
  that draws again at every denoising step (DDPM, Diffusion Policy's default) draws from torch's
  generator for the whole batch, seeded by its first rollout and chunk: the same batch, the same
  draws, but a rollout's draws then depend on its batch;
- ACT's temporal ensembling needs a forward pass per step and environment, outside of this scheme:
  refused in one sentence.

Observations are served from the policy's declared inputs (:func:`libero_bench.rollouts.lerobot_inputs.inputs_from_features`).
"""

from __future__ import annotations

import inspect
from collections import deque
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from libero_bench.rollouts.actors import (
    ActionQueues,
    BatchActor,
    Observations,
    Start,
    chunked_answers,
    forward_threads,
)
from libero_bench.rollouts.lerobot_inputs import (
    SIM_STATE,
    SIM_STATE_DIM,
    Inputs,
    inputs_from_features,
    lerobot_config,
)
from libero_data.errors import InputError
from libero_data.seeding import policy_noise_seed


def state_input(obs: Mapping[str, Any], key: str, width: int) -> np.ndarray:
    """One state input of a LeRobot policy from an environment observation."""
    if key == "eef_pose":
        return np.concatenate([obs["eef_pos"], obs["eef_quat"]]).astype(np.float32)
    if key == SIM_STATE:
        padded = np.zeros(width, dtype=np.float32)
        state = np.asarray(obs["sim_state"], dtype=np.float32)[:width]
        padded[: state.shape[0]] = state
        return padded
    if key == SIM_STATE_DIM:
        return np.array([len(obs["sim_state"])], dtype=np.float32)
    return np.asarray(obs[key], dtype=np.float32)


def raw_batch(
    inputs: Inputs, observations: Sequence[Mapping[str, Any]], instructions: Sequence[str]
) -> dict[str, Any]:
    """The batch LeRobot's ``rollout`` would build from these observations (B rows), before the
    policy's pre-processor: images upright, float in [0, 1], at each input's size."""
    import torch
    import torch.nn.functional as F

    batch: dict[str, Any] = {"task": list(instructions)}
    for name, (camera, h, w) in inputs.cameras.items():
        pixels = np.stack([np.asarray(obs[camera]) for obs in observations])
        image = torch.from_numpy(np.ascontiguousarray(pixels)).permute(0, 3, 1, 2).float() / 255.0
        if image.shape[-2:] != (h, w):
            image = F.interpolate(image, size=(h, w), mode="bilinear", antialias=True, align_corners=False)
        batch[name] = image
    for name, (key, width) in inputs.states.items():
        batch[name] = torch.from_numpy(np.stack([state_input(obs, key, width) for obs in observations]))
    return batch


def _rows(batch: Mapping[str, Any], rows: Sequence[int], size: int) -> dict[str, Any]:
    """The rows ``rows`` of a processed batch of ``size`` rows (other entries as they are)."""
    import torch

    out: dict[str, Any] = {}
    for key, value in batch.items():
        if isinstance(value, torch.Tensor) and value.dim() > 0 and value.shape[0] == size:
            out[key] = value[list(rows)]
        elif isinstance(value, list) and len(value) == size:
            out[key] = [value[r] for r in rows]
        else:
            out[key] = value
    return out


class LeRobotActor(BatchActor):
    """A LeRobot ``pretrained_model/`` folder acting for many environments on ``device``."""

    def __init__(self, path: str | Path, device: str = "cpu") -> None:
        import torch
        from lerobot.policies.factory import get_policy_class, make_pre_post_processors

        super().__init__()
        path = Path(path)
        config = lerobot_config(path)
        if getattr(config, "temporal_ensemble_coeff", None) is not None:
            raise InputError(
                f"the {config.type} policy at {path} averages overlapping chunks (temporal_ensemble_coeff), "
                "which needs a forward pass per step and environment; evaluate it with the coefficient "
                "set to null (n_action_steps of each chunk are executed instead)",
                field="policy",
            )
        self.inputs = inputs_from_features(config.input_features, f"the {config.type} policy at {path}")
        config.device = device
        self.device = torch.device(device)
        self.config = config
        self.policy = get_policy_class(config.type).from_pretrained(str(path), config=config)
        self.policy.eval()
        self.preprocessor, self.postprocessor = make_pre_post_processors(
            policy_cfg=config,
            pretrained_path=str(path),
            preprocessor_overrides={"device_processor": {"device": device}},
        )
        self.n_obs = int(getattr(config, "n_obs_steps", 1) or 1)
        self.queues = ActionQueues(getattr(config, "n_action_steps", None))
        self.chunk_size = int(
            getattr(config, "n_action_steps", None) or getattr(config, "chunk_size", 1) or 1
        )
        cameras = {camera for camera, _h, _w in self.inputs.cameras.values()}
        self.reads = (*sorted(cameras), *(key for key, _width in self.inputs.states.values()))
        self._noise = "noise" in inspect.signature(self.policy.predict_action_chunk).parameters and hasattr(
            config, "horizon"
        )
        self._history: dict[int, deque[dict[str, Any]]] = {}
        self._job: dict[int, tuple[str, str]] = {}  # slot -> (rollout key, instruction)
        self._chunks: dict[int, int] = {}

    def begin(self, slot: int, start: Start) -> None:
        self.queues.clear(slot)
        self._history[slot] = deque(maxlen=self.n_obs)
        self._job[slot] = (start.key, start.language)
        self._chunks[slot] = 0

    def end(self, slot: int, success: bool | None = None) -> None:
        self.queues.drop(slot)
        for table in (self._history, self._job, self._chunks):
            table.pop(slot, None)

    def act(self, observations: Observations) -> dict[int, np.ndarray]:
        import torch

        slots = sorted(observations)
        if not slots:
            return {}
        with torch.inference_mode():
            raw = raw_batch(self.inputs, [observations[s] for s in slots], [self._job[s][1] for s in slots])
            processed = self.preprocessor(raw)
            for i, slot in enumerate(slots if self.n_obs > 1 else ()):  # windows of past observations
                row = {
                    k: v[i]
                    for k in self.config.input_features
                    if isinstance(v := processed.get(k), torch.Tensor)
                }
                history = self._history[slot]
                while len(history) < self.n_obs - 1:  # a new episode: its first observation repeated
                    history.append(row)
                history.append(row)
            waiting = self.queues.waiting(slots)
            if waiting:
                self._predict(waiting, _rows(processed, [slots.index(s) for s in waiting], len(slots)))
        return {s: np.asarray(self.queues.pop(s), dtype=np.float32).reshape(-1)[:7] for s in slots}

    def act_chunks(self, observations: Observations) -> dict[int, np.ndarray]:
        return chunked_answers(self, self.queues, observations)

    def _predict(self, waiting: list[int], batch: dict[str, Any]) -> None:
        """One forward pass for the slots in ``waiting``; fills their queues."""
        import torch

        if self.n_obs > 1:
            for key in self._history[waiting[0]][0]:
                batch[key] = torch.stack([torch.stack([h[key] for h in self._history[s]]) for s in waiting])
        kwargs = {}
        if self._noise:
            kwargs["noise"] = self._draw_noise(waiting)
        self.policy.reset()  # LeRobot's own queues stay empty: the batch is used as given
        with torch.random.fork_rng(devices=[self.device] if self.device.type == "cuda" else []):
            # Draws inside the sampler (DDPM's per-step noise) come from torch's global generator:
            # seeded by the first waiting rollout, they repeat with the same batch.
            first = waiting[0]
            torch.manual_seed(policy_noise_seed(self._job[first][0], self._chunks[first]) + 1)
            with forward_threads(self.device):
                chunk = self.policy.predict_action_chunk(batch, **kwargs)
        steps = self.queues.steps
        chunk = self.postprocessor(chunk[:, :steps] if steps else chunk)
        self.counted(len(waiting))
        out = chunk.detach().to("cpu", torch.float32).numpy()
        for j, slot in enumerate(waiting):
            self.queues.fill(slot, out[j])
            self._chunks[slot] += 1

    def _draw_noise(self, waiting: list[int]) -> Any:
        import torch

        action_dim = int(self.config.action_feature.shape[0])
        rows = []
        for slot in waiting:
            generator = torch.Generator().manual_seed(
                policy_noise_seed(self._job[slot][0], self._chunks[slot])
            )
            rows.append(torch.randn((self.config.horizon, action_dim), generator=generator))
        dtype = next(self.policy.parameters()).dtype
        return torch.stack(rows).to(self.device, dtype)

    def looks(self, slot: int) -> bool:
        # A policy reading several past observations keeps every one of them, chunk or not.
        return self.n_obs > 1 or self.queues.empty(slot)

    def ahead(self, slot: int) -> list[np.ndarray]:
        if self.n_obs > 1:  # every observation joins its history: one step per call
            return []
        return [np.asarray(a, dtype=np.float32).reshape(-1)[:7] for a in self.queues.take(slot)]

    def describe(self) -> dict[str, Any]:
        return {
            "actor": "lerobot",
            "policy_type": self.config.type,
            "device": str(self.device),
            "n_obs_steps": self.n_obs,
            "n_action_steps": self.queues.steps,
        }
