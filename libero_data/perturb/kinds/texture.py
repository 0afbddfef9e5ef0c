"""``texture``: the table, floor and walls tinted (levels 1–2), their images replaced by installed
robosuite/LIBERO textures (3–4), then by generated patterns (5)."""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from libero_data.errors import InputError
from libero_data.perturb.kinds.base import Drawn, Kind, register, sign, tint
from libero_data.perturb.textures import generated_texture, installed_texture

#: Scene parts a texture perturbation changes, by the materials LIBERO's arenas give them.
PART_MATERIALS = {"table": "table_texture", "floor": "floorplane", "walls": "walls_mat"}


@register
class Texture(Kind):
    order = 7
    summary = "table/floor/wall colour tints (1–2), installed textures (3–4), generated textures (5)"
    magnitudes: ClassVar[dict[str, tuple[Any, ...]]] = {
        "tint": (0.15, 0.30, 0.0, 0.0, 0.0),
        "tinted": (("table",), ("table", "floor", "walls"), (), (), ()),
        "installed": ((), (), ("table",), ("table", "floor"), ()),
        "generated": ((), (), (), (), ("table", "floor", "walls")),
    }

    def sample(self, m: dict[str, Any], rng: np.random.Generator) -> dict[str, Any]:
        return {
            "tints": {
                part: tint(float(rng.uniform()), m["tint"], brightness=sign(rng) * m["tint"])
                for part in m["tinted"]
            },
            "installed": {part: _installed(rng) for part in m["installed"]},
            "generated": {part: _pattern(rng) for part in m["generated"]},
        }

    def apply_scene(self, raw: Any, p: Drawn) -> None:
        model = raw.sim.model._model
        _upload(raw, model, _retexture(model, p.params))


def show_images(raw: Any, images: dict[str, str]) -> None:
    """Draw scene parts (``table``, ``floor``, ``walls``) with these images: an installed texture's
    ``<package>/<file>`` name or an image file's path (each resized to the part's texture)."""
    model = raw.sim.model._model
    _upload(raw, model, _retexture(model, {"installed": images}))


def _materials(model: Any) -> dict[str, int]:
    """Scene part -> material id; floor scenes (no table) treat the floor as the table."""
    import mujoco

    found = {
        part: mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_MATERIAL, name)
        for part, name in PART_MATERIALS.items()
    }
    if found["table"] < 0:
        found["table"] = found["floor"]
    return {part: mat for part, mat in found.items() if mat >= 0}


def _texture_of(model: Any, mat: int) -> int:
    ids = np.atleast_1d(model.mat_texid[mat])
    used = [int(t) for t in ids if t >= 0]
    return used[0] if used else -1


def _retexture(model: Any, params: dict[str, Any]) -> list[int]:
    """Tint materials and overwrite texture images; the textures whose images changed."""
    materials = _materials(model)
    for part, rgb in params.get("tints", {}).items():
        if part in materials:
            rgba = model.mat_rgba[materials[part]]
            rgba[:3] = np.clip(rgba[:3] * np.asarray(rgb), 0.0, 1.0)
    changed: list[int] = []
    images = [(part, "installed", v) for part, v in params.get("installed", {}).items()]
    images += [(part, "generated", v) for part, v in params.get("generated", {}).items()]
    for part, source, value in images:
        tex = _texture_of(model, materials[part]) if part in materials else -1
        if tex < 0 or tex in changed:
            continue
        h, w, c = int(model.tex_height[tex]), int(model.tex_width[tex]), int(model.tex_nchannel[tex])
        image = (
            installed_texture(str(value), w, h) if source == "installed" else generated_texture(value, w, h)
        )
        adr = int(model.tex_adr[tex])
        model.tex_data[adr : adr + h * w * c] = image[:, :, :c].reshape(-1)
        changed.append(tex)
    return changed


def _upload(raw: Any, model: Any, textures: list[int]) -> None:
    """Send changed texture images to robosuite's renderer (ours builds its context later)."""
    import mujoco

    context = getattr(raw.sim, "_render_context_offscreen", None)
    if context is None or not textures:
        return
    context.gl_ctx.make_current()
    for tex in textures:
        mujoco.mjr_uploadTexture(model, context.con, tex)


def _installed(rng: np.random.Generator) -> str:
    """An installed texture image, by ``<package>/<file>`` (so a variant names what it shows)."""
    from libero_data.perturb.textures import installed_textures

    names = list(installed_textures())
    if not names:
        raise InputError("no installed texture images found (LIBERO's assets or robosuite's)", field="kinds")
    return names[int(rng.integers(len(names)))]


def _pattern(rng: np.random.Generator) -> dict[str, Any]:
    """A generated texture: a pattern, two colours and a scale."""
    return {
        "pattern": str(rng.choice(["checker", "stripes", "noise", "gradient"])),
        "colour_a": [round(float(v), 3) for v in rng.uniform(0.05, 0.95, 3)],
        "colour_b": [round(float(v), 3) for v in rng.uniform(0.05, 0.95, 3)],
        "cells": int(rng.integers(4, 17)),
    }
