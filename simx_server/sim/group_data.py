"""simxGetObjectGroupData: names, types, parents, poses, sensor readings, joint states and
properties and velocities of every object of a type, in V-REP's tables.

The handler is in :mod:`simx_server.commands.group_data`; :func:`group_data` serves it and
in-process callers (``--list-objects``) with plain values.
"""

from __future__ import annotations

import math

from simx_wire import constants as C
from simx_wire.protocol import UnsupportedError
from simx_server.sim.kinematics import _BALL, _HINGE, _SLIDE, object_velocity
from simx_server.sim.proximity import proximity_reading
from simx_server.sim.sensors import force_sensor_reading
from simx_server.sim.state import SimulationView
from simx_server.sim.world import (
    FORCE_SENSOR,
    JOINT,
    PROXIMITY_SENSOR,
    World,
    euler_from_matrix,
    quaternion_from_matrix,
)

# V-REP values used in replies (vrepConst.py).
SIM_JOINT_REVOLUTE, SIM_JOINT_PRISMATIC, SIM_JOINT_SPHERICAL = 10, 11, 12
SIM_JOINTMODE_FORCE = 5


# --------------------------------------------------------------------- group data
def _joint_properties(world: World, handle: int) -> tuple[list[int], list[float]]:
    m = world.model
    j = world.objects[handle].mj_id
    jtype, limited = int(m.jnt_type[j]), bool(m.jnt_limited[j])
    lo, hi = (float(x) for x in m.jnt_range[j])
    if jtype == _HINGE:
        return [SIM_JOINT_REVOLUTE, SIM_JOINTMODE_FORCE], [lo, hi - lo] if limited else [-math.pi, -1.0]
    if jtype == _SLIDE:
        return [SIM_JOINT_PRISMATIC, SIM_JOINTMODE_FORCE], [lo, hi - lo] if limited else [-math.inf, math.inf]
    if jtype == _BALL:
        return [SIM_JOINT_SPHERICAL, SIM_JOINTMODE_FORCE], [0.0, hi if limited else math.pi]
    return [-1, -1], [0.0, 0.0]  # a free joint has no V-REP counterpart


def _joint_state(world: World, handle: int) -> list[float]:
    jtype = int(world.model.jnt_type[world.objects[handle].mj_id])
    if jtype not in (_HINGE, _SLIDE):
        return [0.0, 0.0]  # as V-REP's simGetJointPosition fails for spherical joints
    return [world.joint_position(handle), world.joint_force(handle)]


def _path(world: World, handle: int) -> str:
    parts, h = [], handle
    while h != -1:
        parts.append(world.objects[h].name)
        h = world.objects[h].parent
    return "/" + "/".join(reversed(parts))


#: dataType -> (ints per object, floats per object, strings per object), V-REP's table.
GROUP_DATA_TYPES = {
    0: "names", 1: "types", 2: "parents", 3: "absolute positions", 4: "positions relative to parent",
    5: "absolute Euler angles", 6: "Euler angles relative to parent", 7: "absolute quaternions",
    8: "quaternions relative to parent", 9: "absolute position + Euler angles",
    10: "position + Euler angles relative to parent", 11: "absolute position + quaternion",
    12: "position + quaternion relative to parent", 13: "proximity sensor data",
    14: "force sensor data", 15: "joint state (position, force)", 16: "joint properties",
    17: "linear velocities", 18: "angular velocities", 19: "linear + angular velocities",
    20: "aliases", 21: "paths",
}


def group_data(sim: SimulationView, object_type: int, data_type: int) -> list:
    """[handles, ints, floats, strings] for ``simxGetObjectGroupData``; see get_object_group_data.

    Args:
        sim: the simulation.
        object_type: ``sim_handle_all`` (-2), ``sim_appobj_object_type`` (109) or a
            ``sim_object_*_type`` (0-14).
        data_type: V-REP's data type, 0-19, or CoppeliaSim 4.2's 20 (alias) and 21 (path).

    Returns:
        ``[handles, ints, floats, strings]``: the objects' handles and their data, flat, in
        V-REP's order per object (positions in m, angles in rad, velocities in m/s and rad/s).

    Raises:
        UnsupportedError: an object type or data type simx does not have.
    """
    world = sim.world
    if object_type in (C.sim_handle_all, C.sim_appobj_object_type):
        object_type = C.sim_handle_all
    elif not 0 <= object_type <= C.sim_object_mirror_type:
        raise UnsupportedError(f"objectType {object_type}: simx supports sim_handle_all (-2), "
                               "sim_appobj_object_type (109) and the sim_object_*_type values (0-14); "
                               "it has no collections")
    if data_type not in GROUP_DATA_TYPES:
        raise UnsupportedError(f"dataType {data_type} of simxGetObjectGroupData is not one of V-REP's "
                               "(0-19; 20 alias and 21 path of CoppeliaSim 4.2)")
    handles = world.objects_of_type(object_type)
    ints: list[int] = []
    floats: list[float] = []
    strings: list[str] = []
    for h in handles:
        obj = world.objects[h]
        if data_type in (0, 20):
            strings.append(obj.name)
        elif data_type == 21:
            strings.append(_path(world, h))
        elif data_type == 1:
            ints.append(obj.type)
        elif data_type == 2:
            ints.append(obj.parent)
        elif 3 <= data_type <= 12:
            pos, rot = world.relative_frame(h, -1 if data_type % 2 else C.sim_handle_parent)
            if data_type in (3, 4, 9, 10, 11, 12):
                floats += pos.tolist()
            if data_type in (5, 6, 9, 10):
                floats += euler_from_matrix(rot)
            if data_type in (7, 8, 11, 12):
                floats += quaternion_from_matrix(rot)
        elif data_type == 13:
            if obj.type == PROXIMITY_SENSOR:
                detected, point, hit, normal = proximity_reading(sim, h)
                ints += [int(detected), hit]
                floats += point + normal
            else:
                ints += [-1, -1]
                floats += [0.0] * 6
        elif data_type == 14:
            if obj.type == FORCE_SENSOR:
                state, force, torque = force_sensor_reading(sim, h)
                ints.append(state)
                floats += force + torque
            else:
                ints.append(-1)
                floats += [0.0] * 6
        elif data_type == 15:
            floats += _joint_state(world, h) if obj.type == JOINT else [0.0, 0.0]
        elif data_type == 16:
            i, f = _joint_properties(world, h) if obj.type == JOINT else ([-1, -1], [0.0, 0.0])
            ints += i
            floats += f
        else:  # 17, 18, 19
            v, w = object_velocity(sim, h)
            floats += (v.tolist() if data_type != 18 else []) + (w.tolist() if data_type != 17 else [])
    return [handles, ints, [float(x) for x in floats], strings]


