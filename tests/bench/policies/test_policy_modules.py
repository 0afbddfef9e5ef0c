"""Building blocks: GMM head, block-causal mask, positions, spatial softmax, augmentation."""

from __future__ import annotations

import torch

from libero_bench.policies.modules import (
    FiLMResNetEncoder,
    GMMHead,
    PatchEncoder,
    SinusoidalPositionEncoding,
    SpatialSoftmax,
    augment_images,
    block_causal_mask,
    gmm_mode_mean,
)


def test_gmm_head_shapes_and_mode_mean() -> None:
    torch.manual_seed(0)
    head = GMMHead(6, 7, hidden_dim=8, num_layers=2, num_modes=5)
    dist = head(torch.randn(2, 3, 6))
    assert dist.batch_shape == (2, 3) and dist.event_shape == (7,)
    assert dist.log_prob(torch.zeros(2, 3, 7)).shape == (2, 3)
    mean = gmm_mode_mean(dist)
    logits = dist.mixture_distribution.logits
    locs = dist.component_distribution.base_dist.loc
    for i in range(2):
        for t in range(3):
            assert torch.equal(mean[i, t], locs[i, t, logits[i, t].argmax()])
    stds = dist.component_distribution.base_dist.scale
    assert (stds >= 1e-4).all() and (locs.abs() <= 1).all()


def test_block_causal_mask() -> None:
    mask = block_causal_mask(3, 2)
    expected = torch.tensor(
        [
            [1, 1, 0, 0, 0, 0],
            [1, 1, 0, 0, 0, 0],
            [1, 1, 1, 1, 0, 0],
            [1, 1, 1, 1, 0, 0],
            [1, 1, 1, 1, 1, 1],
            [1, 1, 1, 1, 1, 1],
        ],
        dtype=torch.bool,
    )
    assert torch.equal(mask, expected)


def test_sinusoidal_positions() -> None:
    enc = SinusoidalPositionEncoding(6, base=10.0)
    pos = enc(4)
    assert pos.shape == (4, 6)
    assert torch.allclose(pos[0], torch.tensor([0.0, 0.0, 0.0, 1.0, 1.0, 1.0]))
    assert torch.allclose(pos[2, 0], torch.sin(torch.tensor(2.0)))
    assert SinusoidalPositionEncoding(5)(3).shape == (3, 5)


def test_spatial_softmax_finds_the_peak() -> None:
    layer = SpatialSoftmax(1, 5, 5, num_keypoints=1)
    x = torch.full((1, 1, 5, 5), -1e4)
    x[0, 0, 4, 0] = 0.0  # bottom-left corner: x = -1, y = +1
    assert torch.allclose(layer(x), torch.tensor([[-1.0, 1.0]]))


def test_film_conditions_on_language() -> None:
    torch.manual_seed(0)
    enc = FiLMResNetEncoder(32, 8, lang_dim=4, channels=(4, 8)).eval()
    images = torch.rand(2, 3, 32, 32)
    lang = torch.randn(2, 4)
    out = enc(images, lang)
    assert out.shape == (2, 8)
    assert not torch.allclose(out, enc(images, lang + 1.0))
    plain = FiLMResNetEncoder(32, 8, lang_dim=4, channels=(4, 8), film=False).eval()
    assert torch.equal(plain(images, lang), plain(images, lang + 1.0))


def test_patch_encoder_token_count() -> None:
    enc = PatchEncoder(128, patch_size=8, embed_dim=16, stem_channels=4)
    assert enc(torch.rand(2, 3, 128, 128)).shape == (2, 64, 16)
    assert enc.num_patches == 64


def test_augmentation_keeps_range_and_shares_draws() -> None:
    g = torch.Generator().manual_seed(0)
    agent = torch.rand(4, 3, 3, 16, 16)
    wrist = agent.clone()
    out_agent, out_wrist = augment_images([agent, wrist], translation=4, color_jitter=0.3, generator=g)
    assert out_agent.shape == agent.shape and out_wrist.shape == wrist.shape
    assert out_agent.min() >= 0 and out_agent.max() <= 1
    # one draw per sample: identical cameras stay identical, frames move together
    assert torch.equal(out_agent, out_wrist)
    assert not torch.equal(out_agent, agent)
    # a pure translation (no colour change) is a shift of the whole window
    g = torch.Generator().manual_seed(1)
    (shifted,) = augment_images([agent], translation=4, color_jitter=0.0, generator=g)
    inner = agent[..., 2:-2, 2:-2]
    found = any(
        torch.equal(shifted[0, :, :, 2 + dy : 14 + dy, 2 + dx : 14 + dx], inner[0])
        for dy in range(-2, 3)
        for dx in range(-2, 3)
    )
    assert found


def test_hue_shift_of_zero_is_identity() -> None:
    from libero_bench.policies.modules.augment import _shift_hue

    x = torch.rand(3, 2, 3, 8, 8)
    torch.testing.assert_close(_shift_hue(x, torch.zeros(3)), x, atol=1e-5, rtol=0)
    full_turn = _shift_hue(x, torch.ones(3))
    torch.testing.assert_close(full_turn, x, atol=1e-5, rtol=0)
    gray = torch.full((1, 3, 4, 4), 0.5)
    torch.testing.assert_close(_shift_hue(gray, torch.tensor([0.3])), gray)


def test_hue_shift_matches_torchvision() -> None:
    import torchvision.transforms.functional as tvf

    from libero_bench.policies.modules.augment import _shift_hue

    g = torch.Generator().manual_seed(3)
    x = torch.rand(4, 2, 3, 16, 16, generator=g)
    x[0, 0, :, :4, :4] = 0.5  # gray pixels: no hue to rotate
    x[1, 0, 1, :4, :4] = x[1, 0, 0, :4, :4]  # red and green tie for the maximum
    shift = torch.tensor([0.3, -0.25, 0.1, -0.5])
    expected = torch.stack(
        [torch.stack([tvf.adjust_hue(x[i, t], float(shift[i])) for t in range(2)]) for i in range(4)]
    )
    torch.testing.assert_close(_shift_hue(x, shift), expected, atol=1e-5, rtol=0)
