"""Training-time image augmentation of LIBERO: a random translation (replicate padding and a
random crop) and a colour jitter (brightness, contrast, saturation, hue), both drawn once per
sample and shared by its cameras and frames."""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import Tensor

_LUMA = (0.299, 0.587, 0.114)


def _uniform(n: int, low: float, high: float, like: Tensor, generator: torch.Generator | None) -> Tensor:
    u = torch.rand(n, generator=generator, device=generator.device if generator else like.device)
    return (low + (high - low) * u).to(like.device, like.dtype)


def _gray(x: Tensor) -> Tensor:
    r, g, b = x.unbind(dim=-3)
    return (_LUMA[0] * r + _LUMA[1] * g + _LUMA[2] * b).unsqueeze(-3)


def _shift_hue(x: Tensor, shift: Tensor) -> Tensor:
    """Rotate hue by ``shift`` (fraction of a turn), per sample: x (B, ..., 3, H, W).

    RGB to HSV, then the closed form of HSV to RGB (channel n = V - V S clamp(min(k, 4 - k), 0, 1)
    with k = (n + 6 H) mod 6 for n = 5, 3, 1): the same result as the six-sector form
    (torchvision's adjust_hue) at a third of its cost, which matters on CPU where the hue is most
    of an augmented batch.
    """
    r, g, b = x.unbind(dim=-3)
    maxc, argmax = x.max(dim=-3)
    delta = maxc - x.amin(dim=-3)
    safe = torch.where(delta > 0, delta, torch.ones_like(delta))
    hue6 = torch.where(
        argmax == 0, ((g - b) / safe) % 6, torch.where(argmax == 1, (b - r) / safe + 2, (r - g) / safe + 4)
    )
    hue6 = torch.where(delta > 0, hue6, torch.zeros_like(hue6))
    hue6 = (hue6 + 6.0 * shift.view(-1, *([1] * (hue6.dim() - 1)))) % 6.0
    channels = []
    for n in (5.0, 3.0, 1.0):
        k = (hue6 + n) % 6.0
        channels.append(maxc - delta * torch.clamp(torch.minimum(k, 4.0 - k), 0.0, 1.0))
    return torch.stack(channels, dim=-3)


def _color_jitter(x: Tensor, strength: float, generator: torch.Generator | None, skip_prob: float) -> Tensor:
    b = x.shape[0]
    view = (b,) + (1,) * (x.dim() - 1)
    out = x * _uniform(b, 1 - strength, 1 + strength, x, generator).view(view)
    out = out.clamp(0, 1)
    mean = _gray(out).mean(dim=(-1, -2, -3), keepdim=True)
    out = ((out - mean) * _uniform(b, 1 - strength, 1 + strength, x, generator).view(view) + mean).clamp(0, 1)
    gray = _gray(out)
    out = ((out - gray) * _uniform(b, 1 - strength, 1 + strength, x, generator).view(view) + gray).clamp(0, 1)
    out = _shift_hue(out, _uniform(b, -strength, strength, x, generator))
    keep = _uniform(b, 0, 1, x, generator) < skip_prob
    return torch.where(keep.view(view), x, out.clamp(0, 1))


def _translate(x: Tensor, translation: int, generator: torch.Generator | None) -> Tensor:
    b, *_, h, w = x.shape
    pad = translation // 2
    if pad == 0:
        return x
    flat = x.reshape(b, -1, h, w)
    padded = F.pad(flat, (pad, pad, pad, pad), mode="replicate")
    offsets = torch.randint(
        0, 2 * pad + 1, (b, 2), generator=generator, device=generator.device if generator else x.device
    )
    crops = [padded[i, :, oy : oy + h, ox : ox + w] for i, (oy, ox) in enumerate(offsets.tolist())]
    return torch.stack(crops).view_as(x)


def augment_images(
    images: list[Tensor],
    translation: int = 8,
    color_jitter: float = 0.3,
    skip_prob: float = 0.1,
    generator: torch.Generator | None = None,
) -> list[Tensor]:
    """Augment camera streams (each (B, T, 3, H, W) in [0, 1]) with one draw per sample.

    ``translation`` is the padded size (the image moves by up to translation / 2 pixels);
    ``color_jitter`` the strength of each jitter factor; ``skip_prob`` the chance that a
    sample keeps its original colours (LIBERO's epsilon).
    """
    if not images:
        return images
    sizes = [im.shape[1] for im in images]
    x = torch.cat(images, dim=1)  # (B, sum T, 3, H, W): one draw for all cameras of a sample
    if color_jitter > 0:
        x = _color_jitter(x, color_jitter, generator, skip_prob)
    if translation > 0:
        x = _translate(x, translation, generator)
    return list(torch.split(x, sizes, dim=1))
