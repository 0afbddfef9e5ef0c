"""Keeping long-running worker processes from growing: glibc's malloc arenas.

LeRobot's streaming video encoder starts two threads per episode (one per camera). glibc
gives new threads their own malloc arenas (up to 8 per core) and keeps freed memory in them,
so a worker writing one episode after another grew by ~0.8 MiB per episode (measured over
100 synthetic 20-frame episodes: +82 MiB; with two arenas: +4 MiB). Workers (and the CLI
process, which is the worker when ``--workers 1``) cap the arenas at two.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import sys

#: mallopt parameter number of M_ARENA_MAX in glibc's <malloc.h>.
_M_ARENA_MAX = -8
ARENAS = 2


def limit_malloc_arenas(arenas: int = ARENAS) -> bool:
    """Cap this process's glibc malloc arenas (threads created later share them); True if set.

    A no-op (False) outside Linux or without glibc. Call it from a process entry point (a
    worker initialiser, a CLI command), not from library functions.
    """
    if not sys.platform.startswith("linux"):
        return False
    name = ctypes.util.find_library("c")
    if name is None:
        return False
    try:
        libc = ctypes.CDLL(name)
        return bool(libc.mallopt(_M_ARENA_MAX, int(arenas)))
    except (OSError, AttributeError):
        return False
