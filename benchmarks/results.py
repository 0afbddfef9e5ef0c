"""Writing one benchmark's section of ``benchmarks/RESULTS.md`` (machine, versions, date)."""

from __future__ import annotations

import datetime as dt
import os
import platform
import re
from pathlib import Path


def status_mib(pid: int, field: str) -> float:
    """A memory field of ``/proc/<pid>/status`` (``VmRSS``, ``VmHWM``) in MiB."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith(field + ":"):
            return int(line.split()[1]) / 1024
    return float("nan")


def growth_summary(trace: list[float], what: str) -> str:
    """One sentence on resident memory sampled after each of ``len(trace)`` ``what``."""
    tenth = max(len(trace) // 10, 1)
    early, late = sum(trace[:tenth]) / tenth, sum(trace[-tenth:]) / tenth
    return (
        f"Resident MiB over {len(trace)} {what}: first {trace[0]:.0f}, mean of the first tenth {early:.0f}, "
        f"of the last tenth {late:.0f}, max {max(trace):.0f}; growth from the first to the last tenth "
        f"**{late - early:+.0f} MiB**."
    )


def machine() -> str:
    cores = os.cpu_count()
    try:
        mem = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30
    except (ValueError, OSError):
        mem = float("nan")
    return f"{platform.processor() or platform.machine()}, {cores} cores, {mem:.0f} GiB, {platform.system()}"


def stamp() -> str:
    from libero_data.numerics import describe, machine_fingerprint
    from libero_data.runtime.versions import versions

    vers = ", ".join(f"{k} {v}" for k, v in versions().items())
    fingerprint = machine_fingerprint()
    numerics = f"{describe(fingerprint)} (numeric key {fingerprint['numeric_key']})"
    return f"_{dt.date.today().isoformat()} · {machine()} · {numerics} · {vers}_"


def replace_section(path: Path, title: str, body: str) -> None:
    """Replace (or append) ``## title`` in ``path`` with ``body`` and a stamp."""
    text = (
        path.read_text()
        if path.is_file()
        else "# Benchmark results\n\nWritten by the scripts in `benchmarks/`.\n"
    )
    block = f"## {title}\n\n{stamp()}\n\n{body.rstrip()}\n"
    pattern = re.compile(rf"^## {re.escape(title)}\n.*?(?=^## |\Z)", re.S | re.M)
    if pattern.search(text):
        text = pattern.sub(lambda _m: block + "\n", text)
    else:
        text = text.rstrip() + "\n\n" + block
    path.write_text(text.rstrip() + "\n")
