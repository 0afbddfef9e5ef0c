"""A LIBERO-Plus scene class's look applied to LIBERO's built scene: floor and wall images, and
from a scene XML of their assets the images of LIBERO's scene materials (table, floor, walls) and
the lights it defines, matched by name. The built scene's geometry stays LIBERO's; a scene XML
whose light the built scene does not have is refused in one sentence (a built model cannot gain
a light)."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np

from libero_data.errors import FileFormatError
from libero_data.perturb.kinds.texture import PART_MATERIALS, show_images

#: Light attributes a scene XML may set, and the model's array of each.
LIGHT_FIELDS = {
    "pos": "light_pos",
    "dir": "light_dir",
    "diffuse": "light_diffuse",
    "specular": "light_specular",
    "ambient": "light_ambient",
    "attenuation": "light_attenuation",
    "cutoff": "light_cutoff",
    "exponent": "light_exponent",
    "castshadow": "light_castshadow",
}


def apply_plus_scene(raw: Any, scene: dict[str, Any]) -> None:
    """``scene``: ``floor``/``walls`` images (an installed texture's name or a file) and
    ``scene_xml`` (a file of their assets), each None where the class keeps LIBERO's."""
    images = {part: scene[part] for part in ("floor", "walls") if scene.get(part)}
    if scene.get("scene_xml"):
        looks = scene_looks(Path(scene["scene_xml"]))
        images.update(looks["images"])
        set_lights(raw, looks["lights"], where=scene["scene_xml"])
    if images:
        show_images(raw, images)


def scene_looks(path: Path) -> dict[str, Any]:
    """The images of LIBERO's scene materials and the named lights a scene XML defines."""
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError) as exc:
        raise FileFormatError(f"LIBERO-Plus scene {path} cannot be read ({exc})") from None
    textures = {t.get("name"): t.get("file") for t in root.iter("texture") if t.get("file")}
    materials = {m.get("name"): m.get("texture") for m in root.iter("material")}
    images: dict[str, str] = {}
    for part, material in PART_MATERIALS.items():
        file = textures.get(materials.get(material))
        if file:
            images[part] = str((path.parent / file).resolve())
    lights = {
        str(light.get("name")): {k: v for k, v in light.attrib.items() if k in LIGHT_FIELDS}
        for light in root.iter("light")
        if light.get("name")
    }
    return {"images": images, "lights": lights}


def set_lights(raw: Any, lights: dict[str, dict[str, str]], *, where: str) -> None:
    """Give the built scene's lights of these names the attributes given."""
    import mujoco

    model, data = raw.sim.model._model, raw.sim.data._data
    for name, attributes in lights.items():
        light = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_LIGHT, name)
        if light < 0:
            raise FileFormatError(
                f"LIBERO-Plus scene {where} defines light {name!r}, which LIBERO's scene does not have"
            )
        for key, text in attributes.items():
            field = getattr(model, LIGHT_FIELDS[key])
            if key == "castshadow":
                field[light] = text.strip().lower() in ("true", "1")
                continue
            values = np.array([float(v) for v in text.split()])
            field[light] = values if values.size > 1 else values[0]
    mujoco.mj_kinematics(model, data)
