"""Writer: :class:`~libero_data.bddl.model.Problem` -> BDDL text in LIBERO's layout.

The output loads in LIBERO's own parser unchanged, and ``parse(write(p)) == p``.
"""

from __future__ import annotations

from libero_data.bddl.model import And, Atom, Entity, Formula, Not, Or, Problem, Region
from libero_data.bddl.parser import PERTURBATION_MARK
from libero_data.errors import BDDLError


def _num(value: float) -> str:
    # repr() of a float round-trips exactly.
    return repr(float(value))


def formula_text(formula: Formula) -> str:
    """A goal formula as BDDL writes it, e.g. ``(And (Open a) (On b c))``."""
    if isinstance(formula, Atom):
        return str(formula)
    if isinstance(formula, Not):
        return f"(Not {formula_text(formula.term)})"
    head = "And" if isinstance(formula, And) else "Or"
    assert isinstance(formula, (And, Or))
    return f"({head} {' '.join(formula_text(t) for t in formula.terms)})"


def _region(region: Region) -> list[str]:
    lines = [f"      ({region.name}", f"          (:target {region.target})"]
    if region.ranges:
        lines.append("          (:ranges (")
        for r in region.ranges:
            lines.append(f"              ({' '.join(_num(v) for v in r)})")
        lines += ["            )", "          )"]
    if region.yaw_rotation is not None:
        lines.append("          (:yaw_rotation (")
        lines.append(f"              ({' '.join(_num(v) for v in region.yaw_rotation)})")
        lines += ["            )", "          )"]
    if region.rgba is not None:
        lines.append(f"          (:rgba ({' '.join(_num(v) for v in region.rgba)}))")
    lines.append("      )")
    return lines


def _typed(entities: tuple[Entity, ...]) -> list[str]:
    """One line per category, its names together, as LIBERO writes them: LIBERO's parser keeps
    only the last line of a category, so two bowls on two lines would lose the first."""
    names: dict[str, list[str]] = {}
    for e in entities:
        names.setdefault(e.category, []).append(e.name)
    return [f"    {' '.join(group)} - {category}" for category, group in names.items()]


def write(problem: Problem) -> str:
    """Serialise a problem as BDDL text."""
    if "(" in problem.language or ")" in problem.language:
        raise BDDLError("the language sentence must not contain parentheses", source=problem.problem)
    lines = [f"{PERTURBATION_MARK} {problem.perturbation}"] if problem.perturbation else []
    lines += [
        f"(define (problem {problem.problem})",
        f"  (:domain {problem.domain})",
        f"  (:language {problem.language})",
        "    (:regions",
    ]
    for region in problem.regions:
        lines += _region(region)
    lines += ["    )", "", "  (:fixtures", *_typed(problem.fixtures), "  )", ""]
    lines += ["  (:objects", *_typed(problem.objects), "  )", ""]
    lines += ["  (:obj_of_interest", *[f"    {n}" for n in problem.obj_of_interest], "  )", ""]
    lines += ["  (:init", *[f"    {a}" for a in problem.init], "  )", ""]
    lines += ["  (:goal", f"    {formula_text(problem.goal)}", "  )", "", ")", ""]
    return "\n".join(lines)
