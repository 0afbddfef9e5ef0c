"""Privileged, read-only views of a running LIBERO scene for the scripted expert.

Everything the expert knows comes from here: poses of bodies and sites, collision geometry
as surface point clouds, joint positions of articulated fixtures, contacts, and the gripper.
The simulator is never changed through this module.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from libero_data.sim import LiberoEnv

# MuJoCo geom types.
_PLANE, _HFIELD, _SPHERE, _CAPSULE, _ELLIPSOID, _CYLINDER, _BOX, _MESH = 0, 1, 2, 3, 4, 5, 6, 7
_SPACING = 0.004  # surface sample spacing in metres


@dataclass(frozen=True)
class Site:
    """A placement region: centre, rotation and half sizes in its own frame."""

    name: str
    pos: np.ndarray
    mat: np.ndarray
    size: np.ndarray

    def contains_xy(self, point: np.ndarray, margin: float = 0.0) -> bool:
        local = self.mat.T @ (np.asarray(point) - self.pos)
        return bool(np.all(np.abs(local[:2]) < self.size[:2] - margin))


@dataclass(frozen=True)
class Joint:
    """A hinge or slide joint of an articulated fixture, in world coordinates."""

    name: str
    kind: str  # "hinge" or "slide" (or "free"/"ball" for movable bodies)
    qpos: float
    range: tuple[float, float]
    anchor: np.ndarray
    axis: np.ndarray
    body: str


class SceneView:
    """Read access to one environment's simulator, by the names the BDDL file uses."""

    def __init__(self, env: LiberoEnv) -> None:
        import mujoco

        self._mj = mujoco
        self.env = env
        self.raw = env.raw
        self.model = env.sim.model._model
        self.data = env.sim.data._data
        m = self.model
        self._body_names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, i) or "" for i in range(m.nbody)]
        self._children: dict[int, list[int]] = {}
        for body in range(1, m.nbody):
            self._children.setdefault(int(m.body_parentid[body]), []).append(body)
        self._grip_site = self.site_id("gripper0_grip_site")
        self._finger_geoms = {
            self.geom_id(n) for n in ("gripper0_finger1_pad_collision", "gripper0_finger2_pad_collision")
        }
        self._gripper_bodies = {b for b in range(m.nbody) if self._body_names[b].startswith("gripper0")}
        self._robot_bodies = {
            b for b in range(m.nbody) if self._body_names[b].startswith(("robot0", "gripper0"))
        }
        self._samples: dict[int, np.ndarray] = {}

    # ids ---------------------------------------------------------------------------------
    def site_id(self, name: str) -> int:
        i = self._mj.mj_name2id(self.model, self._mj.mjtObj.mjOBJ_SITE, name)
        if i < 0:
            raise KeyError(f"no site {name!r} in the scene")
        return int(i)

    def geom_id(self, name: str) -> int:
        i = self._mj.mj_name2id(self.model, self._mj.mjtObj.mjOBJ_GEOM, name)
        if i < 0:
            raise KeyError(f"no geom {name!r} in the scene")
        return int(i)

    def body_id(self, name: str) -> int:
        """The root body of a BDDL object or fixture (or any body by its MuJoCo name)."""
        if name in self.raw.obj_body_id:
            return int(self.raw.obj_body_id[name])
        i = self._mj.mj_name2id(self.model, self._mj.mjtObj.mjOBJ_BODY, name)
        if i < 0:
            raise KeyError(f"no object or body {name!r} in the scene")
        return int(i)

    def shoulder_pos(self) -> np.ndarray:
        """World position of the arm's shoulder (the second joint's link)."""
        return self.data.xpos[self.body_id("robot0_link2")].copy()

    def body_name(self, body: int) -> str:
        return self._body_names[body]

    def subtree(self, body: int) -> list[int]:
        out, stack = [], [body]
        while stack:
            b = stack.pop()
            out.append(b)
            stack.extend(self._children.get(b, []))
        return out

    def bodies(self, name: str) -> list[int]:
        return self.subtree(self.body_id(name))

    def collision_geoms(self, bodies: list[int]) -> list[int]:
        m = self.model
        wanted = set(bodies)
        return [
            g
            for g in range(m.ngeom)
            if int(m.geom_bodyid[g]) in wanted and (m.geom_contype[g] or m.geom_conaffinity[g])
        ]

    # poses -------------------------------------------------------------------------------
    def pos(self, name: str) -> np.ndarray:
        return self.data.xpos[self.body_id(name)].copy()

    def mat(self, name: str) -> np.ndarray:
        return self.data.xmat[self.body_id(name)].reshape(3, 3).copy()

    def com(self, name: str) -> np.ndarray:
        """Mass-weighted centre of an object's subtree."""
        bodies = self.bodies(name)
        mass = self.model.body_mass[bodies]
        return (self.data.xipos[bodies] * mass[:, None]).sum(0) / max(mass.sum(), 1e-9)

    def speed(self, name: str) -> float:
        """Linear speed (m/s) of an object's root body."""
        return float(np.linalg.norm(self.data.cvel[self.body_id(name)][3:]))

    def site(self, name: str) -> Site:
        i = self.site_id(name)
        return Site(
            name=name,
            pos=self.data.site_xpos[i].copy(),
            mat=self.data.site_xmat[i].reshape(3, 3).copy(),
            size=self.model.site_size[i].copy(),
        )

    def has_site(self, name: str) -> bool:
        return self._mj.mj_name2id(self.model, self._mj.mjtObj.mjOBJ_SITE, name) >= 0

    # the gripper ---------------------------------------------------------------------------
    def eef_pos(self) -> np.ndarray:
        return self.data.site_xpos[self._grip_site].copy()

    def eef_mat(self) -> np.ndarray:
        return self.data.site_xmat[self._grip_site].reshape(3, 3).copy()

    def finger_opening(self) -> float:
        """Distance between the finger joints (0 closed, ~0.08 m fully open)."""
        q = self.env.sim.data.qpos
        idx = self.raw.robots[0]._ref_gripper_joint_pos_indexes
        return float(abs(q[idx[0]]) + abs(q[idx[1]]))

    # geometry ------------------------------------------------------------------------------
    def points(self, name: str) -> np.ndarray:
        """World-frame surface samples of an object's collision geometry, shape (N, 3)."""
        return self.points_of_bodies(self.bodies(name))

    def points_of_bodies(self, bodies: list[int]) -> np.ndarray:
        chunks = []
        for g in self.collision_geoms(bodies):
            local = self._local_points(g)
            if len(local):
                chunks.append(local @ self.data.geom_xmat[g].reshape(3, 3).T + self.data.geom_xpos[g])
        return np.concatenate(chunks) if chunks else np.zeros((0, 3))

    def obstacle_points(
        self, exclude: tuple[str, ...] = (), include_robot: bool = False, exclude_bodies: tuple[int, ...] = ()
    ) -> np.ndarray:
        """Points of every object and fixture except ``exclude`` (and the robot)."""
        skip: set[int] = set(exclude_bodies)
        for name in exclude:
            skip.update(self.bodies(name))
        if not include_robot:
            skip.update(self._robot_bodies)
        bodies = [b for b in range(1, self.model.nbody) if b not in skip]
        return self.points_of_bodies(bodies)

    def _local_points(self, geom: int) -> np.ndarray:
        # Cached per view (a class-level cache would keep every environment alive).
        cached = self._samples.get(geom)
        if cached is None:
            cached = self._samples[geom] = _surface_samples(self.model, geom)
        return cached

    def aabb(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        pts = self.points(name)
        return pts.min(0), pts.max(0)

    # articulation ----------------------------------------------------------------------------
    def joints_of(self, name: str) -> list[Joint]:
        """Hinge and slide joints inside an object's subtree."""
        m = self.model
        wanted = set(self.bodies(name))
        out = []
        for j in range(m.njnt):
            kind = int(m.jnt_type[j])
            if int(m.jnt_bodyid[j]) not in wanted or kind not in (2, 3):
                continue
            out.append(self.joint(self._mj.mj_id2name(m, self._mj.mjtObj.mjOBJ_JOINT, j)))
        return out

    def joint(self, joint_name: str) -> Joint:
        m, d = self.model, self.data
        j = self._mj.mj_name2id(m, self._mj.mjtObj.mjOBJ_JOINT, joint_name)
        if j < 0:
            raise KeyError(f"no joint {joint_name!r}")
        body = int(m.jnt_bodyid[j])
        return Joint(
            name=joint_name,
            kind=("free", "ball", "slide", "hinge")[int(m.jnt_type[j])],
            qpos=float(d.qpos[m.jnt_qposadr[j]]),
            range=(float(m.jnt_range[j][0]), float(m.jnt_range[j][1])),
            anchor=d.xanchor[j].copy(),
            axis=d.xaxis[j].copy(),
            body=self._body_names[body],
        )

    # contacts --------------------------------------------------------------------------------
    def in_contact(self, a: str, b: str) -> bool:
        ba, bb = set(self.bodies(a)), set(self.bodies(b))
        m, d = self.model, self.data
        for i in range(d.ncon):
            c = d.contact[i]
            g1, g2 = int(m.geom_bodyid[c.geom1]), int(m.geom_bodyid[c.geom2])
            if (g1 in ba and g2 in bb) or (g1 in bb and g2 in ba):
                return True
        return False

    def grasped(self, name: str) -> bool:
        """Both finger pads (or fingers) touch the object."""
        bodies = set(self.bodies(name))
        m, d = self.model, self.data
        touching: set[str] = set()
        for i in range(d.ncon):
            c = d.contact[i]
            for mine, other in ((c.geom1, c.geom2), (c.geom2, c.geom1)):
                body = int(m.geom_bodyid[mine])
                if int(m.geom_bodyid[other]) in bodies and body in self._gripper_bodies:
                    bname = self._body_names[body]
                    if "left" in bname or "finger_joint1" in bname:
                        touching.add("left")
                    elif "right" in bname or "finger_joint2" in bname:
                        touching.add("right")
        return touching == {"left", "right"}

    def robot_touches(self, name: str) -> bool:
        bodies = set(self.bodies(name))
        m, d = self.model, self.data
        for i in range(d.ncon):
            c = d.contact[i]
            b1, b2 = int(m.geom_bodyid[c.geom1]), int(m.geom_bodyid[c.geom2])
            if (b1 in bodies and b2 in self._robot_bodies) or (b2 in bodies and b1 in self._robot_bodies):
                return True
        return False

    def support_height(self, xy: np.ndarray, radius: float, names: tuple[str, ...]) -> float:
        """Highest surface point of ``names`` within ``radius`` of ``xy``."""
        best = -np.inf
        for name in names:
            pts = self.points(name)
            near = np.linalg.norm(pts[:, :2] - xy[None], axis=1) < radius
            if near.any():
                best = max(best, float(pts[near, 2].max()))
        return best

    def object_state(self, name: str) -> Any:
        return self.raw.object_states_dict[name]


def _surface_samples(model: Any, g: int) -> np.ndarray:
    """Points on the surface of geom ``g`` in its own frame, about ``_SPACING`` apart."""
    kind = int(model.geom_type[g])
    size = model.geom_size[g]
    if kind == _BOX:
        return _box_points(size)
    if kind == _SPHERE:
        return _sphere_points(float(size[0]))
    if kind in (_CYLINDER, _CAPSULE):
        pts = _cylinder_points(float(size[0]), float(size[1]))
        if kind == _CAPSULE:
            cap = _sphere_points(float(size[0]))
            up = np.array([0.0, 0.0, size[1]])
            pts = np.concatenate([pts, cap + up, cap - up])
        return pts
    if kind == _ELLIPSOID:
        return _sphere_points(1.0) * size
    if kind == _MESH:
        mesh = int(model.geom_dataid[g])
        v0, nv = int(model.mesh_vertadr[mesh]), int(model.mesh_vertnum[mesh])
        f0, nf = int(model.mesh_faceadr[mesh]), int(model.mesh_facenum[mesh])
        verts = np.asarray(model.mesh_vert[v0 : v0 + nv], dtype=np.float64)
        faces = np.asarray(model.mesh_face[f0 : f0 + nf], dtype=np.int64)
        return _triangle_points(verts, faces)
    return np.zeros((0, 3))


def _grid(n: float, spacing: float = _SPACING) -> np.ndarray:
    count = max(2, int(np.ceil(2 * n / spacing)) + 1)
    return np.linspace(-n, n, count)


def _box_points(size: np.ndarray) -> np.ndarray:
    sx, sy, sz = (float(v) for v in size)
    area = 8 * (sx * sy + sy * sz + sx * sz)
    # Large slabs (tables, walls) get coarser samples: at most ~20k points per box.
    spacing = max(_SPACING, float(np.sqrt(area / 20_000)))
    faces = []
    for axis, half in enumerate((sx, sy, sz)):
        others = [i for i in range(3) if i != axis]
        a, b = np.meshgrid(_grid(size[others[0]], spacing), _grid(size[others[1]], spacing), indexing="ij")
        for sign in (-1.0, 1.0):
            pts = np.zeros((a.size, 3))
            pts[:, axis] = sign * half
            pts[:, others[0]] = a.ravel()
            pts[:, others[1]] = b.ravel()
            faces.append(pts)
    return np.concatenate(faces)


def _sphere_points(r: float) -> np.ndarray:
    n = max(20, int(4 * np.pi * r * r / _SPACING**2))
    i = np.arange(n) + 0.5
    phi = np.arccos(1 - 2 * i / n)
    theta = np.pi * (1 + 5**0.5) * i
    return r * np.stack([np.cos(theta) * np.sin(phi), np.sin(theta) * np.sin(phi), np.cos(phi)], axis=1)


def _cylinder_points(r: float, half: float) -> np.ndarray:
    around = max(8, int(2 * np.pi * r / _SPACING))
    ang = np.linspace(0, 2 * np.pi, around, endpoint=False)
    zs = _grid(half)
    a, z = np.meshgrid(ang, zs, indexing="ij")
    side = np.stack([r * np.cos(a.ravel()), r * np.sin(a.ravel()), z.ravel()], axis=1)
    rings = []
    for rr in np.linspace(0, r, max(2, int(r / _SPACING) + 1))[1:]:
        k = max(6, int(2 * np.pi * rr / _SPACING))
        aa = np.linspace(0, 2 * np.pi, k, endpoint=False)
        ring = np.stack([rr * np.cos(aa), rr * np.sin(aa), np.zeros(k)], axis=1)
        up = np.array([0.0, 0.0, half])
        rings += [ring + up, ring - up]
    return np.concatenate([side, *rings, np.array([[0, 0, half], [0, 0, -half]])])


def _triangle_points(verts: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Deterministic area-proportional samples on each triangle, plus the vertices."""
    a, b, c = verts[faces[:, 0]], verts[faces[:, 1]], verts[faces[:, 2]]
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    spacing = max(_SPACING, float(np.sqrt(area.sum() / 40_000)))
    counts = np.ceil(area / (spacing**2 * 0.5)).astype(int)
    counts = np.minimum(counts, 400)
    total = int(counts.sum())
    rng = np.random.default_rng(0)
    tri = np.repeat(np.arange(len(faces)), counts)
    r1 = np.sqrt(rng.random(total))
    r2 = rng.random(total)
    pts = (1 - r1)[:, None] * a[tri] + (r1 * (1 - r2))[:, None] * b[tri] + (r1 * r2)[:, None] * c[tri]
    return np.concatenate([verts, pts])
