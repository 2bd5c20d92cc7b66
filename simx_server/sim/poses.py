"""Object poses in V-REP's terms, as a mixin of :class:`simx_server.sim.world.World`: frames
(position and rotation matrix in the world frame), poses relative to another object (Euler
angles, quaternions), children, and placing an object (``simxSetObjectPosition`` ...).
Positions in m, angles in rad, quaternions (x, y, z, w) as V-REP writes them.
"""

from __future__ import annotations

import mujoco
import numpy as np

from simx_wire import constants as C
from simx_wire.protocol import ObjectTypeError
from simx_server.sim import grasps, physics
from simx_server.sim.objects import _TYPE_NAMES, JOINT, LIGHT, SHAPE, SITES, VISION_SENSOR, WORLD
from simx_server.sim.rotations import (
    _frame_with_z,
    euler_from_matrix,
    quaternion_from_matrix,
)


class Poses:
    """Poses of the objects of a :class:`~simx_server.sim.world.World` (needs its model, data and registry)."""

    # ------------------------------------------------------------------- poses
    def frame(self, handle: int) -> tuple[np.ndarray, np.ndarray]:
        """World position (3,) in m and rotation matrix (3, 3) of an object; -1 is the world.

        Args:
            handle: an object's handle, or -1.

        Returns:
            ``(position, rotation)``: arrays (3,) m and (3, 3). A vision sensor's frame looks along
            +z (V-REP's), a joint's z is its axis.

        Raises:
            UnknownObjectError: no such object.
        """
        if handle == WORLD:
            return np.zeros(3), np.eye(3)
        obj = self.get(handle)
        d = self.data
        if obj.type == SHAPE:
            return d.xpos[obj.mj_id].copy(), d.xmat[obj.mj_id].reshape(3, 3).copy()
        if obj.type == JOINT:
            return d.xanchor[obj.mj_id].copy(), _frame_with_z(d.xaxis[obj.mj_id],
                                                              d.xmat[obj.body].reshape(3, 3))
        if obj.type in SITES:
            return d.site_xpos[obj.mj_id].copy(), d.site_xmat[obj.mj_id].reshape(3, 3).copy()
        if obj.type == VISION_SENSOR:
            # MuJoCo cameras look along -z with y up; V-REP sensors look along +z with y up.
            r = d.cam_xmat[obj.mj_id].reshape(3, 3) @ np.diag([-1.0, 1.0, -1.0])
            return d.cam_xpos[obj.mj_id].copy(), r
        return d.light_xpos[obj.mj_id].copy(), _frame_with_z(d.light_xdir[obj.mj_id], np.eye(3))

    def relative_frame(self, handle: int, relative_to: int) -> tuple[np.ndarray, np.ndarray]:
        """Pose of ``handle`` in the frame of ``relative_to`` (-1 world, -11 parent).

        Args:
            handle: an object's handle.
            relative_to: another object's handle, -1 or -11 (``sim_handle_parent``).

        Returns:
            ``(position, rotation)``: arrays (3,) m and (3, 3).

        Raises:
            UnknownObjectError: no such object.
        """
        if relative_to == C.sim_handle_parent:
            relative_to = self.get(handle).parent
        p, r = self.frame(handle)
        p0, r0 = self.frame(relative_to)
        return r0.T @ (p - p0), r0.T @ r

    def position(self, handle: int, relative_to: int) -> list[float]:
        """Position (m) of an object relative to another. ``simxGetObjectPosition``.

        Args:
            handle: an object's handle.
            relative_to: another object's handle, -1 (world) or -11 (parent).

        Returns:
            ``[x, y, z]`` in m.

        Raises:
            UnknownObjectError: no such object.
        """
        return self.relative_frame(handle, relative_to)[0].tolist()

    def orientation(self, handle: int, relative_to: int) -> list[float]:
        """Euler angles alpha, beta, gamma (rad) with R = Rx(a) Ry(b) Rz(g). ``simxGetObjectOrientation``.

        Args:
            handle: an object's handle.
            relative_to: another object's handle, -1 (world) or -11 (parent).

        Returns:
            ``[alpha, beta, gamma]`` in rad.

        Raises:
            UnknownObjectError: no such object.
        """
        return euler_from_matrix(self.relative_frame(handle, relative_to)[1])

    def quaternion(self, handle: int, relative_to: int) -> list[float]:
        """Orientation as a quaternion in V-REP's order (x, y, z, w). ``simxGetObjectQuaternion``.

        Args:
            handle: an object's handle.
            relative_to: another object's handle, -1 (world) or -11 (parent).

        Returns:
            ``[x, y, z, w]``, unit length.

        Raises:
            UnknownObjectError: no such object.
        """
        return quaternion_from_matrix(self.relative_frame(handle, relative_to)[1])

    def children(self, handle: int) -> list[int]:
        """Handles of the objects whose parent is ``handle`` (-1: the world), in tree order.

        Args:
            handle: an object's handle, or -1.

        Returns:
            Handles.

        Raises:
            UnknownObjectError: no such object.
        """
        if handle != WORLD:
            self.get(handle)
        return [o.handle for o in self.objects.values() if o.parent == handle]

    def set_pose(self, handle: int, relative_to: int, position: list[float] | None = None,
                 rotation: np.ndarray | None = None) -> None:
        """Move an object: ``position`` (3,) in m and/or ``rotation`` (3, 3), both expressed in the
        frame of ``relative_to`` (-1 world, -11 parent). ``simxSetObjectPosition`` & co.

        Free bodies get a new free-joint state (velocity zeroed), mocap bodies a new mocap pose,
        bodies without joints, dummies, vision sensors and lights a new placement in their
        parent body. A hinge or slide joint alone in its body moves with its body (what hangs
        from it in V-REP), its state kept; a body moved by one such joint gets a new placement
        relative to the joint, which stays (V-REP's omni-wheels reset joints so, every step).
        Other bodies with joints (several, a ball) and ball joints cannot be placed (set their
        joints instead): ObjectTypeError. A coordinate of ``position`` beyond
        ±limits.MAX_POSITION: ArgumentError.

        Args:
            handle: the object's handle.
            relative_to: another object's handle, -1 or -11.
            position: the new position, or None to keep it.
            rotation: the new rotation, or None to keep it.

        Raises:
            UnknownObjectError: no such object.
            ObjectTypeError: an object that cannot be placed (above).
            ArgumentError: a position out of bounds.
        """
        if position is not None:
            physics.check_position(position)
        obj = self.get(handle)
        if relative_to == C.sim_handle_parent:
            relative_to = obj.parent
        p0, r0 = self.frame(relative_to)
        p_now, r_now = self.frame(handle)
        p = p_now if position is None else p0 + r0 @ np.asarray(position, dtype=float)
        r = r_now if rotation is None else r0 @ rotation
        m, d = self.model, self.data
        if obj.type == VISION_SENSOR:
            r = r @ np.diag([-1.0, 1.0, -1.0])  # back to MuJoCo's camera frame
        quat = np.empty(4)
        mujoco.mju_mat2Quat(quat, np.ascontiguousarray(r).reshape(9))
        if obj.type == SHAPE:
            b, jnum = obj.mj_id, m.body_jntnum[obj.mj_id]
            if m.body_mocapid[b] >= 0:
                d.mocap_pos[m.body_mocapid[b]], d.mocap_quat[m.body_mocapid[b]] = p, quat
            elif jnum == 1 and m.jnt_type[m.body_jntadr[b]] == mujoco.mjtJoint.mjJNT_FREE:
                j = m.body_jntadr[b]
                d.qpos[m.jnt_qposadr[j]:m.jnt_qposadr[j] + 7] = np.concatenate([p, quat])
                d.qvel[m.jnt_dofadr[j]:m.jnt_dofadr[j] + 6] = 0.0
            elif jnum == 0:
                m.body_pos[b], m.body_quat[b] = self._in_parent(int(m.body_parentid[b]), p, quat)
            elif jnum == 1 and int(m.jnt_type[m.body_jntadr[b]]) in _PLACEABLE:
                self._place_on_joint(b, int(m.body_jntadr[b]), p, r)
            else:
                raise ObjectTypeError(f"{obj.name!r} is moved by its joints: set their positions instead")
        elif obj.type == JOINT and m.body_jntnum[obj.body] == 1 and int(m.jnt_type[obj.mj_id]) in _PLACEABLE:
            self._place_joint(obj.body, p, r, p_now, r_now)
        elif obj.type in SITES:
            m.site_pos[obj.mj_id], m.site_quat[obj.mj_id] = self._in_parent(obj.body, p, quat)
            m.site_sameframe[obj.mj_id] = 0  # else MuJoCo keeps a site compiled at its body's origin there
        elif obj.type == VISION_SENSOR:
            m.cam_pos[obj.mj_id], m.cam_quat[obj.mj_id] = self._in_parent(obj.body, p, quat)
        elif obj.type == LIGHT:
            lp, lq = self._in_parent(obj.body, p, quat)
            rot = np.empty(9)
            mujoco.mju_quat2Mat(rot, lq)
            m.light_pos[obj.mj_id], m.light_dir[obj.mj_id] = lp, rot.reshape(3, 3)[:, 2]
        else:
            raise ObjectTypeError(f"{obj.name!r} is a {_TYPE_NAMES[obj.type]}: it cannot be placed; "
                                  "move the body it belongs to")
        if obj.name in self.grasps:  # a grasped part keeps its new pose relative to what holds it
            grasps.placed(self, obj)
        self.changed()

    def _place_joint(self, b: int, p: np.ndarray, r: np.ndarray, p_now: np.ndarray, r_now: np.ndarray) -> None:
        """V-REP places a joint with what hangs from it: the joint's body moves rigidly by the
        transform that takes the joint's frame (``p_now``, ``r_now``) to (``p``, ``r``), its
        joint state kept. In MuJoCo: the body's placement in its parent, composed with that
        transform seen from the parent."""
        m, d = self.model, self.data
        parent = int(m.body_parentid[b])
        rp, pp = d.xmat[parent].reshape(3, 3), d.xpos[parent]
        rt = r @ r_now.T  # the move, in the world frame: x -> rt (x - p_now) + p
        rot = _mat(m.body_quat[b])
        m.body_pos[b] = rp.T @ (rt @ (rp @ m.body_pos[b] + pp - p_now) + p - pp)
        mujoco.mju_mat2Quat(m.body_quat[b], np.ascontiguousarray(rp.T @ rt @ rp @ rot).reshape(9))

    def _place_on_joint(self, b: int, j: int, p: np.ndarray, r: np.ndarray) -> None:
        """V-REP places a shape that hangs from a joint relative to the joint's frame, the joint
        staying where it is: the body gets the pose (``p``, ``r``) at the current joint state,
        and the joint's anchor and axis are re-expressed in the body's new frame."""
        m, d = self.model, self.data
        anchor, axis = d.xanchor[j].copy(), d.xaxis[j].copy()
        q = float(d.qpos[m.jnt_qposadr[j]] - m.qpos0[m.jnt_qposadr[j]])
        undo_r, undo_p = np.eye(3), np.zeros(3)  # the joint's displacement, undone: world -> world
        if int(m.jnt_type[j]) == int(mujoco.mjtJoint.mjJNT_HINGE):
            quat = np.empty(4)
            mujoco.mju_axisAngle2Quat(quat, axis, -q)
            undo_r = _mat(quat)
            undo_p = anchor - undo_r @ anchor
        else:
            undo_p = -q * axis
        r0, p0 = undo_r @ r, undo_r @ p + undo_p  # the body's pose with the joint at rest
        parent = int(m.body_parentid[b])
        rp, pp = d.xmat[parent].reshape(3, 3), d.xpos[parent]
        m.body_pos[b] = rp.T @ (p0 - pp)
        mujoco.mju_mat2Quat(m.body_quat[b], np.ascontiguousarray(rp.T @ r0).reshape(9))
        m.jnt_pos[j] = r0.T @ (anchor - p0)  # where the joint is, seen from the body at rest (MuJoCo's
        m.jnt_axis[j] = r0.T @ axis         # anchor is the rest frame's: a slide moves the body past it)

    def _in_parent(self, body: int, p: np.ndarray, quat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """World pose (p, quat) expressed in body ``body``'s frame."""
        d = self.data
        rb = d.xmat[body].reshape(3, 3)
        qb, qinv, q = d.xquat[body], np.empty(4), np.empty(4)
        mujoco.mju_negQuat(qinv, qb)
        mujoco.mju_mulQuat(q, qinv, quat)
        return rb.T @ (p - d.xpos[body]), q


#: Joints that V-REP lets a script place, and under which a shape can be placed: hinge, slide.
_PLACEABLE = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))


def _mat(quat: np.ndarray) -> np.ndarray:
    out = np.empty(9)
    mujoco.mju_quat2Mat(out, np.asarray(quat, dtype=float))
    return out.reshape(3, 3)
