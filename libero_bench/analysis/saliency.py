"""Perturbation saliency of a policy's visual encoder (Greydanus et al. 2018, as used in the
LIBERO paper): how far the agentview latent moves when a small Gaussian neighbourhood of the
image is blurred.

For every ``stride``-th pixel (both directions) the image is mixed with a blurred copy of
itself under a Gaussian mask centred there, ``I' = I * (1 - M) + blur(I) * M``; the score is
``0.5 * ||f(I') - f(I)||^2`` for the encoder latent ``f``. The coarse score grid is upsampled
to the image size and normalised to [0, 1].
"""

from __future__ import annotations

import logging

import numpy as np
import torch
import torch.nn.functional as F
from numpy.typing import ArrayLike
from torch import Tensor

from libero_bench.policies.base import Policy, eval_mode

logger = logging.getLogger(__name__)


def _gaussian_kernel(sigma: float) -> Tensor:
    radius = max(1, round(3 * sigma))
    x = torch.arange(-radius, radius + 1, dtype=torch.float32)
    k = torch.exp(-(x**2) / (2 * sigma**2))
    return k / k.sum()


def gaussian_blur(image: Tensor, sigma: float) -> Tensor:
    """Separable Gaussian blur of (N, C, H, W) with reflected borders."""
    k = _gaussian_kernel(sigma).to(image)
    r = k.numel() // 2
    c = image.shape[1]
    pad_mode = "reflect" if min(image.shape[-2:]) > r else "replicate"
    x = F.pad(image, (r, r, 0, 0), mode=pad_mode)
    x = F.conv2d(x, k.view(1, 1, 1, -1).expand(c, 1, 1, -1), groups=c)
    x = F.pad(x, (0, 0, r, r), mode=pad_mode)
    return F.conv2d(x, k.view(1, 1, -1, 1).expand(c, 1, -1, 1), groups=c)


def saliency_map(
    policy: Policy,
    image: Tensor | np.ndarray,
    task_emb: Tensor | np.ndarray,
    stride: int = 5,
    mask_sigma: float = 5.0,
    blur_sigma: float = 3.0,
    batch_size: int = 64,
) -> np.ndarray:
    """Saliency (H, W) in [0, 1] of ``policy.visual_latent`` for one image (3, H, W) in
    [0, 1] and its task embedding (E,). Perturbed images go through the encoder in batches
    of ``batch_size``; the policy runs in eval mode without gradients."""
    param = next(policy.parameters())
    img = torch.as_tensor(image, dtype=torch.float32, device=param.device)
    emb = torch.as_tensor(task_emb, dtype=torch.float32, device=param.device)
    if img.dim() != 3 or img.shape[0] != 3:
        raise ValueError(f"image must be (3, H, W), got {tuple(img.shape)}")
    if emb.dim() != 1:
        raise ValueError(f"task_emb must be (E,), got {tuple(emb.shape)}")
    if stride <= 0 or batch_size <= 0:
        raise ValueError("stride and batch_size must be positive")
    _, h, w = img.shape
    img = img[None]
    blurred = gaussian_blur(img, blur_sigma)
    ys = torch.arange(0, h, stride, device=img.device)
    xs = torch.arange(0, w, stride, device=img.device)
    centres = torch.cartesian_prod(ys, xs).to(img.dtype)  # (P, 2)
    yy = torch.arange(h, device=img.device, dtype=img.dtype)
    xx = torch.arange(w, device=img.device, dtype=img.dtype)
    scores = []
    with torch.no_grad(), eval_mode(policy):
        base = policy.visual_latent(img, emb[None])
        for chunk in centres.split(batch_size):
            dy = (yy[None, :] - chunk[:, :1]) ** 2  # (n, H)
            dx = (xx[None, :] - chunk[:, 1:]) ** 2  # (n, W)
            mask = torch.exp(-(dy[:, :, None] + dx[:, None, :]) / (2 * mask_sigma**2))[:, None]
            perturbed = img * (1 - mask) + blurred * mask
            latent = policy.visual_latent(perturbed, emb[None].expand(len(chunk), -1))
            scores.append(0.5 * (latent - base).pow(2).flatten(1).sum(-1))
    coarse = torch.cat(scores).view(1, 1, len(ys), len(xs))
    full = F.interpolate(coarse, size=(h, w), mode="bilinear", align_corners=False)[0, 0]
    lo, hi = full.min(), full.max()
    normalised = (full - lo) / (hi - lo) if hi > lo else torch.zeros_like(full)
    return normalised.clamp(0, 1).cpu().numpy().astype(np.float32)


def _jet(values: np.ndarray) -> np.ndarray:
    v = values[..., None]
    centres = np.array([3.0, 2.0, 1.0])
    return np.clip(1.5 - np.abs(4.0 * v - centres), 0.0, 1.0)


def overlay(image: ArrayLike, saliency: ArrayLike, alpha: float = 0.5) -> np.ndarray:
    """Blend a jet-coloured saliency map over the image: uint8 (H, W, 3).

    ``image`` is (3, H, W) or (H, W, 3), floats in [0, 1] or uint8; ``saliency`` is (H, W)
    in [0, 1].
    """
    img = np.asarray(image)
    sal = np.clip(np.asarray(saliency, dtype=np.float64), 0.0, 1.0)
    if img.ndim != 3 or 3 not in (img.shape[0], img.shape[-1]):
        raise ValueError(f"image must be (3, H, W) or (H, W, 3), got {img.shape}")
    if img.shape[-1] != 3:
        img = np.moveaxis(img, 0, -1)
    rgb = img.astype(np.float64) / 255.0 if img.dtype == np.uint8 else img.astype(np.float64)
    if sal.shape != rgb.shape[:2]:
        raise ValueError(f"saliency must be {rgb.shape[:2]}, got {sal.shape}")
    if not 0.0 <= alpha <= 1.0:
        raise ValueError(f"alpha must be in [0, 1], got {alpha}")
    blended = (1.0 - alpha) * np.clip(rgb, 0.0, 1.0) + alpha * _jet(sal)
    return np.round(blended * 255.0).astype(np.uint8)
