"""Job functions for the runner's tests (module level: spawned workers import them)."""

from __future__ import annotations

import os
import time

from libero_data.runtime.jobs import WorkerContext


def count_and_report(ctx: WorkerContext, n: int) -> dict[str, int]:
    """Reports n events (slowly for the first job, so results and events interleave), writes a file."""
    for i in range(n):
        ctx.report((n, i))
    if n == 5:
        time.sleep(0.3)
    built = ctx.cache.get("thing", "key", lambda: {"pid": os.getpid(), "uses": 0})
    built["uses"] += 1
    out = ctx.root / "out" / f"{n}.txt"
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(str(n))
    ctx.ship(f"out/{n}.txt")
    shared = ctx.shared.read_text() if ctx.shared is not None else ""
    return {"n": n, "pid": os.getpid(), "uses": built["uses"], "shared": len(shared)}


def fail_on_three(ctx: WorkerContext, n: int) -> int:
    if n == 3:
        raise ArithmeticError(f"job {n} failed")
    return n


class Counter:
    """An actor for the actor pool's tests: counts, writes a file, fails or dies on request."""

    def __init__(self, ctx: WorkerContext) -> None:
        self.ctx = ctx
        self.total = 0

    def add(self, n: int) -> dict[str, int]:
        self.total += n
        out = self.ctx.root / "out" / f"{os.getpid()}-{self.total}.txt"
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(str(self.total))
        self.ctx.ship(str(out.relative_to(self.ctx.root)))
        return {"pid": os.getpid(), "total": self.total}

    def fail(self) -> None:
        raise ArithmeticError("asked to fail")

    def die(self) -> None:
        os._exit(3)


def make_counter(ctx: WorkerContext) -> Counter:
    return Counter(ctx)
