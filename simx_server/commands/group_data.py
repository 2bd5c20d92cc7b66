"""``simxGetObjectGroupData``: one call, the data of every object of a type; the tables are built by
:func:`simx_server.sim.group_data.group_data`."""

from __future__ import annotations

from typing import Any, Callable

from simx_server.base.arguments import check_args as _args
from simx_server.scene.simulation import Simulation
from simx_server.sim.group_data import group_data


def get_object_group_data(sim: Simulation, args: list) -> list:
    """``simxGetObjectGroupData`` [objectType, dataType] -> [handles, ints, floats, strings].

    objectType: sim_handle_all (-2) or sim_appobj_object_type (109) for every object, or a
    sim_object_*_type. Per object, by dataType (V-REP's table):
    0 name (1 string); 1 type (1 int); 2 parent handle (1 int); 3/4 position abs/rel-to-parent
    (3 floats, m); 5/6 Euler angles abs/rel (3 floats, rad, as simxGetObjectOrientation);
    7/8 quaternion abs/rel (4 floats x, y, z, w); 9/10 position + Euler (6 floats);
    11/12 position + quaternion (7 floats; V-REP's server wrote Euler angles there, simx writes
    the quaternion it names); 13 proximity sensor (2 ints state, object; 6 floats point, normal;
    -1, -1 and zeros for other objects); 14 force sensor (1 int state; 6 floats force, torque;
    -1 and zeros for others); 15 joint (2 floats position, force; zeros for others and for ball
    and free joints); 16 joint (2 ints type 10/11/12 revolute/prismatic/spherical and mode 5
    "force/torque" (every MuJoCo joint is dynamic); 2 floats lower limit and range: range -1
    for an unlimited hinge (V-REP's cyclic), -inf/inf for an unlimited slide, 0 and the cone
    angle for a ball; -1, -1, 0, 0 for others and free joints); 17 linear velocity (3 floats,
    m/s); 18 angular velocity (3 floats, rad/s); 19 both (6 floats); 20 alias (the name) and
    21 path ("/a/b/c"), strings, as CoppeliaSim 4.2. Others -> UnsupportedError.
    """
    object_type, data_type = _args(args, "int", "int")
    return group_data(sim, object_type, data_type)


#: Command name -> handler, merged into simx_server.commands.HANDLERS.
GROUP_DATA_HANDLERS: dict[str, Callable[[Simulation, list], Any]] = {
    "GetObjectGroupData": get_object_group_data,
}


#: Command name -> number of leading arguments that identify it (for protocol.COMMANDS).
GROUP_DATA_IDENTITY_ARITY: dict[str, int] = {
    "GetObjectGroupData": 2,
}




