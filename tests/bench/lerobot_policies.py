"""Tiny LeRobot policies made in place (no lerobot-train run, no downloaded weights): an ACT and a
Diffusion Policy with random weights and normalisation statistics, saved as pretrained_model/
folders with their processor pipelines, for tests of the evaluation paths."""

from __future__ import annotations

from pathlib import Path
from typing import Any

CAMERAS = ("observation.images.image", "observation.images.wrist_image")


def _features(image_size: int) -> tuple[dict[str, Any], dict[str, Any]]:
    from lerobot.configs.types import FeatureType, PolicyFeature

    inputs = {
        name: PolicyFeature(type=FeatureType.VISUAL, shape=(3, image_size, image_size)) for name in CAMERAS
    }
    inputs["observation.state"] = PolicyFeature(type=FeatureType.STATE, shape=(8,))
    return inputs, {"action": PolicyFeature(type=FeatureType.ACTION, shape=(7,))}


def _stats() -> dict[str, dict[str, Any]]:
    import torch

    stats: dict[str, dict[str, Any]] = {
        name: {"mean": torch.full((3, 1, 1), 0.5), "std": torch.full((3, 1, 1), 0.25)} for name in CAMERAS
    }
    stats["observation.state"] = {"mean": torch.zeros(8), "std": torch.ones(8)}
    stats["action"] = {"mean": torch.zeros(7), "std": torch.full((7,), 0.5)}
    for entry in stats.values():
        entry["min"], entry["max"] = entry["mean"] - 2 * entry["std"], entry["mean"] + 2 * entry["std"]
    return stats


def save_policy(kind: str, out: Path, image_size: int = 32, seed: int = 0, scheduler: str = "DDIM") -> Path:
    """A random ``kind`` ("act" or "diffusion") policy saved at ``out``; returns ``out``. Diffusion
    Policy samples with ``scheduler`` (DDIM: its only draw is the initial noise)."""
    import torch
    from lerobot.policies.factory import get_policy_class, make_policy_config, make_pre_post_processors

    inputs, outputs = _features(image_size)
    options: dict[str, Any] = {"device": "cpu", "input_features": inputs, "output_features": outputs}
    if kind == "act":
        options.update(
            dim_model=32,
            dim_feedforward=64,
            n_encoder_layers=1,
            n_decoder_layers=1,
            chunk_size=5,
            n_action_steps=5,
            pretrained_backbone_weights=None,
        )
    else:
        options.update(
            down_dims=(16, 32),
            crop_shape=None,
            num_inference_steps=2,
            horizon=8,
            n_action_steps=4,
            use_group_norm=True,
            pretrained_backbone_weights=None,
            noise_scheduler_type=scheduler,
        )
    config = make_policy_config(kind, **options)
    torch.manual_seed(seed)
    policy = get_policy_class(kind)(config)
    pre, post = make_pre_post_processors(config, dataset_stats=_stats())
    out.mkdir(parents=True, exist_ok=True)
    policy.save_pretrained(out)
    pre.save_pretrained(out)
    post.save_pretrained(out)
    return out
