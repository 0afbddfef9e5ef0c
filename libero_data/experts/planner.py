"""From a task's goal predicates to an ordered list of skills.

Rules, in the order they are applied:

- atoms that already hold are skipped when the plan runs (see :mod:`runner`);
- ``In(x, R)`` where ``R`` is a drawer that is closed: open the drawer first;
- ``Close(R)`` after every ``In(x, R)`` into it; other ``Open``/``Close``/``Turnon``/
  ``Turnoff`` atoms come first, in written order (a stove turned on before a pot goes on it);
- ``On(x, y)``/``In(x, y)`` where ``y`` itself must be moved: move ``y`` first;
- ``On(x, R)`` of a flat object that cannot be grasped from above: push it;
- an object that is moved later and that opening a drawer would cover (a bowl in front of
  the cabinet), with no grasp as good left once it is open: push it aside (or, where no
  stroke fits, set it aside) before the drawer opens.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from libero_data.bddl import Atom, Problem


@dataclass(frozen=True)
class Step:
    """One skill application that makes ``atom`` true (``atom`` is None for helper steps)."""

    skill: str
    args: tuple[str, ...]
    atom: Atom | None

    def __str__(self) -> str:
        return f"{self.skill}({', '.join(self.args)})"


def plan(
    problem: Problem,
    *,
    joint_kind: Callable[[str], str | None] = lambda name: None,
    is_open: Callable[[str], bool] = lambda name: True,
    graspable: Callable[[str], bool] = lambda name: True,
    covered: Callable[[str, str], bool] = lambda drawer, obj: False,
) -> list[Step]:
    """Order the goal's atoms into skills.

    ``joint_kind(name)`` tells "slide" (drawers), "hinge" (doors, knobs) or None;
    ``is_open(region)`` whether a container is open now; ``graspable(obj)`` whether a
    top-down grasp fits the object; ``covered(drawer, obj)`` whether opening the drawer would
    put it over the object.
    """

    def articulation(atom: Atom) -> Step:
        name = atom.args[0]
        if atom.predicate in ("Turnon", "Turnoff"):
            return Step("turn_on" if atom.predicate == "Turnon" else "turn_off", atom.args, atom)
        kind = "drawer" if joint_kind(name) == "slide" else "door"
        verb = "open" if atom.predicate == "Open" else "close"
        return Step(f"{verb}_{kind}", atom.args, atom)

    goal = problem.goal_atoms()
    moves = [a for a in goal if a.predicate in ("On", "In")]
    switches = [a for a in goal if a.predicate in ("Open", "Close", "Turnon", "Turnoff")]

    parents = {r.full_name: r.target for r in problem.regions}

    def door_of(target: str) -> str | None:
        """What must be open to put something into ``target``: a drawer region or its fixture."""
        for name in (target, parents.get(target)):
            if name is not None and joint_kind(name):
                return name
        return None

    closing_after: dict[str, Atom] = {}
    first: list[Atom] = []
    for atom in switches:
        name = atom.args[0]
        if atom.predicate == "Close" and any(
            m.predicate == "In" and door_of(m.args[1]) == name for m in moves
        ):
            closing_after[name] = atom
        else:
            first.append(atom)

    # A target that is itself moved goes first (stack the left bowl on the right bowl and
    # put them in the tray: the right bowl goes into the tray, then the left bowl on it).
    ordered: list[Atom] = []
    pending = list(moves)
    while pending:
        for atom in pending:
            target = atom.args[1]
            if not any(other is not atom and other.args[0] == target for other in pending):
                ordered.append(atom)
                pending.remove(atom)
                break
        else:  # a cycle cannot be satisfied in order; keep the written order
            ordered += pending
            break

    steps: list[Step] = [articulation(a) for a in first]
    # A drawer the goal opens anyway is open by the time anything goes in.
    opened: set[str] = {a.args[0] for a in first if a.predicate == "Open"}
    for atom in ordered:
        obj, target = atom.args
        door = door_of(target) if atom.predicate == "In" else None
        if door is not None and door not in opened and not is_open(door):
            opening = articulation(Atom("Open", (door,)))
            steps.append(Step(opening.skill, opening.args, None))
            opened.add(door)
        if atom.predicate == "On" and not graspable(obj):
            steps.append(Step("push", (obj, target), atom))
        else:
            steps.append(Step("pick", (obj, target), None))
            steps.append(Step("place_in" if atom.predicate == "In" else "place_on", (obj, target), atom))
        if door is not None and door in closing_after:
            steps.append(articulation(closing_after.pop(door)))
    steps += [articulation(a) for a in closing_after.values()]
    return _clear_the_way(steps, covered)


def _clear_the_way(steps: list[Step], covered: Callable[[str, str], bool]) -> list[Step]:
    """Before each drawer opens, push aside what it would cover and what is picked later."""
    out: list[Step] = []
    moved: set[str] = set()
    for i, step in enumerate(steps):
        if step.skill == "open_drawer":
            drawer = step.args[0]
            later = [s.args[0] for s in steps[i + 1 :] if s.skill == "pick"]
            for obj in dict.fromkeys(later):
                if obj not in moved and covered(drawer, obj):
                    out.append(Step("push_aside", (obj, drawer), None))
                    moved.add(obj)
        out.append(step)
    return out
