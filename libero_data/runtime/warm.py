"""Importing heavy modules ahead, in a background thread, while the process does other work.

A worker that writes its first rollout, or a driver that joins its rollouts at the end, first
imports LeRobot's dataset code (torch, ``datasets``, PyAV: seconds). Started when the process
starts, the import overlaps with what the process waits on anyway (environments being built,
rendering, replies from other processes). Python's import lock makes it safe: a thread that needs
a module the background import is loading waits for it.
"""

from __future__ import annotations

import importlib
import logging
import threading
from collections.abc import Sequence

log = logging.getLogger(__name__)


def warm_imports(modules: Sequence[str]) -> threading.Thread:
    """Import ``modules`` in a daemon thread (started, returned); a failing import is left for
    the code that needs the module to report."""

    def run() -> None:
        for name in modules:
            try:
                importlib.import_module(name)
            except Exception as exc:  # reported where the module is used
                log.debug("warming %s failed: %s", name, exc)

    thread = threading.Thread(target=run, name="warm-imports", daemon=True)
    thread.start()
    return thread
