"""Keeping long-running worker processes from growing: glibc's malloc arenas.

LeRobot's streaming video encoder starts two threads per episode (one per camera). glibc
gives new threads their own malloc arenas (up to 8 per core) and keeps freed memory in them,
so a worker writing one episode after another grew with every episode as its threads filled
fresh arenas. Workers (and the CLI process, which is the worker when ``--workers 1``) cap the
arenas at two.

Even with two arenas, which thread lands in which arena decides how much freed memory an arena
holds on to, so the resident size jumped between levels at random episodes. After each episode
a worker therefore hands the free memory of every arena back to the kernel (``malloc_trim``),
and its resident size stays level from one episode to the next (benchmarks/RESULTS.md,
Generation memory and Evaluation memory: a worker's memory over 100 episodes or rollouts).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import functools
import sys

#: mallopt parameter number of M_ARENA_MAX in glibc's <malloc.h>.
_M_ARENA_MAX = -8
ARENAS = 2


@functools.cache
def _libc() -> ctypes.CDLL | None:
    """The C library, looked up once (``find_library`` may run ``ldconfig``)."""
    if not sys.platform.startswith("linux"):
        return None
    name = ctypes.util.find_library("c")
    if name is None:
        return None
    try:
        return ctypes.CDLL(name)
    except OSError:
        return None


def limit_malloc_arenas(arenas: int = ARENAS) -> bool:
    """Cap this process's glibc malloc arenas (threads created later share them); True if set.

    A no-op (False) outside Linux or without glibc. Call it from a process entry point (a
    worker initialiser, a CLI command), not from library functions.
    """
    libc = _libc()
    if libc is None:
        return False
    try:
        return bool(libc.mallopt(_M_ARENA_MAX, int(arenas)))
    except AttributeError:
        return False


def release_free_memory() -> bool:
    """Give the free memory of every malloc arena back to the kernel; True if glibc did it.

    It walks every arena: too slow to call after every step (benchmarks/RESULTS.md, Evaluation:
    one batched policy), little beside an episode, so a worker calls it between episodes. A
    no-op (False) without glibc.
    """
    libc = _libc()
    if libc is None:
        return False
    try:
        libc.malloc_trim(0)
    except AttributeError:
        return False
    return True
