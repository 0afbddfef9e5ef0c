"""Open and close a hinged door (the microwave's) around its vertical hinge."""

from __future__ import annotations

import numpy as np

from libero_data.experts.geometry import approach_frame, rot_z
from libero_data.experts.motion import CLOSE, OPEN, Actions
from libero_data.experts.skills.articulation import Part, holds, part_of
from libero_data.experts.skills.base import SKILLS, Context, Skill, SkillFailed, lift


class _Door:
    """The door's geometry now: hinge, the door's points, and which way is 'open'."""

    def __init__(self, ctx: Context, part: Part) -> None:
        scene = ctx.scene
        self.part = part
        joint = scene.joint(part.joint.name)
        self.anchor = joint.anchor
        self.axis = joint.axis / np.linalg.norm(joint.axis)
        self.points = scene.points_of_bodies(scene.subtree(scene.body_id(joint.body)))
        rel = self.points[:, :2] - self.anchor[:2]
        self.radius = float(np.linalg.norm(rel, axis=1).max())
        # Unit vector along the door (hinge to free edge) and the door's outward normal.
        far = self.points[np.linalg.norm(rel, axis=1) > 0.8 * self.radius]
        along = far[:, :2].mean(0) - self.anchor[:2]
        self.along = along / np.linalg.norm(along)
        body_centre = ctx.scene.pos(part.fixture)[:2]
        normal = np.array([-self.along[1], self.along[0]])
        if normal @ (self.anchor[:2] - body_centre) < 0:
            normal = -normal
        self.normal = normal  # points away from the cabinet body when the door is closed
        self.z_mid = float((self.points[:, 2].min() + self.points[:, 2].max()) / 2)
        self.z_top = float(self.points[:, 2].max())

    def swing(self, sign: float) -> np.ndarray:
        """Horizontal direction in which the door's free edge moves for a joint change of ``sign``."""
        tangent = np.cross(self.axis, np.array([*self.along, 0.0]))[:2] * sign
        return tangent / np.linalg.norm(tangent)


def _swing(ctx: Context, part: Part, sign: float, predicate: str) -> Actions:
    """Push the door round its hinge in joint direction ``sign`` until ``predicate`` holds.

    The closed fingertips press on the face that trails the motion, near the free edge, and
    are led about 0.35 rad ahead along the circle; the contact is re-planned from the
    door's actual angle whenever the hand has fallen behind.
    """
    ctx.motion.gripper = CLOSE
    fraction = 0.75 + ctx.jitter(0.05)
    z = None
    for _ in range(40):
        if holds(ctx, predicate, part.region) and (predicate != "Open" or part.opened_by(ctx) > 0):
            break
        door = _Door(ctx, part)
        z = door.z_mid + ctx.jitter(0.01) if z is None else z
        swing = door.swing(sign)
        contact = door.anchor[:2] + door.along * door.radius * fraction
        mat = approach_frame(np.array([0, 0, -1.0]), np.array([*door.along, 0.0]))
        if mat[:, 0] @ ctx.scene.eef_mat()[:, 0] < 0:
            mat = approach_frame(np.array([0, 0, -1.0]), -np.array([*door.along, 0.0]))
        behind = np.array([*(contact - swing * 0.035), z])
        here = ctx.scene.eef_pos()
        if np.linalg.norm(here[:2] - behind[:2]) > 0.04 or abs(here[2] - z) > 0.03:
            yield from lift(ctx, door.z_top + 0.06)
            # Where the arm cannot get there (the door's far side out of reach), the swing
            # goes on from where the hand stopped rather than pressing on for 120 steps.
            yield from ctx.motion.move(
                np.array([*behind[:2], door.z_top + 0.06]), mat, tol=0.015, max_steps=120, stall=8
            )
            yield from ctx.motion.move(behind, mat, speed=0.12, tol=0.008, max_steps=50, stall=8)
        ahead = rot_z(sign * 0.35 * np.sign(door.axis[2]))
        target = door.anchor[:2] + (ahead[:2, :2] @ (contact - door.anchor[:2])) - swing * 0.01
        yield from ctx.motion.move(np.array([*target, z]), ahead @ mat, speed=0.15, tol=0.01, max_steps=25)
    return True


@SKILLS.register("close_door")
class CloseDoor(Skill):
    """``close_door(fixture)``: push the open door shut, following its arc.

    The fingertips (closed) press on the door's face near its free edge and move ahead of
    it along the circle around the hinge. Randomised: contact radius and height.
    """

    name = "close_door"

    def run(self, ctx: Context) -> Actions:
        (name,) = self.args
        part = part_of(ctx, name)
        yield from _swing(ctx, part, -part.open_sign, "Close")
        yield from lift(ctx, ctx.scene.eef_pos()[2] + 0.05)
        if not holds(ctx, "Close", name):
            raise SkillFailed(f"{name} did not close")
        return True


@SKILLS.register("open_door")
class OpenDoor(Skill):
    """``open_door(fixture)``: take the handle from the front and swing the door open.

    The gripper points at the door, fingers closing around the handle; the hand then moves
    along the circle around the hinge, turning with the door. Randomised: grip height.
    """

    name = "open_door"

    def run(self, ctx: Context) -> Actions:
        (name,) = self.args
        part = part_of(ctx, name)
        door = _Door(ctx, part)
        sign = part.open_sign
        # The handle: door points standing out in front of the face, far from the hinge.
        rel = door.points[:, :2] - door.anchor[:2]
        out = rel @ door.normal
        radial = rel @ door.along
        handle = door.points[(out > out.max() - 0.02) & (radial > 0.5 * door.radius)]
        if len(handle) == 0:
            raise SkillFailed(f"no handle found on {name}")
        z = float(
            np.clip(
                handle[:, 2].mean() + ctx.jitter(0.02), handle[:, 2].min() + 0.02, handle[:, 2].max() - 0.02
            )
        )
        centre_xy = door.anchor[:2] + door.along * float(
            ((handle[:, :2] - door.anchor[:2]) @ door.along).mean()
        )
        bar_xy = centre_xy + door.normal * (float(((handle[:, :2] - door.anchor[:2]) @ door.normal).mean()))
        approach = np.array([*(-door.normal), 0.0])
        mat = approach_frame(approach, np.array([*door.along, 0.0]))
        if mat[:, 0] @ ctx.scene.eef_mat()[:, 0] < 0:
            mat = approach_frame(approach, -np.array([*door.along, 0.0]))
        grip = np.array([*bar_xy, z])
        ctx.motion.gripper = OPEN
        yield from lift(ctx, z + 0.05)
        yield from ctx.motion.move(grip - approach * 0.08, mat, tol=0.01, max_steps=150)
        yield from ctx.motion.move(grip + approach * 0.005, mat, speed=0.1, tol=0.005, max_steps=60)
        yield from ctx.motion.set_gripper(CLOSE, steps=10, mat=mat)
        turn_sign = sign * np.sign(door.axis[2])
        # Follow the door: the hand stays at the grasped point of the door, turned with it,
        # and is led a little ahead along the circle. Re-aimed from the actual door angle.
        q0 = ctx.scene.joint(part.joint.name).qpos
        grasped = ctx.scene.eef_pos()
        for _ in range(60):
            turned = abs(ctx.scene.joint(part.joint.name).qpos - q0)
            if (holds(ctx, "Open", name) and part.opened_by(ctx) > 0) or turned > 0.3:
                break
            rot = rot_z(turn_sign * (turned + 0.12))
            target = door.anchor + rot @ (grasped - door.anchor)
            target[2] = grasped[2]
            yield from ctx.motion.move(target, rot @ mat, speed=0.12, tol=0.004, rot_tol=0.05, max_steps=4)
        yield from ctx.motion.set_gripper(OPEN, steps=6, mat=ctx.scene.eef_mat())
        back = ctx.scene.eef_pos() - ctx.scene.eef_mat()[:, 2] * 0.06
        yield from ctx.motion.move(back, ctx.scene.eef_mat(), tol=0.02, max_steps=30)
        # The door stands ajar: reach behind its free edge and swing it the rest of the way.
        yield from _swing(ctx, part, part.open_sign, "Open")
        yield from lift(ctx, ctx.scene.eef_pos()[2] + 0.05)
        if not holds(ctx, "Open", name):
            raise SkillFailed(f"{name} did not open")
        return True
