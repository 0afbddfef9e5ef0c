"""Importing robosuite and LIBERO without their side effects.

robosuite 1.4 opens ``/tmp/robosuite.log`` on first import and advises writing a private
macro file into site-packages; LIBERO's environment module imports matplotlib, which creates
``~/.config/matplotlib``. A library must write nothing outside the paths it was given, so the
first import goes through :func:`import_libero`, which avoids all three.
"""

from __future__ import annotations

import atexit
import functools
import importlib.util
import os
import shutil
import sys
import tempfile
import types
import warnings
from pathlib import Path
from typing import Any


def _load_robosuite_macros() -> None:
    """Load ``robosuite.macros`` ahead of robosuite itself, with its file log switched off."""
    if "robosuite" in sys.modules:
        return
    spec = importlib.util.find_spec("robosuite")
    if spec is None or not spec.submodule_search_locations:
        raise ImportError("robosuite is not installed; run scripts/setup")
    path = Path(next(iter(spec.submodule_search_locations))) / "macros.py"
    macros_spec = importlib.util.spec_from_file_location("robosuite.macros", path)
    assert macros_spec is not None and macros_spec.loader is not None
    macros = importlib.util.module_from_spec(macros_spec)
    macros_spec.loader.exec_module(macros)
    macros.FILE_LOGGING_LEVEL = None  # type: ignore[attr-defined]
    sys.modules["robosuite.macros"] = macros
    sys.modules["robosuite.macros_private"] = types.ModuleType("robosuite.macros_private")


def _import_matplotlib_quietly() -> None:
    """Import matplotlib with a throw-away config folder unless the user chose one.

    matplotlib remembers the folder for the life of the process (as it does with its own
    fallback when the home directory is read-only), so it is removed at exit.
    """
    if "matplotlib" in sys.modules or "MPLCONFIGDIR" in os.environ:
        return
    folder = tempfile.mkdtemp(prefix="libero-data-mpl-")
    os.environ["MPLCONFIGDIR"] = folder
    try:
        import matplotlib  # noqa: F401
    finally:
        del os.environ["MPLCONFIGDIR"]
        atexit.register(shutil.rmtree, folder, ignore_errors=True)


@functools.cache
def import_libero() -> tuple[Any, dict[str, Any]]:
    """``(robosuite, TASK_MAPPING)``, imported once per process."""
    _load_robosuite_macros()
    _import_matplotlib_quietly()
    with warnings.catch_warnings():
        # robosuite 1.4 has an invalid escape in its logo string; compiling it warns once.
        warnings.simplefilter("ignore", SyntaxWarning)
        import robosuite
        from libero.libero.envs import TASK_MAPPING
    return robosuite, TASK_MAPPING
