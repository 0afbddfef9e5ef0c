"""Provenance: the code and the machines that made an artifact.

- **Expert code.** :func:`expert_code` is a short hash of the code that decides an expert
  episode (:data:`EPISODE_CODE`: the expert and the simulator). Datasets
  record it per episode, the expert report refuses to mix rows of two codes, and ``validate``
  checks replays exactly only against the same code.
- **Machines.** Each episode's ``episode.json`` (and its MCAP log) carries the whole numeric
  fingerprint of the process that searched it (``libero_data.numerics.machine_fingerprint``)
  and the OpenGL strings of the renderer that drew its images. A dataset lists each distinct
  one once (``meta/libero.json`` and the card); a row of ``meta/libero_episodes.jsonl`` names
  its machine by the fingerprint's key, so that file stays small however many episodes there are.
"""

from __future__ import annotations

import functools
import hashlib
from collections.abc import Iterable
from pathlib import Path
from typing import Any

_PACKAGE = Path(__file__).resolve().parent
#: The code that decides an expert episode, relative to the package: folders (every module in
#: them, recursively) and modules. Measuring, recording and tables are left out on purpose:
#: rewording a table must not make measured episodes stale. The seeds an episode gets
#: (``libero_data.seeding``) are frozen instead, their values pinned by tests.
EPISODE_CODE = ("experts", "sim")
#: Folders and modules inside those that do not decide an episode (a folder: all of it). The fast
#: renderer draws images only; LIBERO's evaluation loop replays LIBERO's protocol.
NOT_EPISODE_CODE = (
    "experts/report.py",
    "sim/fast",
    "sim/libero_loop.py",
)


def is_episode_code(path: str) -> bool:
    """Whether the module at ``path`` (relative to the package, ``/``-separated) is in
    :data:`EPISODE_CODE` and not in :data:`NOT_EPISODE_CODE`."""

    def under(entries: tuple[str, ...]) -> bool:
        return any(path == entry or path.startswith(entry + "/") for entry in entries)

    return under(EPISODE_CODE) and not under(NOT_EPISODE_CODE)


@functools.cache
def expert_code() -> str:
    """12 hex digits naming the code that decides an expert episode (:data:`EPISODE_CODE`)."""
    paths: list[Path] = []
    for entry in EPISODE_CODE:
        path = _PACKAGE / entry
        paths.extend(path.rglob("*.py") if path.is_dir() else [path])
    kept = (p for p in paths if is_episode_code(p.relative_to(_PACKAGE).as_posix()))
    return code_digest(sorted(kept), _PACKAGE)


def code_digest(paths: Iterable[Path], root: Path) -> str:
    """12 hex digits of sha256 over the files' paths (relative to ``root``) and their code,
    with comments, docstrings and formatting left out (the code as Python reads it)."""
    import ast

    digest = hashlib.sha256()
    for path in paths:
        tree = ast.parse(path.read_bytes(), filename=str(path))
        for node in ast.walk(tree):
            body = getattr(node, "body", None)
            if (
                isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef)
                and body
                and isinstance(body[0], ast.Expr)
                and isinstance(body[0].value, ast.Constant)
                and isinstance(body[0].value.value, str)
            ):
                node.body = body[1:] or [ast.Pass()]
        digest.update(Path(path).relative_to(root).as_posix().encode())
        digest.update(ast.unparse(tree).encode())
    return digest.hexdigest()[:12]


def compact_row(info: dict[str, Any]) -> dict[str, Any]:
    """An episode's row for ``meta/libero_episodes.jsonl``: the machine by its key, the renderer by name."""
    row = dict(info)
    if "machine" in row:
        machine = row.pop("machine")
        row["numeric_key"] = (
            str(machine.get("numeric_key", "unknown")) if isinstance(machine, dict) else "unknown"
        )
    if "gl" in row:
        gl = row.pop("gl")
        row["gl_renderer"] = str(gl.get("renderer", "unknown")) if isinstance(gl, dict) else "unknown"
    if "render" in row:
        render = row.pop("render")
        row["render_quality"] = (
            str(render.get("quality", "unknown")) if isinstance(render, dict) else "unknown"
        )
    return row


def machines(infos: Iterable[dict[str, Any]]) -> list[dict[str, Any]]:
    """The distinct numeric fingerprints of these episodes (first seen first), each with its
    episode count under ``episodes``."""
    found: dict[str, dict[str, Any]] = {}
    for info in infos:
        machine = info.get("machine") if isinstance(info.get("machine"), dict) else None
        key = str((machine or {}).get("numeric_key", "unknown"))
        entry = found.setdefault(key, {**(machine or {"numeric_key": "unknown"}), "episodes": 0})
        entry["episodes"] += 1
    return list(found.values())


def renderers(infos: Iterable[dict[str, Any]]) -> list[dict[str, Any]]:
    """The distinct OpenGL renderers that drew these episodes, each with its episode count."""
    found: dict[tuple[str, ...], dict[str, Any]] = {}
    for info in infos:
        gl = info.get("gl")
        strings: dict[str, Any] = gl if isinstance(gl, dict) else {}
        names = ("backend", "vendor", "renderer", "version")
        key = tuple(str(strings.get(k, "unknown")) for k in names)
        entry = found.setdefault(key, {**dict(zip(names, key, strict=True)), "episodes": 0})
        entry["episodes"] += 1
    return list(found.values())


def render_summary(infos: Iterable[dict[str, Any]], quality: str) -> dict[str, Any]:
    """How a dataset's images were drawn: the quality, and for ``fast`` the mesh settings, the
    triangles drawn (fewest/most over the episodes' scenes) and the measured difference from
    full-quality images per camera (mean and max |fast - full| on a 0-1 scale, over the frames
    compared: each episode's first and last frame)."""
    out: dict[str, Any] = {"quality": quality}
    renders = [i["render"] for i in infos if isinstance(i.get("render"), dict)]
    if quality != "fast" or not renders:
        return out
    out["settings"] = renders[0].get("settings", {})
    before = [int(r["faces_before"]) for r in renders if "faces_before" in r]
    after = [int(r["faces_after"]) for r in renders if "faces_after" in r]
    if before and after:
        out["triangles_drawn"] = {"full": [min(before), max(before)], "fast": [min(after), max(after)]}
    totals: dict[str, dict[str, float]] = {}
    for r in renders:
        for camera, d in (r.get("difference") or {}).items():
            t = totals.setdefault(camera, {"sum": 0.0, "max": 0.0, "values": 0.0, "frames": 0})
            t["sum"] += float(d["sum"])
            t["max"] = max(t["max"], float(d["max"]))
            t["values"] += float(d["values"])
            t["frames"] += int(d.get("frames", 0))
    out["difference"] = {
        camera: {
            "mean_abs": round(t["sum"] / max(t["values"], 1.0) / 255.0, 5),
            "max_abs": round(t["max"] / 255.0, 4),
            "frames": int(t["frames"]),
        }
        for camera, t in sorted(totals.items())
    }
    return out


def render_line(summary: dict[str, Any]) -> str:
    """The card's "render quality" row."""
    if summary.get("quality") != "fast":
        return "full: LIBERO's own renderer, pixel for pixel"
    settings = summary.get("settings", {})
    line = f"fast: simplified visual meshes (surface error at most {1000 * float(settings.get('max_error', 0)):.2g} mm"
    drawn = summary.get("triangles_drawn")
    if drawn:
        line += f"; {drawn['full'][1] / 1000:.0f} k -> {drawn['fast'][1] / 1000:.0f} k triangles per scene at most"
    line += ")"
    diffs = summary.get("difference", {})
    if diffs:
        parts = [f"{camera} mean {d['mean_abs']:.4f}, max {d['max_abs']:.3f}" for camera, d in diffs.items()]
        frames = max(int(d["frames"]) for d in diffs.values())
        line += f"; |fast - full| on a 0-1 scale over {frames} frames: " + "; ".join(parts)
    return line


def card_settings(
    found_machines: list[dict[str, Any]], found_renderers: list[dict[str, Any]]
) -> dict[str, str]:
    """Rows for the card's settings table: one per machine and one per renderer."""
    rows: dict[str, str] = {}
    for m in found_machines:
        rows[f"numeric path {m.get('numeric_key', 'unknown')}"] = f"{machine_line(m)} ({_episodes(m)})"
    for r in found_renderers:
        rows[f"OpenGL renderer ({r['backend']})"] = (
            f"{r['vendor']} · {r['renderer']} · {r['version']} ({_episodes(r)})"
        )
    return rows


def machine_line(fingerprint: dict[str, Any]) -> str:
    """A fingerprint in one line: CPU and vector extensions, BLAS kernels, NumPy SIMD, libm, pinning."""
    if fingerprint.get("numeric_key") == "unknown" or "cpu" not in fingerprint:
        return "not recorded (episodes searched before libero-data recorded machines)"
    blas = ", ".join(
        f"{b['library']} {b['version']} {b['kernel']} kernel" for b in fingerprint.get("blas", [])
    )
    simd = (fingerprint.get("numpy_simd") or ["baseline"])[-1]
    return (
        f"{fingerprint['cpu']} ({' '.join(fingerprint.get('vector_extensions', []))}); "
        f"BLAS: {blas or 'none loaded'}; NumPy SIMD up to {simd}; {fingerprint.get('libm', 'libm unknown')}; "
        f"numerics {fingerprint.get('numerics', 'unknown')}"
    )


def _episodes(entry: dict[str, Any]) -> str:
    n = int(entry["episodes"])
    return f"{n} episode" if n == 1 else f"{n} episodes"
