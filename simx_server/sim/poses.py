"""Object poses in V-REP's terms, as a mixin of :class:`simx_server.sim.world.World`: frames
(position and rotation matrix in the world frame), poses relative to another object (Euler
angles, quaternions), children, and placing an object (``simxSetObjectPosition`` ...).
Positions in m, angles in rad, quaternions (x, y, z, w) as V-REP writes them.
"""

from __future__ import annotations

import functools

import mujoco
import numpy as np

from simx_wire import constants as C
from simx_wire.protocol import ObjectTypeError
from simx_server.sim import grasps, physics
from simx_server.sim.objects import _TYPE_NAMES, JOINT, LIGHT, SHAPE, SITES, VISION_SENSOR, WORLD, SceneObject
from simx_server.sim.rotations import (
    _frame_with_z,
    euler_from_matrix,
    quaternion_from_matrix,
)


#: The world's frame (read-only): :meth:`Poses.relative_frame`'s reference -1.
_ORIGIN, _NO_TURN = np.zeros(3), np.eye(3)
_ORIGIN.flags.writeable = _NO_TURN.flags.writeable = False
#: MuJoCo's joint types as ints (a numpy value compared with MuJoCo's enum costs 4 us, with an int 0.3).
_HINGE, _SLIDE, _BALL = int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE), int(mujoco.mjtJoint.mjJNT_BALL)


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
        p, r = self._frame(self.get(handle))
        return (p.copy() if p.base is not None else p), (r.copy() if r.base is not None else r)

    def _frame(self, obj: SceneObject) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`frame` of ``obj`` (not the world), views of MuJoCo's data where they are them:
        for reads that make new arrays of them."""
        d = self.data
        if obj.type == SHAPE:
            return d.xpos[obj.mj_id], d.xmat[obj.mj_id].reshape(3, 3)
        if obj.type == JOINT:
            j, m = obj.mj_id, self.model
            anchor = d.xanchor[j].copy()
            if m.jnt_type[j] == _SLIDE:  # MuJoCo's anchor is before the slide's travel
                a = m.jnt_qposadr[j]
                anchor += (d.qpos[a] - m.qpos0[a]) * d.xaxis[j]
            in_body = self.joint_frame_in_body(obj)
            if in_body is not None:
                return anchor, d.xmat[obj.body].reshape(3, 3) @ in_body
            return anchor, _frame_with_z(d.xaxis[j], d.xmat[obj.body].reshape(3, 3))
        if obj.type in SITES:
            return d.site_xpos[obj.mj_id], d.site_xmat[obj.mj_id].reshape(3, 3)
        if obj.type == VISION_SENSOR:
            # MuJoCo cameras look along -z with y up; V-REP sensors look along +z with y up.
            r = d.cam_xmat[obj.mj_id].reshape(3, 3) @ np.diag([-1.0, 1.0, -1.0])
            return d.cam_xpos[obj.mj_id], r
        return d.light_xpos[obj.mj_id], _frame_with_z(d.light_xdir[obj.mj_id], np.eye(3))

    def joint_frame_in_body(self, obj: SceneObject) -> np.ndarray | None:
        """The rotation (3, 3) of joint ``obj``'s (moved) frame in its MuJoCo body, where simx
        knows it: a .ttt joint merged into its child shape's body keeps its frame there as
        ``frame=w,x,y,z`` (MuJoCo keeps only the axis; the x and y of V-REP's frame place what
        is relative to it, e.g. omni-wheels' rollers), changed when the body is placed anew
        (:attr:`World.joint_frames`). None: a frame with z along the axis, turned from the
        body's by the least rotation.

        Args:
            obj: a joint.

        Returns:
            A rotation (3, 3), or None.

        Raises:
            ValueError: a ``frame`` setting that is not four numbers.
        """
        kept = self.joint_frames.get(obj.name)
        if kept is not None:
            return kept
        text = obj.settings.get("frame")
        return None if text is None else _frame_setting(text, obj.name)

    def base_frame(self, handle: int) -> tuple[np.ndarray, np.ndarray]:
        """The frame of an object itself, as V-REP gives it (coppeliaSimLib
        ``CSceneObject::getCumulativeTransformation``): a joint's frame without its own motion
        (its base frame: a hinge not turned by its angle, a slide not moved by its travel, a
        ball not turned by its rotation); any other object's :meth:`frame`. :meth:`frame` is
        the frame things hang from (``getFullCumulativeTransformation``), the joint's moved one.

        Args:
            handle: an object's handle, or -1.

        Returns:
            ``(position, rotation)``: arrays (3,) m and (3, 3).

        Raises:
            UnknownObjectError: no such object.
        """
        if handle == WORLD:
            return self.frame(handle)
        p, r = self._base_frame(self.get(handle))
        return (p.copy() if p.base is not None else p), (r.copy() if r.base is not None else r)

    def _base_frame(self, obj: SceneObject) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`base_frame` of ``obj`` (not the world), views where :meth:`_frame` gives them."""
        p, r = self._frame(obj)
        if obj.type != JOINT:
            return p, r
        m, d = self.model, self.data
        a, kind = int(m.jnt_qposadr[obj.mj_id]), int(m.jnt_type[obj.mj_id])
        # a .ttt joint's ``ref`` is the position it was saved at, where its body was placed: the
        # moved frame is the base turned (moved) by qpos itself, as V-REP's by its position
        if kind == _HINGE:
            q = d.qpos[a]
            c, s = np.cos(q), np.sin(q)
            r = r @ np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])  # r @ Rz(-q)
        elif kind == _SLIDE:
            p = p - float(d.qpos[a]) * r[:, 2]
        elif kind == _BALL:
            b = d.xmat[obj.body].reshape(3, 3)  # the body turned by the ball's rotation q
            turn = _mat(d.qpos[a:a + 4])
            r = b @ turn.T @ (b.T @ r)  # the frame's fixed place in its body, on the body unturned
        return p, r

    def relative_frame(self, handle: int, relative_to: int,
                       reference_base: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """Pose of ``handle`` (its :meth:`base_frame`, V-REP's frame of the object) in the
        frame of ``relative_to`` (-1 world, -11 parent): a joint's moved frame, what its
        children hang from (coppeliaSimLib ``simGetObjectPosition_internal`` & co.), or with
        ``reference_base`` its base frame (``sim.handleflag_reljointbaseframe``).

        Args:
            handle: an object's handle.
            relative_to: another object's handle, -1 or -11 (``sim_handle_parent``).
            reference_base: a joint as ``relative_to`` counts by its base frame.

        Returns:
            ``(position, rotation)``: arrays (3,) m and (3, 3).

        Raises:
            UnknownObjectError: no such object.
        """
        return self._relative(handle, relative_to, reference_base, True, True)  # type: ignore[return-value]

    def _relative(self, handle: int, relative_to: int, reference_base: bool, position: bool,
                  rotation: bool) -> tuple[np.ndarray | None, np.ndarray | None]:
        """:meth:`relative_frame`'s position and rotation, each only if asked (None else)."""
        if handle == WORLD and relative_to != C.sim_handle_parent:
            p, r = _ORIGIN, _NO_TURN
        else:
            obj = self.get(handle)
            if relative_to == C.sim_handle_parent:
                relative_to = obj.parent
            p, r = self._base_frame(obj)
        if relative_to == WORLD:
            p0, r0 = _ORIGIN, _NO_TURN
        else:
            other = self.get(relative_to)
            p0, r0 = self._base_frame(other) if reference_base else self._frame(other)
        return (r0.T @ (p - p0) if position else None), (r0.T @ r if rotation else None)

    def position(self, handle: int, relative_to: int, reference_base: bool = False) -> list[float]:
        """Position (m) of an object relative to another. ``simxGetObjectPosition``.

        Args:
            handle: an object's handle.
            relative_to: another object's handle, -1 (world) or -11 (parent).
            reference_base: a joint as ``relative_to`` counts by its base frame.

        Returns:
            ``[x, y, z]`` in m.

        Raises:
            UnknownObjectError: no such object.
        """
        return self._relative(handle, relative_to, reference_base, True, False)[0].tolist()  # type: ignore[union-attr]

    def orientation(self, handle: int, relative_to: int, reference_base: bool = False) -> list[float]:
        """Euler angles alpha, beta, gamma (rad) with R = Rx(a) Ry(b) Rz(g). ``simxGetObjectOrientation``.

        Args:
            handle: an object's handle.
            relative_to: another object's handle, -1 (world) or -11 (parent).
            reference_base: a joint as ``relative_to`` counts by its base frame.

        Returns:
            ``[alpha, beta, gamma]`` in rad.

        Raises:
            UnknownObjectError: no such object.
        """
        return euler_from_matrix(self._relative(handle, relative_to, reference_base, False, True)[1])

    def pose(self, handle: int, relative_to: int, reference_base: bool = False) -> tuple[list[float], list[float]]:
        """:meth:`position` and :meth:`quaternion` of an object, its frame read once.

        Args:
            handle: an object's handle.
            relative_to: another object's handle, -1 (world) or -11 (parent).
            reference_base: a joint as ``relative_to`` counts by its base frame.

        Returns:
            ``([x, y, z] m, [x, y, z, w])``.

        Raises:
            UnknownObjectError: no such object.
        """
        p, r = self._relative(handle, relative_to, reference_base, True, True)
        return p.tolist(), quaternion_from_matrix(r)  # type: ignore[union-attr]

    def quaternion(self, handle: int, relative_to: int, reference_base: bool = False) -> list[float]:
        """Orientation as a quaternion in V-REP's order (x, y, z, w). ``simxGetObjectQuaternion``.

        Args:
            handle: an object's handle.
            relative_to: another object's handle, -1 (world) or -11 (parent).
            reference_base: a joint as ``relative_to`` counts by its base frame.

        Returns:
            ``[x, y, z, w]``, unit length.

        Raises:
            UnknownObjectError: no such object.
        """
        return quaternion_from_matrix(self._relative(handle, relative_to, reference_base, False, True)[1])

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
                 rotation: np.ndarray | None = None, reference_base: bool = False) -> None:
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
            reference_base: a joint as ``relative_to`` counts by its base frame
                (``sim.handleflag_reljointbaseframe``); else by its moved frame.

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
        p0, r0 = self.base_frame(relative_to) if reference_base else self.frame(relative_to)
        p_now, r_now = self.base_frame(handle)  # a joint is placed by its base frame, as in V-REP
        p = p_now if position is None else p0 + r0 @ np.asarray(position, dtype=float)
        r = r_now if rotation is None else r0 @ rotation
        m, d = self.model, self.data
        move = (p.copy(), r.copy(), p_now, r_now)  # world -> world: x -> r r_now^T (x - p_now) + p
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
        self._carry_subtree(obj, *move)
        if obj.name in self.grasps:  # a grasped part keeps its new pose relative to what holds it
            grasps.placed(self, obj)
        self.changed()

    def set_poses(self, handles: list[int], poses: np.ndarray, relative_to: int) -> None:
        """Place several objects, each as :meth:`set_pose` does, with one forward pass: a shape
        that is a body of its own without joints, carries nothing and is not grasped (a
        conveyor's pad) gets its new placement directly, any other object goes through
        :meth:`set_pose`. Call it inside :meth:`one_change` for one forward pass in all.

        Args:
            handles: the objects' handles.
            poses: (n, 7) positions (m) and quaternions (x, y, z, w), in ``relative_to``'s frame.
            relative_to: a handle, or -1.

        Raises:
            UnknownObjectError: no such object.
            ObjectTypeError, ArgumentError: as :meth:`set_pose`.
        """
        poses = np.asarray(poses, dtype=float).reshape(len(handles), 7)
        m = self.model
        p0, r0 = self.frame(relative_to)
        parents = {o.parent for o in self.objects.values()}
        for h, pose in zip(handles, poses):
            physics.check_position(list(pose[:3]))
            obj = self.get(h)
            rot = np.empty(9)
            mujoco.mju_quat2Mat(rot, np.array([pose[6], pose[3], pose[4], pose[5]]))
            b = obj.mj_id
            if obj.type != SHAPE or m.body_jntnum[b] or m.body_mocapid[b] >= 0 or h in parents or obj.name in self.grasps:
                self.set_pose(h, relative_to, list(pose[:3]), rot.reshape(3, 3))
                continue
            r = r0 @ rot.reshape(3, 3)
            quat = np.empty(4)
            mujoco.mju_mat2Quat(quat, np.ascontiguousarray(r).reshape(9))
            m.body_pos[b], m.body_quat[b] = self._in_parent(int(m.body_parentid[b]), p0 + r0 @ pose[:3], quat)
        self.changed()

    def _carry_subtree(self, obj: SceneObject, p: np.ndarray, r: np.ndarray, p_now: np.ndarray,
                       r_now: np.ndarray) -> None:
        """Move what hangs below ``obj`` in V-REP's tree and MuJoCo's tree does not carry, by the
        move ``obj`` made (its frame from ``p_now``, ``r_now`` to ``p``, ``r``): CoppeliaSim
        moves a whole subtree with its top. The children of a dummy or sensor (a site, so its
        V-REP children are elements of the body beside it), dynamic shapes under any object
        (free bodies of the world), bodies hung from a site. Poses are read from the data as it
        was before the move (MuJoCo's forward pass comes after)."""
        kids: dict[int, list[SceneObject]] = {}
        for o in self.objects.values():
            kids.setdefault(o.parent, []).append(o)
        if not kids.get(obj.handle):
            return
        m, d = self.model, self.data
        moved = np.zeros(m.nbody, dtype=bool)
        if obj.type == SHAPE:
            moved[obj.mj_id] = True
        elif obj.type == JOINT:
            moved[obj.body] = True
        _spread(m, moved)
        rt = r @ r_now.T
        todo = list(kids[obj.handle])
        while todo:
            o = todo.pop(0)
            todo.extend(kids.get(o.handle, ()))
            b = o.mj_id if o.type == SHAPE else o.body
            if moved[b]:
                continue
            if o.type in (SHAPE, JOINT):
                jnum = m.body_jntnum[b]
                if jnum == 1 and m.jnt_type[m.body_jntadr[b]] == mujoco.mjtJoint.mjJNT_FREE:
                    a = m.jnt_qposadr[m.body_jntadr[b]]
                    d.qpos[a:a + 3] = rt @ (d.qpos[a:a + 3] - p_now) + p
                    q = np.empty(4)
                    mujoco.mju_mat2Quat(q, np.ascontiguousarray(rt @ _mat(d.qpos[a + 3:a + 7])).reshape(9))
                    d.qpos[a + 3:a + 7] = q
                    d.qvel[m.jnt_dofadr[m.body_jntadr[b]]:m.jnt_dofadr[m.body_jntadr[b]] + 6] = 0.0
                elif m.body_mocapid[b] < 0:
                    self._place_joint(b, p, r, p_now, r_now)  # the body and what it carries, rigidly
                moved[b] = True
                _spread(m, moved)
                continue
            q = np.empty(4)
            if o.type in SITES:
                mujoco.mju_mat2Quat(q, np.ascontiguousarray(rt @ d.site_xmat[o.mj_id].reshape(3, 3)).reshape(9))
                m.site_pos[o.mj_id], m.site_quat[o.mj_id] = self._in_parent(b, rt @ (d.site_xpos[o.mj_id] - p_now) + p, q)
                m.site_sameframe[o.mj_id] = 0
            elif o.type == VISION_SENSOR:
                mujoco.mju_mat2Quat(q, np.ascontiguousarray(rt @ d.cam_xmat[o.mj_id].reshape(3, 3)).reshape(9))
                m.cam_pos[o.mj_id], m.cam_quat[o.mj_id] = self._in_parent(b, rt @ (d.cam_xpos[o.mj_id] - p_now) + p, q)
            elif o.type == LIGHT:
                rb = d.xmat[b].reshape(3, 3)
                m.light_pos[o.mj_id] = rb.T @ (rt @ (d.light_xpos[o.mj_id] - p_now) + p - d.xpos[b])
                m.light_dir[o.mj_id] = rb.T @ (rt @ d.light_xdir[o.mj_id])

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
        joint = next((o for o in self.objects.values() if o.type == JOINT and o.mj_id == j), None)
        frame = self.frame(joint.handle)[1] if joint is not None else None  # the joint's, in the world: kept
        anchor, axis = d.xanchor[j].copy(), d.xaxis[j].copy()
        axis /= np.linalg.norm(axis)  # a unit axis: placed every step (omni-wheels), no error may grow
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
        if frame is not None:
            self.joint_frames[joint.name] = r.T @ frame  # in the body, which now has r at this joint state

    def _in_parent(self, body: int, p: np.ndarray, quat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """World pose (p, quat) expressed in body ``body``'s frame."""
        d = self.data
        rb = d.xmat[body].reshape(3, 3)
        qb, qinv, q = d.xquat[body], np.empty(4), np.empty(4)
        mujoco.mju_negQuat(qinv, qb)
        mujoco.mju_mulQuat(q, qinv, quat)
        return rb.T @ (p - d.xpos[body]), q


def _spread(m: mujoco.MjModel, moved: np.ndarray) -> None:
    """Mark (in place) every body below a marked one: MuJoCo's bodies come parents first."""
    parent = m.body_parentid
    for i in range(1, m.nbody):
        if not moved[i] and moved[parent[i]]:
            moved[i] = True


#: Joints that V-REP lets a script place, and under which a shape can be placed: hinge, slide.
_PLACEABLE = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))


@functools.lru_cache(maxsize=4096)
def _frame_setting(text: str, name: str) -> np.ndarray:
    """A joint's ``frame=w,x,y,z`` setting as a rotation matrix (read-only)."""
    try:
        q = np.array([float(v) for v in text.split(",")])
        if q.shape != (4,) or not np.all(np.isfinite(q)) or not np.linalg.norm(q) > 0:
            raise ValueError
    except ValueError:
        raise ValueError(f"frame of joint {name!r} must be a quaternion w,x,y,z, got {text[:60]!r}") from None
    rot = _mat(q / np.linalg.norm(q))
    rot.setflags(write=False)
    return rot


def _mat(quat: np.ndarray) -> np.ndarray:
    out = np.empty(9)
    mujoco.mju_quat2Mat(out, np.asarray(quat, dtype=float))
    return out.reshape(3, 3)
