"""Writing episode after episode does not grow the process (arenas capped, free memory returned)."""

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
from libero_data.runtime.memory import limit_malloc_arenas, release_free_memory
from libero_data.record import shard
from libero_data.record.features import FeatureLayout
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
                             layout=FeatureLayout(image_size=128), sim_state_width=12, info={{}})
    shutil.rmtree(out)
    gc.collect()
    assert release_free_memory()  # as generate's worker does after each episode
    trace.append(rss())
print(sum(trace[-10:]) / 10 - sum(trace[10:20]) / 10)
"""


@pytest.mark.slow  # hundreds of shards written; run after the default suite
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
    # Growth from episodes 10-20 to 50-60; measured within 2 MiB. Without returning free memory
    # the resident size flipped between two levels ~25 MiB apart at random episodes (which
    # thread got which arena); with LeRobot's own encoder threads and no arena cap, each
    # episode left ~0.8 MiB in fresh arenas (+32 MiB here).
    assert growth < 6, growth
