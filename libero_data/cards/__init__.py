"""Hugging Face dataset cards (README.md with YAML metadata) for generated datasets."""

from libero_data.cards.card import CardTask, render_card

__all__ = ["CardTask", "render_card"]
