"""Every legacy remote API constant with its V-REP / CoppeliaSim value.

The values are those of the original files, read by ``scripts/gen_constants.py`` into the
generated table :mod:`simx_wire.legacy_constants` (nothing here is typed by hand):

* :data:`VREP_CONSTANTS`: what ``vrep`` / ``vrepConst`` export: every constant of V-REP 3.6's
  ``vrepConst.py`` (626 names: 623 ``sim_*`` / ``simx_*`` and 3 ``SIMX_*``) and
  :data:`ADDED_BY_SIMX`;
* :data:`SIM_CONSTANTS`: what ``sim`` / ``simConst`` export: every constant of CoppeliaSim's
  legacy ``simConst.py`` and :data:`ADDED_BY_SIMX`;
* :data:`ADDED_BY_SIMX`: names the Python files lack that simx's client adds, from V-REP 3.6.2's
  C header ``v_repConst.h``: the render modes of ``sim_visionintparam_render_mode``
  (``sim_rendermode_*``) and ``simx_cmdmask`` (the operation mode's low 16 bits);
* :data:`SCRIPT_ONLY`: constants of V-REP's Lua API that the Python files lack and child
  scripts use (``sim_colorcomponent_*`` of ``sim.setShapeColor``, ``sim_handleflag_greyscale``),
  from the same header. Child scripts get them with every ``sim_*`` constant above, as
  ``sim.X`` (CoppeliaSim 4.x) and, in Lua, ``sim_X`` (V-REP 3.x).

Where the two Python files differ (a name in one only, or another value), each legacy module
follows its own file; this module's attributes are the union, with vrepConst.py's values (it is
``import simx_client as vrep``). The two files of V-REP 3.6.2 and CoppeliaSim 4.x name the same
626 constants with the same values.
"""

from __future__ import annotations

from simx_wire.legacy_constants import SIMCONST, V_REPCONST_H, VREPCONST

#: Constants simx's client adds to those of the Python files (from v_repConst.h).
ADDED_BY_SIMX: dict[str, int] = {
    name: value for name, value in V_REPCONST_H.items() if name.startswith("sim_rendermode_") or name == "simx_cmdmask"
}
#: Constants of the Lua API that only child scripts get (from v_repConst.h).
SCRIPT_ONLY: dict[str, int] = {
    name: value for name, value in V_REPCONST_H.items() if name.startswith(("sim_colorcomponent_", "sim_handleflag_"))
}
#: Every constant of ``vrep`` / ``vrepConst``: name -> value.
VREP_CONSTANTS: dict[str, int] = {**VREPCONST, **ADDED_BY_SIMX}
#: Every constant of ``sim`` / ``simConst``: name -> value.
SIM_CONSTANTS: dict[str, int] = {**SIMCONST, **ADDED_BY_SIMX}

#: Name prefixes of the global parameter ids of simxGet/Set*Parameter, by kind.
GLOBAL_PARAM_PREFIXES: dict[str, str] = {
    "integer": "sim_intparam_",
    "float": "sim_floatparam_",
    "boolean": "sim_boolparam_",
    "string": "sim_stringparam_",
    "array": "sim_arrayparam_",
}
#: Name prefixes of the object parameter ids of simxGet/SetObject*Parameter (one id range each).
OBJECT_PARAM_PREFIXES: tuple[str, ...] = (
    "sim_objintparam_",
    "sim_objfloatparam_",
    "sim_visionintparam_",
    "sim_visionfloatparam_",
    "sim_jointintparam_",
    "sim_jointfloatparam_",
    "sim_shapeintparam_",
    "sim_shapefloatparam_",
    "sim_shapestringparam_",
    "sim_proxintparam_",
    "sim_forcefloatparam_",
    "sim_lightintparam_",
    "sim_cameraintparam_",
    "sim_camerafloatparam_",
    "sim_dummyintparam_",
    "sim_mirrorintparam_",
    "sim_mirrorfloatparam_",
    "sim_pplanfloatparam_",
    "sim_mplanintparam_",
)


def names_of(value: int, prefixes: str | tuple[str, ...]) -> list[str]:
    """The legacy names whose value is ``value`` among the constants whose names start with
    ``prefixes`` (vrepConst.py's order, then simConst.py's other names); ``[]`` when none.

    ``names_of(16, "sim_boolparam_")`` is ``["sim_boolparam_display_enabled"]``."""
    names = [n for n, v in VREP_CONSTANTS.items() if v == value and n.startswith(prefixes)]
    return names + [
        n for n, v in SIM_CONSTANTS.items() if v == value and n.startswith(prefixes) and n not in VREP_CONSTANTS
    ]


def describe(value: int, prefixes: str | tuple[str, ...]) -> str:
    """``"NAME (value)"`` (names joined by ``/`` when several), or ``str(value)`` without one:
    how error messages name a parameter id."""
    names = names_of(value, prefixes)
    return f"{'/'.join(names)} ({value})" if names else str(value)


globals().update(SIM_CONSTANTS)
globals().update(VREP_CONSTANTS)  # vrepConst.py's value where the files would differ

#: The constants' names (the union of both files and ADDED_BY_SIMX), sorted.
__all__ = sorted(VREP_CONSTANTS.keys() | SIM_CONSTANTS.keys())
