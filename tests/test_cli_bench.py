from __future__ import annotations

import subprocess
import sys


def bench(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "libero_bench.cli", *args], capture_output=True, text=True, timeout=120
    )


def test_orders_lists_the_upstream_orders() -> None:
    result = bench("orders")
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert len(lines) == 21
    assert lines[0] == " 0: 0 1 2 3 4 5 6 7 8 9"


def test_unknown_order_exits_2() -> None:
    result = bench("orders", "--order", "40")
    assert result.returncode == 2
    assert "task order must be in 0..20" in result.stderr
