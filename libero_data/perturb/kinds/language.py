"""``language``: the instruction is paraphrased (1), then made polite (2), given a context phrase
(3), synonyms (4) and a trailing clause (5); the BDDL is otherwise unchanged."""

from __future__ import annotations

import dataclasses
import re
from typing import Any, ClassVar

import numpy as np

from libero_data.bddl.model import Problem
from libero_data.perturb.kinds.base import Kind, VariantSource, register


@register
class Language(Kind):
    order = 3
    rewrites_task = True
    summary = "how far the instruction is reworded (paraphrase, then politeness, context, synonyms, a trailing clause)"
    magnitudes: ClassVar[dict[str, tuple[Any, ...]]] = {
        "paraphrase": (True, True, True, True, True),
        "politeness": (False, True, True, True, True),
        "context_sentence": (False, False, True, True, True),
        "synonyms": (False, False, False, True, True),
        "trailing_clause": (False, False, False, False, True),
    }

    def vary(self, src: VariantSource, rng: np.random.Generator) -> Problem:
        return dataclasses.replace(src.problem, language=reword(src.problem.language, src.level, rng))


#: Paraphrase rules, tried in order (the first that applies is used).
PARAPHRASES = (
    (r"^pick up the (.+) and place it in the (.+)$", r"grab the \1 and put it into the \2"),
    (r"^put both the (.+) and the (.+) in the (.+)$", r"place the \1 and the \2 into the \3"),
    (r"^put the (.+) in the (.+) and close it$", r"place the \1 into the \2, then shut it"),
    (r"^turn on the stove and put the (.+) on it$", r"switch the stove on and set the \1 on it"),
    (r"^put the (.+) on top of the (.+)$", r"set the \1 on the top of the \2"),
    (r"^put the (.+) in the (.+)$", r"place the \1 into the \2"),
    (r"^put the (.+) on the (.+)$", r"set the \1 down on the \2"),
    (r"^place the (.+) on the (.+)$", r"put the \1 onto the \2"),
    (r"^pick the (.+) and place it on the (.+)$", r"take the \1 and set it on the \2"),
    (r"^pick up the (.+) and place it on the (.+)$", r"take the \1 and set it on the \2"),
    (r"^stack the (.+) on the (.+)$", r"put the \1 on top of the \2"),
    (r"^open the (.+)$", r"pull the \1 open"),
    (r"^close the (.+)$", r"shut the \1"),
    (r"^turn on the (.+)$", r"switch on the \1"),
    (r"^turn off the (.+)$", r"switch off the \1"),
    (r"^push the (.+) to the (.+)$", r"slide the \1 over to the \2"),
)


def paraphrase(language: str) -> str:
    language = language.strip().lower()
    for pattern, repl in PARAPHRASES:
        if re.match(pattern, language):
            return re.sub(pattern, repl, language)
    return f"please {language}"


#: Language levels 2–5: openings, context phrases, word swaps and closings (chosen by the seed).
POLITE = ("please ", "could you ", "i would like you to ", "go ahead and ")
CONTEXT = (
    "there are several things around so ",
    "take a look at the scene and then ",
    "without touching anything else ",
    "when the arm is ready ",
)
SYNONYMS = {
    "bowl": "dish",
    "basket": "bin",
    "cabinet": "cupboard",
    "mug": "cup",
    "stove": "cooktop",
    "plate": "platter",
    "grab": "grasp",
    "put": "move",
    "place": "move",
    "shut": "close",
}
CLOSINGS = (" and then stop", " as carefully as you can", " and leave the rest as it is", " please")


def reword(language: str, level: int, rng: np.random.Generator) -> str:
    """The instruction reworded as far as ``level`` says (see :attr:`Language.magnitudes`)."""
    m = {name: values[level - 1] for name, values in Language.magnitudes.items()}
    text = paraphrase(language)
    if m["synonyms"]:
        text = " ".join(SYNONYMS.get(word, word) for word in text.split())
    if m["politeness"] and not text.startswith("please "):
        text = POLITE[int(rng.integers(len(POLITE)))] + text
    if m["context_sentence"]:
        text = CONTEXT[int(rng.integers(len(CONTEXT)))] + text
    if m["trailing_clause"]:
        text += CLOSINGS[int(rng.integers(len(CLOSINGS)))]
    return text
