"""Choosing MuJoCo's headless OpenGL backend (EGL or OSMesa) before MuJoCo is imported, and
naming the OpenGL implementation that draws (:func:`gl_strings`)."""

from __future__ import annotations

import ctypes.util
import os
import sys

from libero_data.errors import RenderBackendError

BACKENDS = ("egl", "osmesa")
SYSTEM_PACKAGES = {
    "egl": ["libegl1", "libegl-mesa0", "libgl1-mesa-dri"],
    "osmesa": ["libosmesa6"],
}


def available_backends() -> list[str]:
    """Backends whose shared library is present on this machine, best first."""
    found = []
    if ctypes.util.find_library("EGL"):
        found.append("egl")
    if ctypes.util.find_library("OSMesa"):
        found.append("osmesa")
    return found


def select_backend(requested: str | None = None) -> str:
    """Pick the backend: ``requested`` -> ``$MUJOCO_GL`` -> first available of EGL, OSMesa.

    Sets ``MUJOCO_GL`` and ``PYOPENGL_PLATFORM`` for this process when they are unset,
    because MuJoCo and robosuite read them once, when first imported. Called when an
    environment is created, never at import time.
    """
    current = os.environ.get("MUJOCO_GL")
    simulation_loaded = "robosuite" in sys.modules or "mujoco" in sys.modules
    if requested is not None and requested not in BACKENDS:
        raise RenderBackendError(f"unknown render backend {requested!r}; use one of {', '.join(BACKENDS)}")
    if requested is not None and current and current != requested and simulation_loaded:
        raise RenderBackendError(
            f"render backend {requested!r} requested but MuJoCo was already loaded with {current!r} "
            "in this process; choose the backend before the first environment is created"
        )
    choice = requested or current
    if choice is None:
        found = available_backends()
        if not found:
            packages = " ".join(SYSTEM_PACKAGES["egl"] + SYSTEM_PACKAGES["osmesa"])
            raise RenderBackendError(
                f"no headless OpenGL library found (EGL or OSMesa); install: apt-get install {packages}"
            )
        choice = found[0]
    if not simulation_loaded or not current:
        os.environ["MUJOCO_GL"] = choice
        os.environ["PYOPENGL_PLATFORM"] = choice
    return os.environ.get("MUJOCO_GL", choice)


def gl_strings(backend: str | None) -> dict[str, str]:
    """The current OpenGL context's vendor, renderer and version (and the backend named)."""
    from OpenGL import GL

    return {
        "backend": str(backend),
        "vendor": GL.glGetString(GL.GL_VENDOR).decode(errors="replace"),
        "renderer": GL.glGetString(GL.GL_RENDERER).decode(errors="replace"),
        "version": GL.glGetString(GL.GL_VERSION).decode(errors="replace"),
    }
