"""Top-down grasps planned on collision point clouds.

A candidate is a closing line over the object: a centre, a yaw and a height. It is kept
when the object's extent between the open fingers fits the gripper, the fingers can come
down beside the object without touching it or anything else, and the hand stays clear
above. Candidates are scored by closeness to the centre of mass (stable lifts), grasp depth
and clearance. Bowls and mugs come out as rim grasps, boxes and bottles as centre grasps,
without any per-object rule.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from libero_data.experts.geometry import top_down, wrap_half_turn
from libero_data.experts.scene import SceneView

# Panda hand, measured from its collision geometry in the grip-site frame.
MAX_OPENING = 0.078  # usable distance between the finger pads when open
FINGER_HALF_WIDTH = 0.011  # half width of a finger across the closing direction
FINGER_THICKNESS = 0.027
PAD_HALF = 0.008  # half size of a finger pad (square)
FINGER_LENGTH = 0.031  # from the grip site up to the hand
TIP_BELOW_SITE = 0.01  # finger tips reach this far below the grip site
PALM_HALF = (0.105, 0.033)  # hand half extents along / across the closing direction
HAND_TOP = 0.125  # top of the hand above the grip site


@dataclass(frozen=True)
class Grasp:
    pos: np.ndarray  # grip-site position at the grasp
    mat: np.ndarray  # gripper orientation (top down)
    yaw: float
    width: float  # object extent between the fingers
    score: float
    opening: float = MAX_OPENING  # finger opening on the way down (less: a pre-shaped hand)


@dataclass(frozen=True)
class GraspSearch:
    """How :func:`plan_top_down` searches.

    ``depths``: how far below the object's top the grip site goes, in the order tried.
    ``pad_tolerance``: how far (m) the object may stand out beyond the pads' contact higher up
    the fingers (flared walls): small is safe, larger admits thin flared rims. ``opening``
    below the full opening plans for a pre-shaped hand that comes down with its fingers only
    that far apart: then one finger can go inside a bowl and pinch its wall, where a fully open
    hand would reach the far wall. ``limit`` stops the search after that many feasible grasps
    (``limit=1`` answers "is there any?" cheaply).
    """

    depths: tuple[float, ...] = (0.025, 0.015, 0.035, 0.008)
    n_yaw: int = 12
    spacing: float = 0.01
    max_points: int = 2500
    pad_tolerance: float = 0.004
    opening: float = MAX_OPENING
    limit: int | None = None


@dataclass(frozen=True)
class FixturePart:
    """A part of a fixture to grasp instead of a whole object (a stove's knob): its points,
    the bodies that are not obstacles, and the point to grasp close to."""

    points: np.ndarray
    bodies: tuple[int, ...]
    prefer: np.ndarray


class Moved(NamedTuple):
    """Bodies to plan around as if displaced by ``offset`` (m, world frame)."""

    bodies: tuple[int, ...]
    offset: np.ndarray


#: Points as coordinates along a closing line, across it and up, sorted by the second.
_Sorted = tuple[np.ndarray, np.ndarray, np.ndarray]


class _Line(NamedTuple):
    """The points near one closing line: the object's on the line (``o``), and everything's
    around it (``l``), each as coordinates along, across and up; the line's offset and top."""

    du_o: np.ndarray
    dv_o: np.ndarray
    z_o: np.ndarray
    du_l: np.ndarray
    dv_l: np.ndarray
    z_l: np.ndarray
    cv: float
    top: float


def plan_top_down(
    scene: SceneView,
    name: str,
    *,
    yaw_reference: float,
    search: GraspSearch = GraspSearch(),
    part: FixturePart | None = None,
    stats: dict[str, int] | None = None,
    moved: Moved | None = None,
) -> list[Grasp]:
    """Feasible top-down grasps of ``name`` (or of a ``part`` of it), best first; empty when
    none fits. ``stats``, when given, counts the candidates rejected for each reason;
    ``moved`` plans as if those bodies stood elsewhere (a drawer once it is open)."""
    stats = {} if stats is None else stats
    obj = _subsample(scene.points(name) if part is None else part.points, search.max_points)
    lo, hi = obj.min(0), obj.max(0)
    margin = 0.12
    others = scene.obstacle_points(
        exclude=(name,) if part is None else (),
        exclude_bodies=(() if part is None else part.bodies) + (() if moved is None else moved.bodies),
    )
    if moved is not None:
        others = np.concatenate([others, scene.points_of_bodies(list(moved.bodies)) + moved.offset])
    near = np.all((others[:, :2] > lo[:2] - margin) & (others[:, :2] < hi[:2] + margin), axis=1)
    others = _subsample(others[near], search.max_points)
    floor = _support_below(others, lo, hi)
    everything = np.concatenate([obj, others]) if len(others) else obj
    com = scene.com(name)[:2] if part is None else np.asarray(part.prefer)[:2]

    xs = np.arange(lo[0], hi[0] + 1e-9, search.spacing)
    ys = np.arange(lo[1], hi[1] + 1e-9, search.spacing)
    centres = np.stack(np.meshgrid(xs, ys, indexing="ij"), -1).reshape(-1, 2)
    candidates: list[Grasp] = []
    for k in range(search.n_yaw):
        yaw = np.pi * k / search.n_yaw
        u = np.array([np.cos(yaw), np.sin(yaw)])
        v = np.array([-u[1], u[0]])
        # Points sorted across the closing line: each candidate then looks only at the
        # slice of points near its line (a binary search), not at every point.
        sorted_obj, sorted_all = _sorted_by_v(obj, u, v), _sorted_by_v(everything, u, v)
        for c in centres:
            line = _closing_line(c, u, v, sorted_obj, sorted_all, search.opening)
            if line is None:
                stats["empty"] = stats.get("empty", 0) + 1
                continue
            for depth in search.depths:
                found = _grasp_on(line, depth, floor, u, v, yaw, com, yaw_reference, search)
                if isinstance(found, str):
                    stats[found] = stats.get(found, 0) + 1
                    continue
                candidates.append(found)
                if search.limit is not None and len(candidates) >= search.limit:
                    return sorted(candidates, key=lambda g: -g.score)
    candidates.sort(key=lambda g: -g.score)
    return candidates


def _closing_line(
    c: np.ndarray,
    u: np.ndarray,
    v: np.ndarray,
    sorted_obj: _Sorted,
    sorted_all: _Sorted,
    opening: float,
) -> _Line | None:
    """The points that matter for a closing line through ``c`` along ``u`` (None: too few of
    the object's)."""
    cu, cv = float(c @ u), float(c @ v)
    du_o, dv_o, z_o = _near(*sorted_obj, cv, FINGER_HALF_WIDTH)
    in_line = (np.abs(dv_o - cv) < FINGER_HALF_WIDTH) & (np.abs(du_o - cu) < opening / 2)
    if in_line.sum() < 3:
        return None
    # From here on only the points on this closing line matter.
    du_o, dv_o, z_o = du_o[in_line], dv_o[in_line], z_o[in_line]
    # Only what is near this closing line can touch the hand.
    du_e, dv_e, z_e = _near(*sorted_all, cv, PALM_HALF[1] + 0.04)
    local = (np.abs(du_e - cu) < PALM_HALF[0] + 0.06) & (np.abs(dv_e - cv) < PALM_HALF[1] + 0.04)
    return _Line(du_o, dv_o, z_o, du_e[local], dv_e[local], z_e[local], cv, float(z_o.max()))


def _grasp_on(
    line: _Line,
    depth: float,
    floor: float,
    u: np.ndarray,
    v: np.ndarray,
    yaw: float,
    com: np.ndarray,
    yaw_reference: float,
    search: GraspSearch,
) -> Grasp | str:
    """The grasp on ``line`` at ``depth`` below its top, or the reason there is none."""
    top = line.top
    z = max(top - depth, floor + TIP_BELOW_SITE + 0.001)
    if z > top - 0.003:
        return "shallow"
    held = _held_between_pads(line, z, search)
    if isinstance(held, str):
        return held
    lo_u, hi_u = held
    width = hi_u - lo_u
    clearance = _finger_clearance(line, z, (lo_u + hi_u) / 2, width, search.opening)
    if isinstance(clearance, str):
        return clearance
    xy = (lo_u + hi_u) / 2 * u + line.cv * v
    off_centre = float(np.linalg.norm(xy - com))
    grasp_depth = top - z
    # Off-centre (rim) grasps hold best when the fingers close across the wall, i.e.
    # along the line from the centre: penalise closing at an angle to it.
    across = 0.0
    if off_centre > 0.015:
        radial = (xy - com) / off_centre
        across = abs(float(radial @ v)) * min(off_centre / 0.03, 1.0)
    yaw_w = wrap_half_turn(yaw, yaw_reference)
    score = (
        -off_centre / 0.02
        + min(grasp_depth, 0.03) / 0.01
        + clearance / 0.01
        - abs(yaw_w - yaw_reference) / 1.0
        - max(width - 0.06, 0.0) / 0.01
        - max(0.012 - width, 0.0) / 0.004  # thin features (handles, edges) slip more
        - across * 2.0
    )
    return Grasp(
        pos=np.array([xy[0], xy[1], z]),
        mat=top_down(yaw_w),
        yaw=yaw_w,
        width=width,
        score=score,
        opening=search.opening,
    )


def _held_between_pads(line: _Line, z: float, search: GraspSearch) -> tuple[float, float] | str:
    """The object's extent (along the closing line) between the fingers at height ``z``, if
    the pads hold it; else the reason they would not."""
    du_o, dv_o, z_o, cv = line.du_o, line.dv_o, line.z_o, line.cv
    span = (z_o > z - TIP_BELOW_SITE) & (z_o < z + FINGER_LENGTH)
    if span.sum() < 3:
        return "span"
    lo_u, hi_u = float(du_o[span].min()), float(du_o[span].max())
    width = hi_u - lo_u
    if width > search.opening - 0.01 or width < 0.004:
        return "width"
    # The pads must make the first contact on both sides: the outermost points
    # between the fingers lie in front of the pads, not at a finger's edge or top.
    pads = span & (np.abs(dv_o - cv) < PAD_HALF) & (np.abs(z_o - z) < PAD_HALF + 0.002)
    if (
        pads.sum() < 2
        or float(du_o[pads].min()) - lo_u > search.pad_tolerance
        or hi_u - float(du_o[pads].max()) > search.pad_tolerance
    ):
        return "pads"
    # Antipodal contacts: across each pad, the contact surface must face the pad
    # (not run along the closing direction, as a chord across a bowl's edge does),
    # or the squeeze slides off. Compare the surface's position at both pad edges.
    band = pads & (np.abs(z_o - z) < PAD_HALF)
    sides_ok = True
    for sign in (1.0, -1.0):
        left = band & (dv_o - cv > -PAD_HALF) & (dv_o - cv < -0.002)
        right = band & (dv_o - cv > 0.002) & (dv_o - cv < PAD_HALF)
        if left.sum() < 2 or right.sum() < 2:
            continue
        edge_l = float((sign * du_o[left]).max())
        edge_r = float((sign * du_o[right]).max())
        if abs(edge_l - edge_r) > 0.8 * (PAD_HALF + 0.002):
            sides_ok = False
    if not sides_ok:
        return "slanted"
    # Squeezing a wide body whose sides flare out above the pads pushes it down
    # out of the fingers (bowls held from outside): not allowed beyond 1.5 mm.
    if width > 0.02:
        above = span & (z_o > z + PAD_HALF)
        if above.any() and (
            float(du_o[pads].min()) - float(du_o[above].min()) > 0.0015
            or float(du_o[above].max()) - float(du_o[pads].max()) > 0.0015
        ):
            return "flare"
    return lo_u, hi_u


def _finger_clearance(line: _Line, z: float, gu: float, width: float, opening: float) -> float | str:
    """How far the nearest other point is from the fingers coming down at ``gu`` (at most
    3 cm), or the reason they cannot come down (something in the way of a finger or the palm)."""
    # The fingers come down outside [lo_u, hi_u]: nothing may be there.
    rel_u = line.du_l - gu
    rel_v = np.abs(line.dv_l - line.cv)
    z_l = line.z_l
    inner = opening / 2
    in_fingers = (
        (np.abs(rel_u) > width / 2 + 0.002)
        & (np.abs(rel_u) < inner + FINGER_THICKNESS)
        & (rel_v < FINGER_HALF_WIDTH)
        & (z_l > z - TIP_BELOW_SITE)
    )
    if in_fingers.any():
        return "fingers"
    in_palm = (np.abs(rel_u) < PALM_HALF[0]) & (rel_v < PALM_HALF[1]) & (z_l > z + FINGER_LENGTH)
    if in_palm.any():
        return "palm"
    # Clearance: distance from the finger volumes to the nearest other point.
    band = (rel_v < FINGER_HALF_WIDTH + 0.03) & (z_l > z - TIP_BELOW_SITE)
    outside = band & (np.abs(rel_u) > inner + FINGER_THICKNESS)
    clearance = 0.03
    if outside.any():
        clearance = min(clearance, float((np.abs(rel_u[outside]) - inner - FINGER_THICKNESS).min()))
    return clearance


def has_top_down_grasp(scene: SceneView, name: str) -> bool:
    """Whether any top-down grasp fits ``name``, with the strict or the loose pad rule."""
    return bool(
        plan_top_down(scene, name, yaw_reference=0.0, search=GraspSearch(limit=1))
        or plan_top_down(scene, name, yaw_reference=0.0, search=GraspSearch(pad_tolerance=0.008, limit=1))
    )


def _sorted_by_v(points: np.ndarray, u: np.ndarray, v: np.ndarray) -> _Sorted:
    """Coordinates along ``u``, across (``v``) and heights of ``points``, sorted by ``v``."""
    du, dv = points[:, :2] @ u, points[:, :2] @ v
    order = np.argsort(dv, kind="stable")
    return du[order], dv[order], points[order, 2]


def _near(du: np.ndarray, dv: np.ndarray, z: np.ndarray, cv: float, half: float) -> tuple[np.ndarray, ...]:
    """The slice of points (sorted by ``dv``) with ``|dv - cv| < half``, and a little more.

    The slice is a superset (1 mm wider); callers apply the exact test to it.
    """
    a, b = np.searchsorted(dv, (cv - half - 1e-3, cv + half + 1e-3))
    return du[a:b], dv[a:b], z[a:b]


def _subsample(points: np.ndarray, n: int) -> np.ndarray:
    if len(points) <= n:
        return points
    idx = np.linspace(0, len(points) - 1, n).astype(int)
    return points[idx]


def _support_below(others: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> float:
    """Height of the surface the object rests on (the floor plane counts as z = 0)."""
    under = np.all((others[:, :2] > lo[:2]) & (others[:, :2] < hi[:2]), axis=1) & (
        others[:, 2] < lo[2] + 0.005
    )
    if under.any():
        return float(others[under, 2].max())
    return min(0.0, float(lo[2])) if lo[2] < 0.3 else float(lo[2])


WRIST_TOP = 0.26  # the last arm link (wrist) reaches this far above the grip site
WRIST_HALF = 0.055


def hand_collisions(
    points: np.ndarray,
    pos: np.ndarray,
    mat: np.ndarray,
    opening: float = 0.0,
    margin: float = 0.0,
    fingers: bool = True,
) -> int:
    """How many ``points`` the gripper would occupy at ``pos``/``mat`` (fingers ``opening`` apart).

    The gripper is modelled as boxes in its own frame (x closing, z approach): two fingers
    from the tips up to the palm, the hand above them and the wrist link above the hand,
    each grown by ``margin``. ``fingers=False`` counts the hand and wrist only.
    """
    local = (np.asarray(points) - pos) @ mat
    x, y, z = local[:, 0], local[:, 1], -local[:, 2]  # z: height above the grip site
    m = margin
    in_fingers = (
        (np.abs(x) > opening / 2 - m)
        & (np.abs(x) < opening / 2 + FINGER_THICKNESS + m)
        & (np.abs(y) < FINGER_HALF_WIDTH + m)
        & (z > -TIP_BELOW_SITE - m)
        & (z < FINGER_LENGTH)
    )
    hand = (
        (np.abs(x) < PALM_HALF[0] + m)
        & (np.abs(y) < PALM_HALF[1] + m)
        & (z >= FINGER_LENGTH)
        & (z < HAND_TOP)
    )
    wrist = (np.abs(x) < WRIST_HALF + m) & (np.abs(y) < WRIST_HALF + m) & (z >= HAND_TOP) & (z < WRIST_TOP)
    if not fingers:
        return int((hand | wrist).sum())
    return int((in_fingers | hand | wrist).sum())
