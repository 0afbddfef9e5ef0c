"""Writing Rerun recordings (``.rrd`` files) one after another in a long-lived process.

rerun-sdk 0.28 keeps every :class:`rerun.RecordingStream` (and everything logged to it) in
memory after it is disconnected and dropped, until its orphan sweep runs: an evaluation
worker writing one recording per rollout grew with every rollout. :func:`rrd_file` runs the
sweep, so a process holds at most the recording it is writing (a worker's memory over 100
rollouts: benchmarks/RESULTS.md, Evaluation memory).
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from pathlib import Path
from typing import Any


@contextlib.contextmanager
def rrd_file(path: str | Path, application_id: str, recording_id: str) -> Iterator[Any]:
    """A recording stream saving to ``path``, which appears (atomically) when the block ends.

    On an exception nothing is left at ``path`` (the partial file is removed).
    """
    import rerun as rr
    import rerun_bindings

    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(out.name + ".tmp")
    rerun_bindings.flush_and_cleanup_orphaned_recordings()  # streams of earlier files
    rec = rr.RecordingStream(application_id, recording_id=recording_id)
    rec.save(str(tmp))
    finished = False
    try:
        yield rec
        rec.flush()
        finished = True
    finally:
        rec.disconnect()
        rec.reset_time()
        if not finished:
            tmp.unlink(missing_ok=True)
    tmp.replace(out)
