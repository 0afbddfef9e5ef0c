"""Applying a :class:`~libero_data.perturb.spec.Perturbation` to a built LIBERO scene.

``LiberoEnv`` calls these; each takes the robosuite environment it wraps:

- :func:`apply_scene` once, after the scene is built: ``camera`` moves the agentview camera
  about the point its optical axis meets the table (or floor) and changes its field of view;
  ``lighting`` scales, tints and turns the lights (shadows from level 3); ``texture`` tints the
  table, floor and wall materials or replaces their images by installed or generated
  textures (and uploads them to the renderer that already holds the old ones). Physics is
  untouched: only what cameras see changes.
- :func:`start_robot` after each reset: ``robot_init`` offsets the arm joints by values drawn
  from the perturbation's seed and the reset's seed (halved until the arm touches nothing).
- :func:`add_noise` to each observation: ``noise`` blurs, noises and JPEG-compresses the
  images and adds Gaussian noise to the proprioception, seeded by the perturbation's seed and
  the simulator state itself, so the same state always gets the same noise and the state
  stays clean.
"""

from __future__ import annotations

import io
import zlib
from typing import Any

import numpy as np

from libero_data.perturb.spec import Perturbation
from libero_data.perturb.textures import generated_texture, installed_texture

CAMERA = "agentview"
#: Scene parts a texture perturbation changes, by the materials LIBERO's arenas give them.
PART_MATERIALS = {"table": "table_texture", "floor": "floorplane", "walls": "walls_mat"}
#: Proprioceptive observations that get noise (eef_quat stays a unit quaternion).
NOISY_STATE = ("state", "joint_pos", "gripper_state", "eef_pos")


def apply_scene(raw: Any, p: Perturbation) -> None:
    """Change the built scene of ``raw`` (robosuite's env) as ``p`` says (camera, lighting, texture)."""
    model, data = raw.sim.model._model, raw.sim.data._data
    if p.kind == "camera":
        _move_camera(model, data, p.params)
    elif p.kind == "lighting":
        _relight(model, p.params)
    elif p.kind == "texture":
        changed = _retexture(model, p.params)
        _upload(raw, model, changed)


# -- camera ---------------------------------------------------------------------------------------
def _rotation(axis: np.ndarray, degrees: float) -> np.ndarray:
    axis = axis / np.linalg.norm(axis)
    a = np.deg2rad(degrees)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(a) * k + (1 - np.cos(a)) * (k @ k)


def surface_height(model: Any, data: Any) -> float:
    """Height of the table top (or of the floor in floor scenes) the objects stand on."""
    import mujoco

    table = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "table_visual")
    if table >= 0:
        return float(data.geom_xpos[table][2] + model.geom_size[table][2])
    floor = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "floor")
    return float(data.geom_xpos[floor][2]) if floor >= 0 else 0.0


def _move_camera(model: Any, data: Any, params: dict[str, Any]) -> None:
    import mujoco

    cam = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, CAMERA)
    pos = np.array(model.cam_pos[cam], dtype=np.float64)
    flat = np.zeros(9)
    mujoco.mju_quat2Mat(flat, np.array(model.cam_quat[cam], dtype=np.float64))
    rot = flat.reshape(3, 3)
    forward = -rot[:, 2]  # cameras look along their -z axis
    height = surface_height(model, data)
    t = (height - pos[2]) / forward[2] if forward[2] < -1e-6 else 1.0
    pivot = pos + max(t, 0.1) * forward
    offset = pos - pivot
    turn = _rotation(np.array([0.0, 0.0, 1.0]), float(params["azimuth_deg"]))
    offset = turn @ offset
    tilt_axis = np.cross(offset, [0.0, 0.0, 1.0])
    tilt = (
        _rotation(tilt_axis, float(params["elevation_deg"]))
        if np.linalg.norm(tilt_axis) > 1e-9
        else np.eye(3)
    )
    moved = tilt @ turn
    model.cam_pos[cam] = pivot + float(params["distance_scale"]) * (tilt @ offset)
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, (moved @ rot).reshape(-1))
    model.cam_quat[cam] = quat
    model.cam_fovy[cam] = float(np.clip(model.cam_fovy[cam] + float(params["fovy_change_deg"]), 10.0, 120.0))
    mujoco.mj_kinematics(model, data)
    mujoco.mj_camlight(model, data)


# -- lighting -------------------------------------------------------------------------------------
def _relight(model: Any, params: dict[str, Any]) -> None:
    scale = float(params["intensity"]) * np.asarray(params["tint_rgb"], dtype=np.float64)
    model.light_diffuse[:] = np.clip(model.light_diffuse * scale, 0.0, 1.0)
    model.light_specular[:] = np.clip(model.light_specular * float(params["intensity"]), 0.0, 1.0)
    head = model.vis.headlight
    head.diffuse = np.clip(np.asarray(head.diffuse) * scale, 0.0, 1.0)
    head.ambient = np.clip(np.asarray(head.ambient) * scale, 0.0, 1.0)
    turn = _rotation(np.array([0.0, 0.0, 1.0]), float(params["direction_deg"]))
    model.light_dir[:] = model.light_dir @ turn.T
    model.light_pos[:] = model.light_pos @ turn.T
    if params.get("shadows") and model.nlight:
        model.light_castshadow[0] = 1


# -- textures -------------------------------------------------------------------------------------
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
    for part, tint in params.get("tints", {}).items():
        if part in materials:
            rgba = model.mat_rgba[materials[part]]
            rgba[:3] = np.clip(rgba[:3] * np.asarray(tint), 0.0, 1.0)
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


# -- robot start ----------------------------------------------------------------------------------
def start_robot(raw: Any, p: Perturbation, reset_seed: int) -> np.ndarray:
    """Offset the arm's joints for this reset; returns the offsets applied (radians)."""
    sim = raw.sim
    robot = raw.robots[0]
    joints = np.asarray(robot._ref_joint_pos_indexes)
    limit = float(p.params["joint_offset_rad"])
    rng = np.random.default_rng([p.seed, int(reset_seed) & 0xFFFFFFFF, 7])
    delta = rng.uniform(-limit, limit, len(joints))
    base = np.array(sim.data.qpos[joints], copy=True)
    low, high = _joint_limits(sim, robot)
    for scale in (1.0, 0.5, 0.25, 0.125, 0.0):
        sim.data.qpos[joints] = np.clip(base + scale * delta, low, high)
        sim.data.qvel[robot._ref_joint_vel_indexes] = 0.0
        sim.forward()
        if scale == 0.0 or not _robot_touches(sim, robot):
            return np.asarray(sim.data.qpos[joints] - base)
    return np.zeros(len(joints))


def _joint_limits(sim: Any, robot: Any) -> tuple[np.ndarray, np.ndarray]:
    model = sim.model._model
    ids = [model.joint(name).id for name in robot.robot_joints]
    ranges = model.jnt_range[ids]
    limited = (
        model.jnt_limited[ids].astype(bool) if hasattr(model, "jnt_limited") else np.ones(len(ids), bool)
    )
    low = np.where(limited, ranges[:, 0], -np.inf)
    high = np.where(limited, ranges[:, 1], np.inf)
    return low, high


def _robot_touches(sim: Any, robot: Any) -> bool:
    """Whether any arm or gripper geom penetrates anything else by more than a millimetre."""
    model, data = sim.model._model, sim.data._data
    names = [model.body(i).name for i in range(model.nbody)]
    mine = np.array([n.startswith(("robot0_", "gripper0_")) for n in names])
    for k in range(data.ncon):
        c = data.contact[k]
        a, b = mine[model.geom_bodyid[c.geom1]], mine[model.geom_bodyid[c.geom2]]
        if a != b and c.dist < -0.001:
            return True
    return False


# -- noise ----------------------------------------------------------------------------------------
def add_noise(obs: dict[str, Any], p: Perturbation, cameras: tuple[str, ...]) -> None:
    """Noise the images and proprioception of ``obs`` in place (its ``sim_state`` stays clean)."""
    state = np.ascontiguousarray(obs["sim_state"])
    rng = np.random.default_rng([p.seed, zlib.crc32(state.tobytes())])
    params = p.params
    for camera in cameras:
        if camera in obs:
            obs[camera] = noisy_image(obs[camera], params, rng)
    sigma = float(params["state_sigma"])
    for key in NOISY_STATE:
        value = np.asarray(obs[key])
        obs[key] = (value + rng.normal(0.0, sigma, value.shape)).astype(value.dtype)


def noisy_image(image: np.ndarray, params: dict[str, Any], rng: np.random.Generator) -> np.ndarray:
    """Blur, then Gaussian noise, then a JPEG round trip (each where its level sets one)."""
    from PIL import Image, ImageFilter

    out = image
    if float(params["blur_radius_px"]) > 0:
        out = np.asarray(
            Image.fromarray(out).filter(ImageFilter.GaussianBlur(float(params["blur_radius_px"])))
        )
    noisy = out.astype(np.float32) + rng.normal(0.0, float(params["gaussian_sigma_255"]), out.shape)
    out = np.clip(np.round(noisy), 0, 255).astype(np.uint8)
    quality = int(params["jpeg_quality"])
    if quality > 0:
        buffer = io.BytesIO()
        Image.fromarray(out).save(buffer, format="JPEG", quality=quality)
        buffer.seek(0)
        with Image.open(buffer) as img:
            out = np.asarray(img.convert("RGB"), dtype=np.uint8)
    return np.ascontiguousarray(out)
