"""What ``validate`` finds: inconsistencies (issues), notes, and re-simulation counts."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True)
class Issue:
    where: str
    problem: str

    def __str__(self) -> str:
        return f"{self.where}: {self.problem}"


@dataclass
class Report:
    episodes: int = 0
    frames: int = 0
    resimulated: int = 0
    resimulated_ok: int = 0
    issues: list[Issue] | None = None
    #: Findings that are no inconsistency (replays made elsewhere, within the tolerance).
    notes: list[str] = field(default_factory=list)
    #: Re-simulated episodes made on another numeric path or by other simulator code that
    #: departed from their stored states by more than the tolerance.
    departed_elsewhere: int = 0

    @property
    def ok(self) -> bool:
        return not self.issues
