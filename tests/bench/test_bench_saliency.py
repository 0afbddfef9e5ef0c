"""Perturbation saliency: a map in [0, 1] that finds what the encoder looks at."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from torch import Tensor, nn

from libero_bench.analysis.saliency import gaussian_blur, overlay, saliency_map
from libero_bench.policies import make_policy


class CornerEncoder(nn.Module):
    """A stand-in policy whose visual latent only reads the top-left 8x8 pixels."""

    def __init__(self) -> None:
        super().__init__()
        self.scale = nn.Parameter(torch.ones(()))

    def visual_latent(self, images: Tensor, task_emb: Tensor) -> Tensor:
        return self.scale * images[:, :, :8, :8].flatten(1)


def test_map_of_a_tiny_policy() -> None:
    torch.manual_seed(0)
    policy = make_policy("resnet_t", "smoke", image_size=32)
    policy.train()
    image = torch.rand(3, 32, 32)
    emb = torch.randn(384)
    sal = saliency_map(policy, image, emb)
    assert sal.shape == (32, 32) and sal.dtype == np.float32
    assert np.isfinite(sal).all() and sal.min() == 0.0 and sal.max() == 1.0
    assert policy.training  # mode restored
    # batching the perturbed images does not change the result
    np.testing.assert_allclose(saliency_map(policy, image, emb, batch_size=5), sal, atol=1e-5)


def test_map_finds_the_region_the_encoder_reads() -> None:
    torch.manual_seed(0)
    image = torch.rand(3, 40, 40)
    sal = saliency_map(CornerEncoder(), image, torch.zeros(4))  # type: ignore[arg-type]
    assert sal[:8, :8].mean() > 0.5
    assert sal[24:, 24:].max() < 0.05


def test_vit_latent_map() -> None:
    policy = make_policy("vit_t", "smoke", image_size=32)
    sal = saliency_map(policy, np.random.default_rng(0).random((3, 32, 32)), np.zeros(384), stride=4)
    assert sal.shape == (32, 32) and sal.min() >= 0.0 and sal.max() <= 1.0


def test_blur_and_bad_inputs() -> None:
    flat = torch.full((1, 3, 16, 16), 0.3)
    torch.testing.assert_close(gaussian_blur(flat, 3.0), flat)
    noisy = torch.rand(1, 3, 16, 16)
    assert gaussian_blur(noisy, 3.0).std() < noisy.std()
    policy = make_policy("resnet_t", "smoke", image_size=32)
    with pytest.raises(ValueError, match="image"):
        saliency_map(policy, torch.rand(32, 32), torch.zeros(384))


def test_overlay() -> None:
    image = np.random.default_rng(0).random((3, 8, 8)).astype(np.float32)
    sal = np.linspace(0, 1, 64).reshape(8, 8)
    out = overlay(image, sal)
    assert out.shape == (8, 8, 3) and out.dtype == np.uint8
    np.testing.assert_array_equal(overlay(image, sal, alpha=0.0), np.round(image.transpose(1, 2, 0) * 255))
    hot = overlay(np.zeros((8, 8, 3), dtype=np.uint8), np.ones((8, 8)), alpha=1.0)
    assert tuple(hot[0, 0]) == (128, 0, 0)  # the top of the jet scale is dark red
    cold = overlay(np.zeros((8, 8, 3), dtype=np.uint8), np.zeros((8, 8)), alpha=1.0)
    assert tuple(cold[0, 0]) == (0, 0, 128)
    with pytest.raises(ValueError, match="saliency"):
        overlay(image, np.zeros((4, 4)))
