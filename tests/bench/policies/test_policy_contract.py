"""Every registered policy: distribution shapes, loss, deterministic acting, causality."""

from __future__ import annotations

import json

import pytest
import torch
from bench_helpers import BatchFactory

from libero_bench.policies import (
    POLICY_CONFIGS,
    build_policy,
    config_from_dict,
    make_policy,
    policy_config,
    policy_config_class,
    policy_names,
)
from libero_bench.policies.base import Policy
from libero_bench.policies.resnet_rnn.config import ResNetRNNConfig
from libero_bench.policies.resnet_t.config import ResNetTConfig
from libero_bench.policies.vit_t.config import ViTTConfig
from libero_bench.sizes import SIZES


def small(name: str, image_size: int = 32, **overrides: object) -> Policy:
    torch.manual_seed(0)
    return make_policy(name, "smoke", image_size=image_size, **overrides)


def test_registry_lists_the_three_policies() -> None:
    assert policy_names() == ["resnet_rnn", "resnet_t", "vit_t"]
    with pytest.raises(ValueError, match="already registered"):
        POLICY_CONFIGS.register("resnet_t")(ResNetTConfig)


@pytest.mark.parametrize("name", policy_names())
def test_forward_gives_a_distribution_per_timestep(name: str, make_batch: BatchFactory) -> None:
    policy = small(name).eval()  # no dropout, so forward and loss see the same network
    batch = make_batch(batch_size=3, window=5)
    dist = policy(batch)
    log_prob = dist.log_prob(batch["actions"])
    assert log_prob.shape == (3, 5)
    assert dist.mixture_distribution.logits.shape == (3, 5, 5)  # 5 GMM modes
    loss = policy.loss(batch)
    assert loss.dim() == 0 and torch.isfinite(loss)
    assert loss.item() == pytest.approx(-log_prob.mean().item(), rel=1e-5)
    loss.backward()
    grads = [p.grad for p in policy.parameters() if p.requires_grad]
    assert all(g is not None and torch.isfinite(g).all() for g in grads)


@pytest.mark.parametrize("name", policy_names())
def test_a_few_steps_fit_a_batch(name: str, make_batch: BatchFactory) -> None:
    policy = small(name)
    batch = make_batch()
    optimiser = torch.optim.Adam(policy.parameters(), lr=3e-3)
    policy.train()
    first = policy.loss(batch).item()
    for _ in range(15):
        optimiser.zero_grad()
        policy.loss(batch).backward()
        optimiser.step()
    assert policy.loss(batch).item() < first - 1.0


@pytest.mark.parametrize("name", policy_names())
def test_act_is_deterministic_and_matches_step_by_step(name: str, make_batch: BatchFactory) -> None:
    policy = small(name)
    policy.train()
    batch = make_batch(batch_size=2, window=4)
    action = policy.act(batch)
    assert action.shape == (2, 7)
    assert torch.isfinite(action).all() and action.abs().max() <= 1.0
    assert torch.equal(action, policy.act(batch))
    assert policy.training  # act leaves the mode as it found it
    # the mean of the most likely mode, read off the distribution of the last step
    with torch.no_grad():
        policy.eval()
        dist = policy(batch)
        best = dist.mixture_distribution.logits[:, -1].argmax(-1)
        means = dist.component_distribution.base_dist.loc[:, -1]
        torch.testing.assert_close(action, means[torch.arange(2), best])
    # feeding the frames one by one gives the same last action
    policy.reset()
    for t in range(4):
        frame = {k: (v[:, t : t + 1] if v.dim() > 2 else v) for k, v in batch.items()}
        stepped = policy.act_step(frame)
    torch.testing.assert_close(stepped, action, rtol=1e-5, atol=1e-5)
    policy.reset()
    with pytest.raises(ValueError, match="one frame"):
        policy.act_step(batch)


@pytest.mark.parametrize("name", policy_names())
def test_rows_of_one_batch_keep_their_own_episodes(name: str, make_batch: BatchFactory) -> None:
    """act_rows: three episodes share a batch but start at different steps (row 1 starts anew at
    step 3, as an environment that finished and took its next start); each row's actions are
    what act_step gives that episode alone."""
    policy = small(name, window=3) if name != "resnet_rnn" else small(name)
    frames = make_batch(batch_size=3, window=7, seed=4)
    frame = lambda t, rows: {k: (v[rows, t : t + 1] if v.dim() > 2 else v[rows]) for k, v in frames.items()}  # noqa: E731
    history: list[object] = [None, None, None]
    batched = []
    for t in range(7):
        if t == 3:
            history[1] = None
        actions, history = policy.act_rows(frame(t, [0, 1, 2]), history)
        batched.append(actions)
    for row in range(3):
        policy.reset()
        for t in range(7):
            if row == 1 and t == 3:
                policy.reset()
            alone = policy.act_step(frame(t, [row]))
            torch.testing.assert_close(batched[t][row : row + 1], alone, rtol=1e-4, atol=1e-5)
    with pytest.raises(ValueError, match="one history per row"):
        policy.act_rows(frame(0, [0, 1]), [None])


@pytest.mark.parametrize("name", policy_names())
def test_outputs_are_causal_in_time(name: str, make_batch: BatchFactory) -> None:
    policy = small(name).eval()
    batch = make_batch(window=4)
    changed = {k: v.clone() for k, v in batch.items()}
    changed["agentview"][:, -1] = torch.rand_like(changed["agentview"][:, -1])
    changed["joint_states"][:, -1] += 1.0
    with torch.no_grad():
        before = policy(batch).log_prob(batch["actions"])
        after = policy(changed).log_prob(batch["actions"])
    torch.testing.assert_close(before[:, :-1], after[:, :-1])
    assert not torch.allclose(before[:, -1], after[:, -1])


@pytest.mark.parametrize("name", policy_names())
@pytest.mark.parametrize("image_size", [32, 64, 128])
def test_image_sizes(name: str, image_size: int, make_batch: BatchFactory) -> None:
    policy = small(name, image_size=image_size, task_emb_dim=16)
    batch = make_batch(batch_size=1, window=2, image_size=image_size, task_emb_dim=16)
    assert policy(batch).log_prob(batch["actions"]).shape == (1, 2)
    latent = policy.visual_latent(batch["agentview"][:, 0], batch["task_emb"])
    assert latent.dim() == 2 and latent.shape[0] == 1


@pytest.mark.parametrize("name", policy_names())
def test_visual_latent_depends_on_the_image(name: str, make_batch: BatchFactory) -> None:
    policy = small(name).eval()
    batch = make_batch(batch_size=3)
    images, emb = batch["agentview"][:, 0], batch["task_emb"]
    with torch.no_grad():
        latent = policy.visual_latent(images, emb)
        other = policy.visual_latent(torch.rand_like(images), emb)
    assert latent.shape[0] == 3 and torch.isfinite(latent).all()
    assert not torch.allclose(latent, other)


@pytest.mark.parametrize("name", policy_names())
def test_bad_batches_are_named(name: str, make_batch: BatchFactory) -> None:
    policy = small(name)
    batch = make_batch(image_size=64)
    with pytest.raises(ValueError, match="agentview"):
        policy(batch)
    batch = make_batch()
    del batch["wrist"]
    with pytest.raises(ValueError, match="wrist"):
        policy(batch)
    batch = make_batch(task_emb_dim=10)
    with pytest.raises(ValueError, match="task_emb"):
        policy(batch)


@pytest.mark.parametrize("name", policy_names())
def test_configs_round_trip_and_validate(name: str) -> None:
    cls = type(build_policy(policy_config(name, "smoke")))
    assert cls.config_class is policy_config_class(name)
    for size in SIZES:
        config = policy_config(name, size)
        data = json.loads(json.dumps(config.to_dict()))
        assert data["type"] == name
        assert config_from_dict(data) == config
    smoke = policy_config(name, "smoke", image_size=32)
    assert cls.from_config(smoke).config is smoke
    other = next(n for n in policy_names() if n != name)
    with pytest.raises(TypeError, match="needs a"):
        cls.from_config(policy_config(other, "smoke"))
    with pytest.raises(ValueError, match=rf"{cls.config_class.__name__}\.window"):
        cls.config_class(window=0)
    with pytest.raises(ValueError, match=rf"{cls.config_class.__name__}\.num_modes"):
        cls.config_class(num_modes=-1)
    with pytest.raises(ValueError, match="unknown size"):
        policy_config(name, "large")


@pytest.mark.parametrize("name", policy_names())
def test_quick_size_lies_between_smoke_and_paper(name: str, make_batch: BatchFactory) -> None:
    counts = {}
    for size in SIZES:
        policy = make_policy(name, size, image_size=64)
        counts[size] = sum(p.numel() for p in policy.parameters())
    assert counts["smoke"] < counts["quick"] < counts["paper"]
    quick = make_policy(name, "quick", image_size=32)
    loss = quick.loss(make_batch(batch_size=2, window=3))
    loss.backward()
    assert torch.isfinite(loss)
    assert not quick.config.augment  # the quick preset turns augmentation on with augment=true


def test_paper_sizes_follow_the_libero_configs() -> None:
    rnn = policy_config("resnet_rnn")
    assert isinstance(rnn, ResNetRNNConfig)
    assert (rnn.image_embed_dim, rnn.text_embed_dim, rnn.rnn_hidden_dim, rnn.rnn_num_layers) == (
        64,
        32,
        1024,
        2,
    )
    t = policy_config("resnet_t")
    assert isinstance(t, ResNetTConfig)
    assert (t.embed_dim, t.num_layers, t.num_heads, t.head_dim, t.mlp_dim, t.dropout) == (
        64,
        4,
        6,
        64,
        256,
        0.1,
    )
    v = policy_config("vit_t")
    assert isinstance(v, ViTTConfig)
    assert (v.embed_dim, v.spatial_num_layers, v.spatial_num_heads, v.spatial_head_dim) == (128, 7, 8, 120)
    assert (v.patch_size, v.temporal_dim, v.num_layers, v.num_heads) == (8, 64, 4, 6)
    for c in (rnn, t, v):
        assert (c.num_modes, c.head_hidden_dim, c.head_num_layers, c.window) == (5, 1024, 2, 10)
    with pytest.raises(ValueError, match=r"ViTTConfig\.image_size"):
        policy_config("vit_t", image_size=40)
    with pytest.raises(ValueError, match=r"ResNetTConfig\.resnet_channels"):
        policy_config("resnet_t", resnet_channels=(8,))


def test_augmentation_only_in_training(make_batch: BatchFactory) -> None:
    policy = small("resnet_t", augment=True)
    batch = make_batch()
    policy.eval()
    with torch.no_grad():
        a = policy(batch).log_prob(batch["actions"])
        b = policy(batch).log_prob(batch["actions"])
    torch.testing.assert_close(a, b)
    policy.train()
    torch.manual_seed(1)
    with torch.no_grad():
        c = policy.loss(batch)
        d = policy.loss(batch)
    assert c.item() != d.item()
