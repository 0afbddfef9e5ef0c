"""A typed model of LIBERO's BDDL problem files, with our own parser and writer.

>>> from libero_data.bddl import parse_file, write
>>> problem = parse_file("task.bddl")
>>> text = write(problem)
"""

from libero_data.bddl.model import (
    PREDICATES,
    And,
    Atom,
    Entity,
    Formula,
    Not,
    Or,
    Problem,
    Region,
    atoms,
)
from libero_data.bddl.parser import parse, parse_file
from libero_data.bddl.writer import formula_text, write
from libero_data.errors import BDDLError

__all__ = [
    "PREDICATES",
    "And",
    "Atom",
    "BDDLError",
    "Entity",
    "Formula",
    "Not",
    "Or",
    "Problem",
    "Region",
    "atoms",
    "formula_text",
    "parse",
    "parse_file",
    "write",
]
