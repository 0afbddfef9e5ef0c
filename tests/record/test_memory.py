"""Writing episode after episode does not grow the process (malloc arenas capped)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

SCRIPT = """
import gc, shutil, sys, tempfile
from pathlib import Path
sys.path.insert(0, {tests!r})
from test_shard import _frames
from libero_data.pipeline.memory import limit_malloc_arenas
from libero_data.record import shard
if {limit}:
    assert limit_malloc_arenas()
def rss():
    for line in open("/proc/self/status"):
        if line.startswith("VmRSS"):
            return int(line.split()[1]) / 1024
frames = _frames(20, size=128)
work = Path(tempfile.mkdtemp())
trace = []
for i in range(60):
    out = shard.write_frames(work / str(i), frames=frames, success=[False] * 20, task="t", instruction="x",
                             image_size=128, sim_state_width=12, info={{}})
    shutil.rmtree(out)
    gc.collect()
    trace.append(rss())
print(sum(trace[-10:]) / 10 - sum(trace[20:30]) / 10)
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc and /proc")
def test_shard_writing_does_not_grow_the_process() -> None:
    tests = str(Path(__file__).parent)
    code = SCRIPT.format(tests=tests, limit=True)
    result = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        timeout=600,
        env={"OMP_NUM_THREADS": "1", "SVT_LOG": "1", "PATH": "/usr/bin:/bin"},
    )
    assert result.returncode == 0, result.stderr[-2000:]
    growth = float(result.stdout.strip().splitlines()[-1])
    # Growth from episodes 20-30 to 50-60. The first episodes take one step of ~23 MiB (pools
    # that are made once), at episode 1 or as late as 18, which is not growth. With LeRobot's
    # own encoder threads and no arena cap, each episode left ~0.8 MiB in fresh arenas.
    assert growth < 15, growth
