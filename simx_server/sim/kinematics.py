"""Joint matrices and object velocities, as V-REP's legacy remote API has them.

The command handlers are in :mod:`simx_server.commands.joints`; ``joint_matrix`` and
``object_velocity`` take plain values and serve them, the other modules (group data, object
parameters) and in-process callers. Values are those of the world's last ``mj_forward``.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from simx_server.sim.state import SimulationView
from simx_server.sim.world import JOINT, World

_HINGE, _SLIDE = int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)
_BALL, _FREE = int(mujoco.mjtJoint.mjJNT_BALL), int(mujoco.mjtJoint.mjJNT_FREE)


# ------------------------------------------------------------------------ joints
def joint_matrix(world: World, handle: int) -> np.ndarray:
    """Intrinsic transform (3, 4) of a joint: [R | t], in the joint's own frame.

    Hinge: rotation about z by ``q - ref``; slide: translation ``q - ref`` along z; ball: the
    rotation of its quaternion; free: its position and quaternion (world frame).

    Implements ``simGetJointMatrix``.

    Args:
        world: the world.
        handle: a joint's handle.

    Returns:
        Array (3, 4): rotation (3, 3) and translation in m.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a joint.
    """
    obj = world.get(handle, JOINT)
    m, d = world.model, world.data
    j = obj.mj_id
    jtype, a = int(m.jnt_type[j]), int(m.jnt_qposadr[j])
    out = np.zeros((3, 4))
    out[:, :3] = np.eye(3)
    if jtype == _HINGE:
        q = float(d.qpos[a] - m.qpos0[a])
        c, s = math.cos(q), math.sin(q)
        out[:2, :2] = [[c, -s], [s, c]]
    elif jtype == _SLIDE:
        out[2, 3] = float(d.qpos[a] - m.qpos0[a])
    else:
        qa = a if jtype == _BALL else a + 3
        quat = np.array(d.qpos[qa:qa + 4], dtype=float)
        quat /= np.linalg.norm(quat)
        rot = np.empty(9)
        mujoco.mju_quat2Mat(rot, quat)
        out[:, :3] = rot.reshape(3, 3)
        if jtype == _FREE:
            out[:, 3] = d.qpos[a:a + 3]
    return out


# --------------------------------------------------------------------- velocities
def object_velocity(sim: SimulationView, handle: int) -> tuple[np.ndarray, np.ndarray]:
    """Linear (m/s) and angular (rad/s) velocity of an object's frame, world axes.

    ``mj_objectVelocity`` of the object's body frame (mjOBJ_XBODY, flg_local=0), moved to the
    object's own origin (site, camera, joint anchor, light) with v + w x r.

    Implements ``simxGetObjectVelocity``.

    Args:
        sim: the simulation.
        handle: any object's handle.

    Returns:
        ``(v, w)``: two arrays (3,), m/s and rad/s.

    Raises:
        UnknownObjectError: no such object.
    """
    world = sim.world
    obj = world.get(handle)
    res = np.zeros(6)
    # mjOBJ_XBODY: the body's frame origin (xpos); mjOBJ_BODY would be its centre of mass
    mujoco.mj_objectVelocity(world.model, world.data, mujoco.mjtObj.mjOBJ_XBODY, obj.body, res, 0)
    w, v = res[:3], res[3:]
    pos, _ = world.frame(handle)
    return v + np.cross(w, pos - world.data.xpos[obj.body]), w.copy()


