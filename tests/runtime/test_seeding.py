"""Every derived seed keeps the value it had before it moved into ``libero_data.seeding``
(datasets made before stay reproducible): the constants below were computed by the code as it
stood before (``experts.report.episode_seeds``, ``train._mix``), the rest are those formulas."""

from __future__ import annotations

import hashlib

import numpy as np

from libero_data import seeding


def _old_hash(text: str) -> int:
    return int.from_bytes(hashlib.sha256(text.encode()).digest()[:4], "little")


def test_episode_and_candidate_seeds_keep_their_values() -> None:
    for seed, key, index in [
        (0, "libero_goal/0", 0),
        (3, "libero_goal/turn_on_the_stove/0", 5),
        (11, "x", 49),
    ]:
        a, b = np.random.SeedSequence([seed, _old_hash(key), index]).generate_state(2)
        assert seeding.episode_seeds(seed, key, index) == (int(a), int(b))
        assert seeding.candidate_seed(seed, key, index) == int(a)
    assert seeding.demo_key("libero_goal", "turn_on_the_stove", 4) == "libero_goal/turn_on_the_stove/4"
    assert seeding.episode_seeds(0, "libero_goal/0", 0) == (2242875146, 2077513388)


def test_run_and_loader_seeds_keep_their_values() -> None:
    assert seeding.run_seed(0, 0, seeding.WEIGHTS) == 8270150236444146372
    assert seeding.run_seed(10000, 3, seeding.LOADER) == 3796575150752982347
    assert seeding.loader_epoch_seed(7, 2) == 7 * 1_000_003 + 2


def test_streams_and_rollout_starts() -> None:
    a = seeding.sampler_rng(4).integers(1 << 30, size=3)
    b = np.random.default_rng(np.random.SeedSequence([4, 0x11BE70])).integers(1 << 30, size=3)
    assert np.array_equal(a, b)
    c = seeding.variant_rng(1, 7, 2).random()
    assert c == np.random.default_rng(np.random.SeedSequence([1, 7, 2, 0x7A51])).random()
    assert seeding.rollout_start(53, 50) == (3, 53)
    assert seeding.rollout_start(4, 0) == (-1, 4)
