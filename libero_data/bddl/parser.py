"""Parser for LIBERO BDDL problem files: text -> :class:`~libero_data.bddl.model.Problem`.

Every failure raises :class:`BDDLError` naming the source, the line and the problem.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from libero_data.bddl.model import (
    CANONICAL_PREDICATE,
    PREDICATES,
    And,
    Atom,
    Entity,
    Formula,
    Not,
    Or,
    Problem,
    Region,
)
from libero_data.errors import BDDLError

_BLOCKS = (
    ":domain",
    ":language",
    ":regions",
    ":fixtures",
    ":objects",
    ":obj_of_interest",
    ":init",
    ":goal",
)
_REQUIRED = (":domain", ":language", ":regions", ":fixtures", ":objects", ":init", ":goal")
_REGION_ATTRIBUTES = (":target", ":ranges", ":yaw_rotation", ":rgba")


@dataclass(frozen=True)
class _Sym:
    text: str
    line: int


@dataclass(frozen=True)
class _List:
    items: tuple[_Sym | _List, ...]
    line: int


_Node = _Sym | _List


class _Reader:
    def __init__(self, text: str, source: str) -> None:
        self.text = text
        self.source = source

    def error(self, problem: str, line: int | None) -> BDDLError:
        return BDDLError(problem, source=self.source, line=line)

    def tokens(self) -> list[tuple[str, int]]:
        out: list[tuple[str, int]] = []
        for lineno, raw in enumerate(self.text.splitlines(), start=1):
            line = raw.split(";", 1)[0]
            for piece in line.replace("(", " ( ").replace(")", " ) ").split():
                out.append((piece, lineno))
        return out

    def tree(self) -> _List:
        stack: list[tuple[list[_Node], int]] = []
        root: _List | None = None
        for tok, line in self.tokens():
            if root is not None:
                raise self.error(f"unexpected {tok!r} after the end of the problem", line)
            if tok == "(":
                stack.append(([], line))
            elif tok == ")":
                if not stack:
                    raise self.error("unbalanced parentheses: ')' without a matching '('", line)
                items, start = stack.pop()
                node = _List(tuple(items), start)
                if stack:
                    stack[-1][0].append(node)
                else:
                    root = node
            else:
                if not stack:
                    raise self.error(f"unexpected {tok!r} outside the problem", line)
                stack[-1][0].append(_Sym(tok, line))
        if stack:
            raise self.error("unbalanced parentheses: '(' is never closed", stack[-1][1])
        if root is None:
            raise self.error("empty file: no (define (problem ...)) found", None)
        return root


def _sym(reader: _Reader, node: _Node, what: str) -> str:
    if not isinstance(node, _Sym):
        raise reader.error(f"expected {what}, found a parenthesised list", node.line)
    return node.text


def _number(reader: _Reader, node: _Node, what: str) -> float:
    text = _sym(reader, node, what)
    try:
        value = float(text)
    except ValueError:
        raise reader.error(f"{what} must be a number, found {text!r}", node.line) from None
    if not math.isfinite(value):
        raise reader.error(f"{what} must be finite, found {text!r}", node.line)
    return value


def _typed_list(reader: _Reader, block: _List, what: str) -> list[Entity]:
    """``name_1 name_2 - category`` groups, as in PDDL typed lists."""
    entities: list[Entity] = []
    pending: list[_Sym] = []
    items = list(block.items[1:])
    i = 0
    while i < len(items):
        node = items[i]
        text = _sym(reader, node, f"a {what} name")
        if text == "-":
            if i + 1 >= len(items):
                raise reader.error(f"'-' without a category in {what}s", node.line)
            category = _sym(reader, items[i + 1], f"a {what} category")
            if not pending:
                raise reader.error(f"category {category!r} names no {what}", node.line)
            entities.extend(Entity(p.text, category) for p in pending)
            pending = []
            i += 2
            continue
        pending.append(node)  # type: ignore[arg-type]
        i += 1
    if pending:
        raise reader.error(f"{what} {pending[0].text!r} has no category ('- category')", pending[0].line)
    return entities


def _region(reader: _Reader, node: _Node) -> Region:
    if not isinstance(node, _List) or not node.items:
        raise reader.error("a region must be a list '(name (:target ...) ...)'", node.line)
    name = _sym(reader, node.items[0], "a region name")
    target: str | None = None
    ranges: list[tuple[float, float, float, float]] = []
    yaw: tuple[float, float] | None = None
    rgba: tuple[float, float, float, float] | None = None
    for attr in node.items[1:]:
        if not isinstance(attr, _List) or not attr.items:
            raise reader.error(f"region {name!r}: expected an attribute list", attr.line)
        key = _sym(reader, attr.items[0], "a region attribute")
        values = attr.items[1:]
        if key == ":target":
            if len(values) != 1:
                raise reader.error(f"region {name!r}: :target takes exactly one name", attr.line)
            target = _sym(reader, values[0], "a target name")
        elif key in (":ranges", ":yaw_rotation"):
            if len(values) != 1 or not isinstance(values[0], _List):
                raise reader.error(f"region {name!r}: {key} takes one list of tuples", attr.line)
            width = 4 if key == ":ranges" else 2
            rows: list[tuple[float, ...]] = []
            for item in values[0].items:
                if not isinstance(item, _List) or len(item.items) != width:
                    raise reader.error(f"region {name!r}: each {key} entry needs {width} numbers", item.line)
                rows.append(tuple(_number(reader, v, f"region {name!r} {key} value") for v in item.items))
            if key == ":ranges":
                for row in rows:
                    if row[0] > row[2] or row[1] > row[3]:
                        raise reader.error(f"region {name!r}: range {row} has min > max", values[0].line)
                ranges.extend(rows)  # type: ignore[arg-type]
            else:
                if len(rows) != 1:
                    raise reader.error(f"region {name!r}: :yaw_rotation takes one (min max) pair", attr.line)
                yaw = rows[0]  # type: ignore[assignment]
        elif key == ":rgba":
            if len(values) != 1 or not isinstance(values[0], _List) or len(values[0].items) != 4:
                raise reader.error(f"region {name!r}: :rgba takes one list of 4 numbers", attr.line)
            rgba = tuple(_number(reader, v, f"region {name!r} rgba value") for v in values[0].items)  # type: ignore[assignment]
        else:
            allowed = ", ".join(_REGION_ATTRIBUTES)
            raise reader.error(f"region {name!r}: unknown attribute {key!r} (expected {allowed})", attr.line)
    if target is None:
        raise reader.error(f"region {name!r} has no :target", node.line)
    return Region(name=name, target=target, ranges=tuple(ranges), yaw_rotation=yaw, rgba=rgba)


def _formula(reader: _Reader, node: _Node, names: set[str], where: str) -> Formula:
    if not isinstance(node, _List) or not node.items:
        raise reader.error(f"{where}: expected a predicate '(Name args...)'", node.line)
    head = _sym(reader, node.items[0], "a predicate name")
    rest = node.items[1:]
    lowered = head.lower()
    if lowered in ("and", "or"):
        if not rest:
            raise reader.error(f"{where}: empty ({head})", node.line)
        terms = tuple(_formula(reader, t, names, where) for t in rest)
        return And(terms) if lowered == "and" else Or(terms)
    if lowered == "not":
        if len(rest) != 1:
            raise reader.error(f"{where}: (Not ...) takes exactly one formula", node.line)
        return Not(_formula(reader, rest[0], names, where))
    return _atom(reader, node, names, where)


def _atom(reader: _Reader, node: _List, names: set[str], where: str) -> Atom:
    head = _sym(reader, node.items[0], "a predicate name")
    canonical = CANONICAL_PREDICATE.get(head.lower())
    if canonical is None:
        known = ", ".join(PREDICATES)
        raise reader.error(f"{where}: unknown predicate {head!r} (known: {known})", node.line)
    args = tuple(_sym(reader, a, f"an argument of {head}") for a in node.items[1:])
    if len(args) != PREDICATES[canonical]:
        raise reader.error(
            f"{where}: {canonical} takes {PREDICATES[canonical]} argument(s), got {len(args)}",
            node.line,
        )
    for arg, arg_node in zip(args, node.items[1:], strict=True):
        if arg not in names:
            raise reader.error(
                f"{where}: ({canonical} {' '.join(args)}) refers to undeclared {arg!r}",
                arg_node.line,
            )
    return Atom(canonical, args)


def parse(text: str, source: str = "<string>") -> Problem:
    """Parse BDDL text into a :class:`Problem`; ``source`` names the text in errors."""
    reader = _Reader(text, source)
    root = reader.tree()
    if not root.items or _sym(reader, root.items[0], "'define'") != "define":
        raise reader.error("a problem must start with '(define (problem NAME)'", root.line)
    blocks: dict[str, _List] = {}
    problem_name: str | None = None
    for node in root.items[1:]:
        if not isinstance(node, _List) or not node.items:
            raise reader.error("expected a block '(:name ...)' inside define", node.line)
        key = _sym(reader, node.items[0], "a block name")
        if key == "problem":
            if len(node.items) != 2:
                raise reader.error("(problem NAME) takes exactly one name", node.line)
            problem_name = _sym(reader, node.items[1], "a problem name")
            continue
        if key not in _BLOCKS:
            raise reader.error(f"unknown block {key!r} (expected one of {', '.join(_BLOCKS)})", node.line)
        if key in blocks:
            raise reader.error(f"block {key!r} appears twice", node.line)
        blocks[key] = node
    if problem_name is None:
        raise reader.error("missing (problem NAME)", root.line)
    for key in _REQUIRED:
        if key not in blocks:
            raise reader.error(f"missing block {key!r}", root.line)

    domain_items = blocks[":domain"].items[1:]
    if len(domain_items) != 1:
        raise reader.error("(:domain NAME) takes exactly one name", blocks[":domain"].line)
    domain = _sym(reader, domain_items[0], "a domain name")
    words = [_sym(reader, w, "a word of the instruction") for w in blocks[":language"].items[1:]]
    if not words:
        raise reader.error("empty (:language)", blocks[":language"].line)
    language = " ".join(words)

    regions = [_region(reader, r) for r in blocks[":regions"].items[1:]]
    fixtures = _typed_list(reader, blocks[":fixtures"], "fixture")
    objects = _typed_list(reader, blocks[":objects"], "object")

    seen: dict[str, int] = {}
    for entity, kind in [(f, "fixture") for f in fixtures] + [(o, "object") for o in objects]:
        if entity.name in seen:
            raise reader.error(f"{kind} {entity.name!r} is declared twice", blocks[":objects"].line)
        seen[entity.name] = 1
    entity_names = set(seen)
    full_names: set[str] = set()
    for region, node in zip(regions, blocks[":regions"].items[1:], strict=True):
        if region.full_name in full_names:
            raise reader.error(f"region {region.full_name!r} is declared twice", node.line)
        # Shipped LIBERO files declare regions on fixtures they do not place (for example
        # bowl_drainer_1 in libero_goal); LIBERO ignores them, so do we, but no predicate
        # may refer to them.
        if region.target in entity_names:
            full_names.add(region.full_name)
    names = entity_names | full_names

    interest: list[str] = []
    if ":obj_of_interest" in blocks:
        for node in blocks[":obj_of_interest"].items[1:]:
            name = _sym(reader, node, "an object of interest")
            if name not in names:
                raise reader.error(f"object of interest {name!r} is not declared", node.line)
            interest.append(name)

    init = [_atom_or_error(reader, n, names, "init") for n in blocks[":init"].items[1:]]

    goal_items = blocks[":goal"].items[1:]
    if not goal_items:
        raise reader.error("empty goal: (:goal) needs a formula", blocks[":goal"].line)
    if len(goal_items) != 1:
        raise reader.error("(:goal ...) takes one formula; wrap several in (And ...)", blocks[":goal"].line)
    goal = _formula(reader, goal_items[0], names, "goal")

    return Problem(
        problem=problem_name,
        perturbation=_perturbation(reader),
        domain=domain,
        language=language,
        regions=tuple(regions),
        fixtures=tuple(fixtures),
        objects=tuple(objects),
        obj_of_interest=tuple(interest),
        init=tuple(init),
        goal=goal,
    )


#: The comment line that carries a problem's perturbation (see Problem.perturbation).
PERTURBATION_MARK = "; libero-data perturbation:"


def _perturbation(reader: _Reader) -> str:
    """The perturbation comment's JSON, canonical (sorted keys); "" without one."""
    import json

    found = ""
    for lineno, raw in enumerate(reader.text.splitlines(), start=1):
        line = raw.strip()
        if not line.startswith(PERTURBATION_MARK):
            continue
        if found:
            raise reader.error("the perturbation comment appears twice", lineno)
        try:
            value = json.loads(line[len(PERTURBATION_MARK) :])
        except json.JSONDecodeError as exc:
            raise reader.error(f"the perturbation comment is not valid JSON ({exc.msg})", lineno) from None
        if not isinstance(value, dict) or not isinstance(value.get("kind"), str):
            raise reader.error("the perturbation comment must be a JSON object with a 'kind'", lineno)
        found = json.dumps(value, sort_keys=True, separators=(",", ":"))
    return found


def _atom_or_error(reader: _Reader, node: _Node, names: set[str], where: str) -> Atom:
    if not isinstance(node, _List) or not node.items:
        raise reader.error(f"{where}: expected a predicate '(Name args...)'", node.line)
    return _atom(reader, node, names, where)


def parse_file(path: str | Path) -> Problem:
    """Parse a BDDL file; errors name the file and line."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise BDDLError("file not found", source=str(path)) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise BDDLError(f"cannot read file ({exc.__class__.__name__})", source=str(path)) from None
    return parse(text, source=str(path))
