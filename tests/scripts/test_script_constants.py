"""Child scripts see every legacy constant: ``sim.X`` (CoppeliaSim 4.x, Lua and Python) and
``sim_X`` (V-REP 3.x Lua globals), from the generated table; ``sim.setShapeColor`` with
``sim.colorcomponent_ambient_diffuse`` colours a shape's MuJoCo geoms (issue 19)."""

from __future__ import annotations

import pytest

from simx_client import constants as C
from simx_server.api import SIM
from simx_server.scene.simulation import Simulation

FACADE_CONSTANTS = SIM.constants

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here

CHILD = C.sim_scripttype_childscript

SCENE = """<mujoco model="script constants">
  <option timestep="0.002" gravity="0 0 0"/>
  <worldbody>
    <body name="Cube" pos="0 0 0.1">
      <geom name="Cube_top" type="box" size="0.02 0.02 0.01" pos="0 0 0.01" rgba="1 1 1 1"/>
      <geom name="Cube_bottom" type="box" size="0.02 0.02 0.01" pos="0 0 -0.01" rgba="1 1 1 1"/>
    </body>
    <body name="Joint_base" pos="0.3 0 0.1">
      <geom type="box" size="0.02 0.02 0.02"/>
      <body name="Slider" pos="0 0 0.05">
        <joint name="Slider_joint" type="slide" axis="1 0 0" range="-0.5 0.5"/>
        <geom type="box" size="0.01 0.01 0.01" mass="0.1"/>
      </body>
    </body>
    <body name="LuaHolder" pos="1 0 0"><geom type="box" size="0.01 0.01 0.01" contype="0" conaffinity="0"/></body>
    <body name="PyHolder" pos="1 1 0"><geom type="box" size="0.01 0.01 0.01" contype="0" conaffinity="0"/></body>
  </worldbody>
  <custom>
    <text name="simx:LuaHolder" data="child_script=colours.lua"/>
    <text name="simx:PyHolder" data="child_script=colours.py"/>
  </custom>
</mujoco>
"""

LUA = """
function values()
  -- CoppeliaSim 4.x fields and V-REP 3.x globals of the same constants
  return {sim.colorcomponent_ambient_diffuse, sim_colorcomponent_transparency, sim.jointintparam_motor_enabled,
          sim_jointfloatparam_upper_limit, sim.objintparam_visibility_layer, sim_boolparam_display_enabled,
          sim.stringparam_application_path, sim_api_errormessage_output, sim.message_eventcallback_scenesave,
          sim_navigation_camerafly, sim.drawing_cyclic, sim.simulation_advancing_running,
          sim_handleflag_greyscale, sim.rendermode_colorcoded}
end

function paint(inInts, inFloats)
  local cube = sim.getObjectHandle('Cube')
  sim.setShapeColor(cube, nil, sim.colorcomponent_ambient_diffuse, {inFloats[1], inFloats[2], inFloats[3]})
  -- V-REP 3.x spelling: simSetShapeColor and the sim_* global, on one geom by name
  simSetShapeColor(cube, 'Cube_top', sim_colorcomponent_transparency, {0.25})
  return {}
end

function missing()
  local ok, err = pcall(function() return sim.colorcomponent_no_such_thing end)
  return {}, {}, {tostring(ok), err, tostring(sim_no_such_constant)}
end
"""

PY = """
def values(inInts, inFloats, inStrings, inBuffer):
    return [sim.colorcomponent_ambient_diffuse, sim.colorcomponent_transparency, sim.jointintparam_motor_enabled,
            sim.jointfloatparam_upper_limit, sim.boolparam_display_enabled, sim.navigation_camerafly]

def paint(inInts, inFloats, inStrings, inBuffer):
    cube = sim.getObjectHandle('Cube')
    sim.setShapeColor(cube, None, sim.colorcomponent_ambient_diffuse, inFloats[:3])
    sim.setShapeColor(cube, 'Cube_bottom', sim.colorcomponent_transparency, [0.5])
    return []

def missing(inInts, inFloats, inStrings, inBuffer):
    try:
        sim.colorcomponent_no_such_thing
    except AttributeError as exc:
        return [], [], [str(exc)]
    return [], [], ['no error']
"""


@pytest.fixture
def simulation(tmp_path):
    (tmp_path / "colours.lua").write_text(LUA)
    (tmp_path / "colours.py").write_text(PY)
    (tmp_path / "scene.xml").write_text(SCENE)
    sim = Simulation(tmp_path / "scene.xml", realtime=False, allow_python_scripts=True)
    sim.start()
    yield sim
    sim.close()


def call(sim: Simulation, obj: str, function: str, floats=()) -> list:
    return sim.scripts.call(obj, CHILD, function, [], list(floats), [], b"")


def rgba(sim: Simulation, geom: str) -> list[float]:
    return sim.world.model.geom(geom).rgba.tolist()


def test_every_table_constant_reaches_scripts():
    table = {**C.SIM_CONSTANTS, **C.VREP_CONSTANTS, **C.SCRIPT_ONLY}
    wrong = {n: FACADE_CONSTANTS.get(n[4:]) for n, v in table.items()
             if n.startswith("sim_") and FACADE_CONSTANTS.get(n[4:]) != v}
    assert not wrong
    assert FACADE_CONSTANTS["handle_world"] == -1


def test_lua_sees_4x_fields_and_3x_globals(simulation):
    ints = call(simulation, "LuaHolder", "values")[0]
    assert ints == [0, 4, 2000, 2017, 10, 16, 0, 2, 0x104, 6, 0x1000, 0x11, 0x400000, 2]


def test_python_sees_4x_fields(simulation):
    assert call(simulation, "PyHolder", "values")[0] == [0, 4, 2000, 2017, 16, 6]


def test_lua_set_shape_color_with_the_constants(simulation):
    call(simulation, "LuaHolder", "paint", [0.1, 0.6, 0.3])
    assert rgba(simulation, "Cube_top") == pytest.approx([0.1, 0.6, 0.3, 0.75])  # transparency 0.25
    assert rgba(simulation, "Cube_bottom") == pytest.approx([0.1, 0.6, 0.3, 1.0])


def test_python_set_shape_color_with_the_constants(simulation):
    call(simulation, "PyHolder", "paint", [0.9, 0.2, 0.05])
    assert rgba(simulation, "Cube_top") == pytest.approx([0.9, 0.2, 0.05, 1.0])
    assert rgba(simulation, "Cube_bottom") == pytest.approx([0.9, 0.2, 0.05, 0.5])


def test_unknown_constants_stay_errors(simulation):
    ok, err, global_value = call(simulation, "LuaHolder", "missing")[2]
    assert ok == "false" and "sim.colorcomponent_no_such_thing is not available in simx" in err
    assert global_value == "nil"  # an unknown sim_* global is nil, as any unset Lua global
    (message,) = call(simulation, "PyHolder", "missing")[2]
    assert "sim.colorcomponent_no_such_thing is not available in simx" in message
