"""What the registries hold, written into README and docs/ between markers, never by hand.

A Markdown file marks a block ``<!-- registry:NAME -->`` ... ``<!-- /registry:NAME -->``; this
module makes each block's text from its registry (:data:`BLOCKS`): the robustness kinds and
their level table, the lifelong algorithms, the policies, the kinds of policy an evaluation
accepts and the demonstration sources. Each entry speaks for itself: a kind's ``summary`` and
``magnitudes``, and for the others the first sentence of the module that registers them. So
adding an entry is one file, and the documents follow with

    python -m libero_bench.registry_docs          # rewrite the blocks
    python -m libero_bench.registry_docs --check  # say which blocks miss which entries

(``tests/test_registry_docs.py`` runs the check.)
"""

from __future__ import annotations

import argparse
import re
import sys
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
#: The documents that may hold blocks.
DOCUMENTS = ("README.md", "ARCHITECTURE.md", "docs/*.md")
BLOCK = re.compile(r"<!-- registry:(?P<name>[a-z-]+) -->(?P<body>.*?)<!-- /registry:(?P=name) -->", re.S)
NUMBERS = [
    "zero",
    "one",
    "two",
    "three",
    "four",
    "five",
    "six",
    "seven",
    "eight",
    "nine",
    "ten",
    "eleven",
    "twelve",
]


def ours(entry: Any) -> bool:
    """Whether a registry entry is defined in this project's packages (a test may register a
    throw-away entry in its own process, which the documents do not list)."""
    module = entry if isinstance(entry, str) else entry.__module__
    return module.startswith(("libero_data.", "libero_bench."))


@dataclass(frozen=True)
class Block:
    """One kind of block: the registry's entry names, and the text made from them."""

    names: Callable[[], list[str]]
    text: Callable[[], str]


def number(n: int) -> str:
    """``n`` as prose writes it: a word up to twelve, digits beyond."""
    return NUMBERS[n] if 0 <= n < len(NUMBERS) else str(n)


def first_sentence(obj: Any) -> str:
    """The first sentence of the docstring of the module that defines ``obj``, in Markdown."""
    module = sys.modules[obj if isinstance(obj, str) else obj.__module__]
    text = " ".join((module.__doc__ or "").split())
    sentence = re.split(r"(?<=[.!?])\s+(?=[A-Z(`])", text, maxsplit=1)[0]
    sentence = re.sub(r":\w+:`~?(?:[\w.]+\.)?([\w]+)`", r"`\1`", sentence)  # :mod:`~a.b` -> `b`
    return sentence.replace("``", "`")


# -- robustness kinds ------------------------------------------------------------------------------
def _kinds() -> list[Any]:
    from libero_data.perturb.kinds import all_kinds

    return [k for k in all_kinds() if ours(type(k))]


def kind_names() -> str:
    kinds = _kinds()
    return f"{number(len(kinds))} kinds ({', '.join(k.name for k in kinds)})"


def _bullets(kinds: list[Any]) -> list[str]:
    return [f"- `{k.name}`: {k.summary}{'.' if i == len(kinds) - 1 else ';'}" for i, k in enumerate(kinds)]


def kinds_section() -> str:
    from libero_data.perturb.levels import level_table

    kinds = _kinds()
    scene = [k for k in kinds if k.rewrites_task]
    seen = [k for k in kinds if not k.rewrites_task]
    lines = [
        f"{number(len(scene)).capitalize()} kinds change the scene and its task (a variant is a new BDDL file):",
        "",
    ]
    lines += _bullets(scene)
    lines += [
        "",
        f"{number(len(seen)).capitalize()} kinds change what the policy perceives and leave the task as it is "
        "(the simulator applies them):",
        "",
    ]
    lines += _bullets(seen)
    lines += ["", "Magnitudes per level:", "", level_table()]
    return "\n".join(lines)


# -- libero_bench's registries ---------------------------------------------------------------------
def _table(header: str, rows: Iterable[tuple[str, str]]) -> str:
    lines = [header, "|---|---|"]
    lines += [f"| `{name}` | {what} |" for name, what in rows]
    return "\n".join(lines)


def _algorithms() -> list[Any]:
    from libero_bench.algos import ALGO_CONFIGS, algo_names

    return [c for c in (ALGO_CONFIGS.get(name) for name in algo_names()) if ours(c)]


def algorithms_table() -> str:
    return _table("| `--algo` | what it is |", ((c.name, first_sentence(c)) for c in _algorithms()))


def _policies() -> list[Any]:
    from libero_bench.policies import POLICY_CONFIGS, policy_names

    return [c for c in (POLICY_CONFIGS.get(name) for name in policy_names()) if ours(c)]


def policies_table() -> str:
    rows = ((c.name, first_sentence(c).removeprefix("Config of ")) for c in _policies())
    return _table("| `--policy` | what it is |", rows)


def _policy_kinds() -> list[Any]:
    from libero_bench.rollouts.policy_kinds import policy_kinds

    return [k for k in policy_kinds() if ours(k.source)]


def policy_kinds_table() -> str:
    rows = ((k.name, first_sentence(k.source)) for k in _policy_kinds())
    return _table("| kind | what names one |", rows)


def _sources() -> list[Any]:
    from libero_data.pipeline.sources import demo_sources

    return [s for s in demo_sources() if ours(type(s))]


def sources_table() -> str:
    return _table(
        "| source | where its episodes come from |", ((s.name, first_sentence(s)) for s in _sources())
    )


BLOCKS: dict[str, Block] = {
    "kind-names": Block(lambda: [k.name for k in _kinds()], kind_names),
    "kinds": Block(lambda: [k.name for k in _kinds()], kinds_section),
    "algorithms": Block(lambda: [c.name for c in _algorithms()], algorithms_table),
    "policies": Block(lambda: [c.name for c in _policies()], policies_table),
    "policy-kinds": Block(lambda: [k.name for k in _policy_kinds()], policy_kinds_table),
    "sources": Block(lambda: [s.name for s in _sources()], sources_table),
}


def documents(root: Path = ROOT) -> list[Path]:
    return sorted({p for pattern in DOCUMENTS for p in root.glob(pattern)})


def _wrapped(text: str) -> str:
    """A block's body: on lines of its own where the text has several, inline otherwise."""
    return f"\n\n{text}\n\n" if "\n" in text else text


def rewrite(text: str) -> str:
    """``text`` with every block made again from its registry."""

    def made(match: re.Match[str]) -> str:
        name = match["name"]
        if name not in BLOCKS:
            raise KeyError(f"unknown registry block {name!r}; known: {', '.join(BLOCKS)}")
        body = _wrapped(BLOCKS[name].text())
        return f"<!-- registry:{name} -->{body}<!-- /registry:{name} -->"

    return BLOCK.sub(made, text)


def problems(root: Path = ROOT) -> list[str]:
    """What the documents miss of the registries: per stale block, the entries it lacks or
    names in excess (or that it differs in what it says of them); blocks no document holds."""
    out = []
    found: set[str] = set()
    for path in documents(root):
        text = path.read_text()
        for match in BLOCK.finditer(text):
            name, body = match["name"], match["body"]
            where = f"{path.relative_to(root)}, block {name!r}"
            if name not in BLOCKS:
                out.append(f"{where}: no registry makes it (known: {', '.join(BLOCKS)})")
                continue
            found.add(name)
            if body == _wrapped(BLOCKS[name].text()):
                continue
            entries = BLOCKS[name].names()
            missing = [e for e in entries if not re.search(rf"(?<![\w-]){re.escape(e)}(?![\w-])", body)]
            said = f"misses {', '.join(missing)}" if missing else "says something else of them"
            out.append(f"{where}: {said} (the registry holds {', '.join(entries)})")
    out += [f"no document holds the block {name!r}" for name in BLOCKS if name not in found]
    return out


def run(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "--check", action="store_true", help="Change nothing; list the blocks that are out of date."
    )
    args = parser.parse_args(argv)
    if args.check:
        found = problems()
        for line in found:
            print(line)
        return 1 if found else 0
    for path in documents():
        text = path.read_text()
        new = rewrite(text)
        if new != text:
            path.write_text(new)
            print(f"rewrote {path.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(run())
