"""The single error type raised for malformed BDDL."""

from __future__ import annotations


class BDDLError(ValueError):
    """Malformed BDDL: the message names the file, the line and the problem."""

    def __init__(self, problem: str, *, source: str = "<string>", line: int | None = None) -> None:
        self.problem = problem
        self.source = source
        self.line = line
        where = source if line is None else f"{source}, line {line}"
        super().__init__(f"{where}: {problem}")
