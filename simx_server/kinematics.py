"""Joint matrices and object velocities, as V-REP's legacy remote API has them.

Handlers ``(sim, args) -> value`` are listed in :data:`KINEMATICS_HANDLERS`; ``joint_matrix`` and
``object_velocity`` take plain values and serve the other modules (group data, object
parameters) and in-process callers. Values are those of the world's last ``mj_forward``.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, Callable

import mujoco
import numpy as np

from simx_client.protocol import ArgumentError, ObjectTypeError
from simx_server.arguments import as_floats, check_args as _args
from simx_server.world import JOINT, World

if TYPE_CHECKING:
    from simx_server.simulation import Simulation

_HINGE, _SLIDE = int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)
_BALL, _FREE = int(mujoco.mjtJoint.mjJNT_BALL), int(mujoco.mjtJoint.mjJNT_FREE)


# ------------------------------------------------------------------------ joints
def joint_matrix(world: World, handle: int) -> np.ndarray:
    """Intrinsic transform (3, 4) of a joint: [R | t], in the joint's own frame.

    Hinge: rotation about z by ``q - ref``; slide: translation ``q - ref`` along z; ball: the
    rotation of its quaternion; free: its position and quaternion (world frame).
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


def get_joint_matrix(sim: Simulation, args: list) -> list[float]:
    """``simxGetJointMatrix`` [h] -> 12 floats: the joint's intrinsic 3x4 transform, row-major
    (R00 R01 R02 tx R10 ... tz), m. See :func:`joint_matrix`."""
    (h,) = _args(args, "int")
    return joint_matrix(sim.world, h).reshape(12).tolist()


def set_spherical_joint_matrix(sim: Simulation, args: list) -> None:
    """``simxSetSphericalJointMatrix`` [h, [12 floats]] -> None.

    Sets a ball joint's rotation from the rotation part of a 3x4 row-major matrix (the
    translation column is ignored, as in V-REP) and zeroes its angular velocity. The 12 floats
    may also come flat ([h, m0, ..., m11]). Raises ObjectTypeError for other joints and
    ArgumentError for a matrix whose 3x3 part is not a rotation (tolerance 1e-3).
    """
    if len(args) == 13:
        args = [args[0], list(args[1:])]
    h, values = _args(args, "int", "any")
    world = sim.world
    obj = world.get(h, JOINT)
    m, d = world.model, world.data
    if int(m.jnt_type[obj.mj_id]) != _BALL:
        raise ObjectTypeError(f"joint {obj.name!r} is not a spherical (ball) joint: "
                              "use simxSetJointPosition for revolute and prismatic joints")
    rot = np.array(as_floats(values, 12, "matrix")).reshape(3, 4)[:, :3]
    if not np.allclose(rot.T @ rot, np.eye(3), atol=1e-3) or np.linalg.det(rot) < 0:
        raise ArgumentError("matrix: its 3x3 rotation part (elements 0-2, 4-6, 8-10) is not a "
                            "rotation matrix (orthonormal, determinant +1)")
    u, _, vt = np.linalg.svd(rot)  # nearest exact rotation
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, (u @ vt).reshape(9))
    a, v = int(m.jnt_qposadr[obj.mj_id]), int(m.jnt_dofadr[obj.mj_id])
    d.qpos[a:a + 4] = quat / np.linalg.norm(quat)
    d.qvel[v:v + 3] = 0.0
    sim.world.changed()
# --------------------------------------------------------------------- velocities
def object_velocity(sim: Simulation, handle: int) -> tuple[np.ndarray, np.ndarray]:
    """Linear (m/s) and angular (rad/s) velocity of an object's frame, world axes.

    ``mj_objectVelocity`` of the object's body frame (mjOBJ_XBODY, flg_local=0), moved to the
    object's own origin (site, camera, joint anchor, light) with v + w x r.
    """
    world = sim.world
    obj = world.get(handle)
    res = np.zeros(6)
    # mjOBJ_XBODY: the body's frame origin (xpos); mjOBJ_BODY would be its centre of mass
    mujoco.mj_objectVelocity(world.model, world.data, mujoco.mjtObj.mjOBJ_XBODY, obj.body, res, 0)
    w, v = res[:3], res[3:]
    pos, _ = world.frame(handle)
    return v + np.cross(w, pos - world.data.xpos[obj.body]), w.copy()


def get_object_velocity(sim: Simulation, args: list) -> list[list[float]]:
    """``simxGetObjectVelocity`` [h] -> [[vx, vy, vz], [wx, wy, wz]] in the world frame (m/s,
    rad/s), of the object's origin; see :func:`object_velocity`."""
    (h,) = _args(args, "int")
    v, w = object_velocity(sim, h)
    return [v.tolist(), w.tolist()]


#: Command name -> handler, merged into simx_server.commands.HANDLERS.
KINEMATICS_HANDLERS: dict[str, Callable[[Simulation, list], Any]] = {
    "GetJointMatrix": get_joint_matrix,
    "SetSphericalJointMatrix": set_spherical_joint_matrix,
    "GetObjectVelocity": get_object_velocity,
}

#: Command name -> number of leading arguments that identify it (for protocol.COMMANDS).
KINEMATICS_IDENTITY_ARITY: dict[str, int] = {
    "GetJointMatrix": 1,
    "SetSphericalJointMatrix": 1,
    "GetObjectVelocity": 1,
}
