"""Evaluation protocols as data: which starts a task is rolled out from, how the scene settles,
how many steps a rollout may take, how the environment steps, and what the policy is sent.

- ``libero-bench`` (the default): every task from LIBERO's stored init states and from held-out
  placements no demonstration started from, fixtures placed from the rollout's seed, the
  environment reset to a canonical state (:meth:`libero_data.sim.LiberoEnv.reset`), LeRobot's
  step limits, images at the policy's size. Paired comparisons and intervals are built on it.
- ``standard``: LIBERO's evaluation as openpi's LIBERO client runs it (the loop VLA papers report):
  episode ``i`` of a task from stored init state ``i``, its fixtures where LIBERO's ``i``-th reset
  puts them after ``env.seed(7)`` (:mod:`libero_data.sim.libero_loop`), 10 waiting steps, then the
  suite's limit (220 / 280 / 300 / 520 / 400), success as LIBERO's ``done``; cameras rendered at
  256, and the policy sent openpi's request (:mod:`libero_bench.rollouts.observations`), chunks
  executed 5 actions at a time.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

from libero_bench.runs.folder import HELDOUT, STANDARD, STORED
from libero_data.errors import InputError
from libero_data.tasks.horizons import OPENPI_LIMITS, SUITE_LIMITS

LIBERO_BENCH, STANDARD_PROTOCOL = "libero-bench", "standard"
#: How the observation reaches the policy: libero-bench's request (every state it has) or openpi's.
REQUEST_LIBERO_BENCH, REQUEST_OPENPI = "libero-bench", "openpi"


@dataclass(frozen=True)
class Protocol:
    """One evaluation protocol (see the module docstring)."""

    name: str
    starts: tuple[str, ...]  # the kinds of start each task is rolled out from
    settle: int  # waiting steps before the policy acts (not counted in the limit)
    limits: Mapping[str, int] = field(repr=False)  # step limit per LIBERO suite
    libero_loop: bool  # LIBERO's own reset, set_init_state and step (libero_data.sim.libero_loop)
    render_size: int | None  # camera size rendered (None: what the policy reads)
    request: str  # the observation mapping (REQUEST_*)
    sent_size: int | None  # images resized with padding to this size in the request (None: as rendered)
    replan_steps: int  # actions executed of each chunk a server returns

    @property
    def standard(self) -> bool:
        return self.name == STANDARD_PROTOCOL


PROTOCOLS: Mapping[str, Protocol] = MappingProxyType(
    {
        LIBERO_BENCH: Protocol(
            LIBERO_BENCH,
            starts=(STORED, HELDOUT),
            settle=10,
            limits=SUITE_LIMITS,
            libero_loop=False,
            render_size=None,
            request=REQUEST_LIBERO_BENCH,
            sent_size=None,
            replan_steps=5,
        ),
        STANDARD_PROTOCOL: Protocol(
            STANDARD_PROTOCOL,
            starts=(STANDARD,),
            settle=10,
            limits=OPENPI_LIMITS,
            libero_loop=True,
            render_size=256,
            request=REQUEST_OPENPI,
            sent_size=224,
            replan_steps=5,
        ),
    }
)


def get_protocol(name: str) -> Protocol:
    """A protocol by name; :class:`InputError` naming the choices."""
    if name not in PROTOCOLS:
        raise InputError(f"unknown protocol {name!r}; choose {' or '.join(PROTOCOLS)}", field="protocol")
    return PROTOCOLS[name]
