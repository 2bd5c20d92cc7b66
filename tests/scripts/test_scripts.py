"""Child scripts (issue 5): Lua through lupa and Python, one ``sim`` facade, faults and safety.

In-process tests drive a :class:`Simulation` directly (deterministic steps, no wall clock); the
remote tests run real ``simx-server`` subprocesses:

* the tutorial's ``../shared/legacy/RG2.lua``, byte for byte, attached to the RG2 of a test copy
  of the UR5 scene (written into tmp_path, with the ball held between the open fingers):
  ``rg2Close`` answers ``(0, [], [-0.05], [], bytearray())``, the gripper closes at 0.05 m/s and
  stops on the ball pushing with 20 N, ``rg2Open`` opens it;
* ``tests/scenes/scripts/``: scripts with a syntax error, run-time errors and endless loops, in
  both languages: each call answers remote error 8, the server logs the file, line and message,
  and it keeps serving.
"""

from __future__ import annotations

import gc
import logging
import re
import shutil
import struct
import weakref
import xml.etree.ElementTree as ET
from pathlib import Path

import mujoco
import numpy as np
import pytest

from conftest import LEGACY, ROOT, SCENE, ServerProcess, require_shared
from simx_client.protocol import ScriptError
from simx_server.api.signals import Signals
from simx_server.scripts.scene_scripts import Scripts
from simx_server.scene.simulation import Simulation
from simx_server.sim.world import World

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here

LEGACY_RG2 = LEGACY / "RG2.lua"
SCRIPT_SCENE = ROOT / "tests" / "scenes" / "scripts" / "scripts_scene.xml"
CHILD = 1  # sim_scripttype_childscript
GRIPPER = "RG2_openCloseJoint"
BALL_RADIUS = 0.03


# ------------------------------------------------------------------ scene helpers
def ur5_copy(folder: Path, script: Path, name: str | None = None) -> Path:
    """A copy of the shipped UR5 scene in ``folder`` with ``script`` (copied next to it) as the
    RG2's child script, and the ball floating (gravity compensated) between the open fingers."""
    name = name or script.name
    model = mujoco.MjModel.from_xml_path(str(SCENE))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    tcp = data.site("RG2_tcp").xpos
    tree = ET.parse(SCENE)
    texts = [t for t in tree.iter("text") if t.get("name") == "simx:RG2"]
    balls = [b for b in tree.iter("body") if b.get("name") == "Sphere"]
    assert len(texts) == 1 and len(balls) == 1, "the UR5 scene changed: update ur5_copy()"
    texts[0].set("data", f"child_script={name}")
    balls[0].set("pos", " ".join(f"{v:.6f}" for v in tcp))
    balls[0].set("gravcomp", "1")
    folder.mkdir(parents=True, exist_ok=True)
    tree.write(folder / "ur5_scripted.xml")
    shutil.copyfile(script, folder / name)
    return folder / "ur5_scripted.xml"


SMALL_SCENE = """<mujoco model="script test">
  <option timestep="0.002" gravity="0 0 0"/>
  <worldbody>
    <body name="Base" pos="0 0 0.1">
      <geom type="box" size="0.1 0.1 0.02"/>
      <body name="Slider" pos="0 0 0.05">
        <joint name="Slider_joint" type="slide" axis="1 0 0" range="-0.5 0.5" damping="1"/>
        <geom type="box" size="0.02 0.02 0.02" mass="0.1"/>
      </body>
    </body>
    <body name="Ball" pos="0.5 0 0.5"><freejoint/><geom type="sphere" size="0.03" mass="0.05"/></body>
    <body name="Target" mocap="true" pos="0 0.5 0.2">
      <geom type="box" size="0.01 0.01 0.01" contype="0" conaffinity="0"/>
    </body>
    {bodies}
  </worldbody>
  <actuator><velocity name="Slider_motor" joint="Slider_joint" kv="100" forcerange="-5 5"/></actuator>
  <custom>
    <text name="simx:Slider_joint" data="mode=velocity max_velocity=1"/>
    {texts}
  </custom>
</mujoco>
"""


def small_scene(folder: Path, scripts: dict[str, tuple[str, str]], settings: str = "") -> Path:
    """A small scene in ``folder`` with one object per entry ``{object: (file, source)}``."""
    bodies, texts = [], []
    for i, (obj, (file, source)) in enumerate(scripts.items()):
        bodies.append(f'<body name="{obj}" pos="1 {0.1 * i} 0"><geom type="box" size="0.01 0.01 0.01" '
                      'contype="0" conaffinity="0"/></body>')
        texts.append(f'<text name="simx:{obj}" data="child_script={file} {settings}"/>')
        (folder / file).write_text(source)
    path = folder / "scene.xml"
    path.write_text(SMALL_SCENE.format(bodies="\n    ".join(bodies), texts="\n    ".join(texts)))
    return path


@pytest.fixture
def simulation():
    sims = []

    def make(scene: Path, **script_options) -> Simulation:
        sim = Simulation(scene, realtime=False, allow_python_scripts=True)  # the scenes have Python scripts
        if script_options:  # Simulation builds Scripts(world); rebuild with the options under test
            sim.scripts = Scripts(sim.world, **{"allow_python_scripts": True, **script_options})
        sims.append(sim)
        return sim

    yield make
    for sim in sims:
        sim.close()


def call(sim: Simulation, obj: str, function: str, ints=(), floats=(), strings=(), buffer=b"") -> list:
    return sim.scripts.call(obj, CHILD, function, list(ints), list(floats), list(strings), buffer)


# ------------------------------------------------------------------ RG2 in-process
@pytest.mark.parametrize("script", [LEGACY_RG2, ROOT / "scenes" / "rg2.lua", ROOT / "scenes" / "rg2.py"],
                         ids=["legacy RG2.lua", "scenes/rg2.lua", "scenes/rg2.py"])
def test_rg2_script_closes_on_the_ball_and_opens(script, tmp_path, simulation):
    if script == LEGACY_RG2:
        require_shared(script)
    sim = simulation(ur5_copy(tmp_path, script))
    world = sim.world
    g = world.resolve(GRIPPER).handle
    sim.start()  # sysCall_init opens the gripper: it is open already
    for _ in range(2):
        sim.step()
    assert world.joint_position(g) == pytest.approx(0.055, abs=1e-3)

    assert call(sim, "RG2", "rg2Close") == [[], [-0.05], [], b""]
    q = []
    for _ in range(30):
        sim.step()
        q.append(world.joint_position(g))
    speed = (q[6] - q[2]) / (4 * world.dt)
    assert speed == pytest.approx(-0.05, rel=0.05)
    # Stopped on the ball: both fingers' inner faces at the ball's surface, pushing with 20 N.
    assert q[-1] == pytest.approx(q[-5], abs=1e-5)
    assert q[-1] == pytest.approx(BALL_RADIUS, abs=0.003)
    assert world.joint_force(g) == pytest.approx(-20.0, abs=1.0)

    assert call(sim, "RG2", "rg2Open") == [[], [0.05], [], b""]
    for _ in range(20):
        sim.step()
    assert world.joint_position(g) == pytest.approx(0.055, abs=2e-3)


# ------------------------------------------------------------------ life cycle
LUA_LIFE_CYCLE = """
inits = 0                 -- a global: fresh at every simulation start
local steps = 0
print('top level')
function sysCall_init() inits = inits + 1; print('init', inits) end
function sysCall_actuation() steps = steps + 1; print('actuation', steps) end
function sysCall_sensing() print('sensing', steps) end
function sysCall_cleanup() print('cleanup', steps) end
function count(inInts, inFloats, inStrings, inBuffer) return {inits, steps} end
"""

PY_LIFE_CYCLE = """
inits = 0
steps = 0
print('top level')
def sysCall_init():
    global inits
    inits += 1
    print('init', inits)
def sysCall_actuation():
    global steps
    steps += 1
    print('actuation', steps)
def sysCall_sensing():
    print('sensing', steps)
def sysCall_cleanup():
    print('cleanup', steps)
def count(inInts, inFloats, inStrings, inBuffer):
    return [inits, steps]
"""


@pytest.mark.parametrize("file, source", [("life.lua", LUA_LIFE_CYCLE), ("life.py", PY_LIFE_CYCLE)],
                         ids=["lua", "python"])
def test_life_cycle_order_over_stop_and_start(file, source, tmp_path, simulation, caplog):
    sim = simulation(small_scene(tmp_path, {"Box": (file, source)}))
    caplog.set_level(logging.INFO, logger="simx.scripts")

    def events() -> list[str]:
        out = [r.getMessage().split("] ", 1)[1].replace("\t", " ") for r in caplog.records
               if r.getMessage().startswith(f"[{file}]")]
        caplog.clear()
        return out

    with pytest.raises(ScriptError, match="stopped"):
        call(sim, "Box", "count")  # V-REP's child scripts exist only while the simulation runs
    assert events() == []
    sim.start()
    sim.step()
    sim.step()
    sim.pause()
    assert call(sim, "Box", "count") == [[1, 2], [], [], b""]
    sim.start()
    sim.step()
    sim.stop()
    assert events() == ["top level", "init 1", "actuation 1", "sensing 1", "actuation 2", "sensing 2",
                        "actuation 3", "sensing 3", "cleanup 3"]
    sim.start()  # a fresh state: the globals start over
    sim.step()
    assert call(sim, "Box", "count") == [[1, 1], [], [], b""]
    sim.stop()
    assert events() == ["top level", "init 1", "actuation 1", "sensing 1", "cleanup 1"]


def test_step_function_that_never_returns_is_skipped_until_restart(tmp_path, simulation, caplog):
    source = """
function sysCall_actuation() while true do end end
function sysCall_sensing() sim.setIntegerSignal('sensed', (sim.getIntegerSignal('sensed') or 0) + 1) end
function ok() return {1} end
"""
    sim = simulation(small_scene(tmp_path, {"Box": ("stuck.lua", source)}, "script_timeout=0.05"))
    sim.start()
    with caplog.at_level(logging.ERROR, logger="simx.scripts"):
        for _ in range(3):
            sim.step()
    errors = [r.getMessage() for r in caplog.records if r.levelno >= logging.ERROR]
    assert len(errors) == 1
    assert re.search(r"stuck\.lua of 'Box', sysCall_actuation: stuck\.lua:2: interrupted", errors[0])
    assert "skipped until the simulation restarts" in errors[0]
    assert sim.scripts.signals.get_int("sensed") is None  # skipped too, from the first step on
    assert call(sim, "Box", "ok") == [[1], [], [], b""]  # remote calls still work


def test_runtime_error_in_step_function_is_logged_once(tmp_path, simulation, caplog):
    source = "function sysCall_sensing() local t = nil; return t.x end\n"
    sim = simulation(small_scene(tmp_path, {"Box": ("bad.lua", source)}))
    sim.start()
    with caplog.at_level(logging.DEBUG, logger="simx.scripts"):
        for _ in range(4):
            sim.step()
    errors = [r.getMessage() for r in caplog.records if r.levelno >= logging.ERROR]
    assert errors == ["child script bad.lua of 'Box', sysCall_sensing: bad.lua:1: "
                      "attempt to index a nil value (local 't')"]
    assert sim.steps == 4


# ------------------------------------------------------------------ tables and the facade
LUA_TABLES = r"""
function echo(inInts, inFloats, inStrings, inBuffer) return inInts, inFloats, inStrings, inBuffer end
function types(inInts, inFloats, inStrings, inBuffer)
  return {}, {}, {math.type(inInts[1]), math.type(inFloats[1]), type(inStrings[1]), type(inBuffer)}, ''
end
function nothing() end
function intsOnly() return {1, 2.0, 3.7} end
function holes() return nil, {1.5} end
function tooMany() return {}, {}, {}, '', {} end
function notASequence() return {a = 1} end
function numberAsString() return {}, {}, {12} end
function binary() return {}, {}, {}, '\0\255\1' end
"""


def test_lua_tables_map_to_legacy_lists_and_back(tmp_path, simulation):
    sim = simulation(small_scene(tmp_path, {"Box": ("tables.lua", LUA_TABLES)}))
    sim.start()
    blob = bytes(range(256))
    assert call(sim, "Box", "echo", [1, -2, 2**31 - 1], [0.5, -1.25], ["a", "héllo", ""], blob) == \
        [[1, -2, 2**31 - 1], [0.5, -1.25], ["a", "héllo", ""], blob]
    assert call(sim, "Box", "types", [1], [1.0], ["x"]) == [[], [], ["integer", "float", "string", "string"], b""]
    assert call(sim, "Box", "nothing") == [[], [], [], b""]
    assert call(sim, "Box", "intsOnly") == [[1, 2, 3], [], [], b""]
    assert call(sim, "Box", "holes") == [[], [1.5], [], b""]
    assert call(sim, "Box", "numberAsString") == [[], [], ["12"], b""]
    assert call(sim, "Box", "binary") == [[], [], [], b"\x00\xff\x01"]
    with pytest.raises(ScriptError, match="tooMany: returned 5 values; at most 4"):
        call(sim, "Box", "tooMany")
    with pytest.raises(ScriptError, match="notASequence: returned values of the wrong types"):
        call(sim, "Box", "notASequence")


LUA_FACADE = r"""
function objects()
  local me = sim.getObjectHandle(sim.handle_self)
  local slider = sim.getObjectHandle('Slider_joint')
  return {me, sim.getObject('.'), sim.getObject('/Base'), sim.getObject('nope', {noError = true}),
          slider, sim.getObjectType(slider), sim.getObjectParent(sim.getObjectHandle('Slider')),
          sim.getObjectAssociatedWithScript(sim.handle_self), simGetObjectHandle('Base'), sim_handle_self},
         {}, {sim.getObjectName(me), sim.getObjectName(slider)}, ''
end

function poses()
  local ball, target, base = sim.getObjectHandle('Ball'), sim.getObjectHandle('Target'), sim.getObjectHandle('Base')
  sim.setObjectPosition(ball, -1, {0.1, 0.2, 0.3})
  sim.setObjectPosition(target, base, {0, 0, 1})
  sim.setObjectOrientation(target, -1, {0, 0, math.pi / 2})
  local p, q = sim.getObjectPosition(ball, -1), sim.getObjectQuaternion(target, sim.handle_world)
  local t, e = sim.getObjectPosition(target, -1), sim.getObjectOrientation(target, -1)
  local out = {}
  for _, v in ipairs({p, t, e, q}) do for i = 1, #v do out[#out + 1] = v[i] end end
  return {#p, #q}, out
end

function joints()
  local j = sim.getObjectHandle('Slider_joint')
  sim.setJointMaxForce(j, 3)
  sim.setJointTargetVelocity(j, 0.2)
  sim.setJointPosition(j, 0.1)
  return {}, {sim.getJointPosition(j), sim.getJointMaxForce(j), sim.getJointTargetVelocity(j),
              sim.getSimulationTime(), sim.getSimulationTimeStep()}
end

function signals()
  sim.setIntegerSignal('i', 7)
  sim.setFloatSignal('f', 2.5)
  sim.setStringSignal('s', 'a\0b')
  local missing = sim.getIntegerSignal('missing')
  return {sim.getIntegerSignal('i'), missing == nil and 1 or 0}, {sim.getFloatSignal('f')},
         {}, sim.getStringSignal('s')
end

function packing(inInts, inFloats)
  local f = sim.packFloatTable(inFloats)
  local i = sim.packInt32Table(inInts, 1, 2)
  local u = sim.packUInt8Table({1, 255})
  local back = sim.unpackFloatTable(f, 1)
  return sim.unpackInt32Table(i), back, {tostring(#f), tostring(#u)}, f .. i .. u
end

function errors()
  local ok1, e1 = pcall(sim.getObjectHandle, 'nope')
  local ok2, e2 = pcall(function() return sim.noSuchThing end)
  local ok3, e3 = pcall(sim.setObjectPosition, sim.getObjectHandle('Slider'), -1, {1e9, 0, 0})
  local ok4, e4 = pcall(sim.setJointTargetVelocity, sim.getObjectHandle('Slider_joint'), 'fast')
  local ok5, e5 = pcall(sim.getObjectPosition)  -- no handle (relativeTo is optional since CoppeliaSim 4.5)
  return {}, {}, {tostring(ok1), e1, e2, e3, e4, e5}
end

function logs() print('hello', 1, nil, true); sim.addStatusbarMessage('status') end
function sandbox()
  return {}, {}, {type(python), type(debug.sethook), type(os.time), type(string.format), type(unpack),
                  type(table.getn)}
end
"""


@pytest.fixture
def lua_facade(tmp_path, simulation):
    sim = simulation(small_scene(tmp_path, {"Box": ("facade.lua", LUA_FACADE)}))
    sim.start()
    return sim


def test_lua_facade_objects(lua_facade):
    w = lua_facade.world
    h = {n: w.resolve(n).handle for n in ("Box", "Base", "Slider_joint", "Slider")}
    ints, _, strings, _ = call(lua_facade, "Box", "objects")
    assert ints == [h["Box"], h["Box"], h["Base"], -1, h["Slider_joint"], 1, h["Slider_joint"], h["Box"],
                    h["Base"], -4]
    assert strings == ["Box", "Slider_joint"]


def test_lua_facade_poses_of_free_and_mocap_bodies(lua_facade):
    ints, floats, _, _ = call(lua_facade, "Box", "poses")
    assert ints == [3, 4]
    ball, target, euler, quat = floats[0:3], floats[3:6], floats[6:9], floats[9:13]
    assert ball == pytest.approx([0.1, 0.2, 0.3], abs=1e-9)
    assert target == pytest.approx([0.0, 0.0, 1.1], abs=1e-9)  # Base is at z=0.1
    assert euler == pytest.approx([0, 0, np.pi / 2], abs=1e-9)
    assert quat == pytest.approx([0, 0, np.sin(np.pi / 4), np.cos(np.pi / 4)], abs=1e-9)


def test_lua_facade_joints_time_and_signals(lua_facade):
    _, floats, _, _ = call(lua_facade, "Box", "joints")
    assert floats == pytest.approx([0.1, 3.0, 0.2, 0.0, lua_facade.world.dt])
    assert call(lua_facade, "Box", "signals") == [[7, 1], [2.5], [], b"a\x00b"]
    signals = lua_facade.scripts.signals
    assert (signals.get_int("i"), signals.get_float("f"), signals.get_string("s")) == (7, 2.5, b"a\x00b")
    signals.set_int("remote", 1)  # set by a client: outlives the simulation run
    lua_facade.stop()
    assert signals.get_int("i") is None and signals.get_string("s") is None
    assert signals.get_int("remote") == 1


def test_lua_facade_packing(lua_facade):
    ints, floats, strings, buf = call(lua_facade, "Box", "packing", [1, 2, 3, 4], [0.5, 1.5, -2.0])
    assert ints == [2, 3] and floats == [1.5, -2.0] and strings == ["12", "2"]
    assert buf == struct.pack("<3f", 0.5, 1.5, -2.0) + struct.pack("<2i", 2, 3) + b"\x01\xff"


def test_lua_facade_errors_are_lua_errors_that_name_the_function(lua_facade):
    strings = call(lua_facade, "Box", "errors")[2]
    assert strings[0] == "false"
    assert re.fullmatch(r"facade\.lua:\d+: sim\.getObjectHandle: object 'nope' does not exist.*", strings[1])
    assert re.fullmatch(r"facade\.lua:\d+: sim\.noSuchThing is not available in simx.*", strings[2])
    assert re.fullmatch(r"facade\.lua:\d+: sim\.setObjectPosition: .*MAX_POSITION.*", strings[3])
    assert "sim.setJointTargetVelocity: velocity must be a number" in strings[4]
    assert "sim.getObjectPosition: bad arguments" in strings[5]


def test_lua_print_and_status_go_to_the_log(lua_facade, caplog):
    with caplog.at_level(logging.INFO, logger="simx.scripts"):
        call(lua_facade, "Box", "logs")
    assert [r.getMessage() for r in caplog.records] == ["[facade.lua] hello\t1\tnil\ttrue", "[facade.lua] status"]


def test_lua_sandbox(lua_facade):
    assert call(lua_facade, "Box", "sandbox")[2] == ["nil", "nil", "function", "function", "function", "function"]


PY_FACADE = """
import math

def objects(inInts, inFloats, inStrings, inBuffer):
    me = sim.getObjectHandle(sim.handle_self)
    return [me, sim.getObject('/Base'), sim.getObject('nope', {'noError': True})], [], [sim.getObjectName(me)]

def poses(inInts, inFloats, inStrings, inBuffer):
    ball = sim.getObjectHandle('Ball')
    sim.setObjectPosition(ball, -1, [0.1, 0.2, 0.3])
    sim.setObjectQuaternion(ball, -1, [0, 0, math.sin(math.pi / 4), math.cos(math.pi / 4)])
    return [], sim.getObjectPosition(ball, -1) + sim.getObjectOrientation(ball, -1)

def signals(inInts, inFloats, inStrings, inBuffer):
    sim.setStringSignal('s', inBuffer)
    return [], [], [], sim.getStringSignal('s') + sim.packInt32Table([1])

def imported():
    pass

from os import getcwd
"""


def test_python_facade(tmp_path, simulation):
    sim = simulation(small_scene(tmp_path, {"Box": ("facade.py", PY_FACADE)}))
    sim.start()
    w = sim.world
    assert call(sim, "Box", "objects") == [[w.resolve("Box").handle, w.resolve("Base").handle, -1], [], ["Box"], b""]
    _, floats, _, _ = call(sim, "Box", "poses")
    assert floats == pytest.approx([0.1, 0.2, 0.3, 0, 0, np.pi / 2], abs=1e-9)
    assert call(sim, "Box", "signals", buffer=b"\x00x") == [[], [], [], b"\x00x\x01\x00\x00\x00"]
    with pytest.raises(ScriptError, match="no function 'getcwd'"):
        call(sim, "Box", "getcwd")  # imported, not defined by the script


def test_lua_require_finds_modules_in_the_scene_folder_only(tmp_path, simulation):
    (tmp_path / "helpers.lua").write_text("local M = {}\nfunction M.twice(x) return 2 * x end\nreturn M\n")
    source = """
local helpers = require('helpers')
function twice(inInts) return {helpers.twice(inInts[1])} end
function native() return {}, {}, {tostring(pcall(require, 'socket.core'))} end
function memory() local s = string.rep('x', 1 << 30) return {#s} end
"""
    sim = simulation(small_scene(tmp_path, {"Box": ("main.lua", source)}))
    sim.start()
    assert call(sim, "Box", "twice", [21]) == [[42], [], [], b""]
    assert call(sim, "Box", "native")[2] == ["false"]  # no C modules
    with pytest.raises(ScriptError, match="out of memory"):
        call(sim, "Box", "memory")
    assert call(sim, "Box", "twice", [2]) == [[4], [], [], b""]


def test_script_errors_leave_no_reference_cycles(tmp_path, simulation):
    """The server's pending Zenoh query lives in a caller's frame and answers the client's final
    reply only when it goes: an error kept alive by a reference cycle (exception -> traceback ->
    frame -> exception) would make the client wait until the garbage collector runs."""
    lua = "function fail() error('x') end\nfunction spin() while true do end end\n"
    py = "def fail(*a):\n    raise ValueError('x')\ndef spin(*a):\n    while True:\n        pass\n"
    sim = simulation(small_scene(tmp_path, {"L": ("c.lua", lua), "P": ("c.py", py)}, "script_timeout=0.05"))
    sim.start()

    class Query:
        pass

    def answer(query, obj, function):
        with pytest.raises(ScriptError):
            call(sim, obj, function)

    gc.collect()
    gc.disable()
    try:
        for obj, function in [("L", "fail"), ("L", "spin"), ("P", "fail"), ("P", "spin")]:
            query = Query()
            alive = weakref.ref(query)
            answer(query, obj, function)
            del query
            assert alive() is None, f"{obj}.{function}: the caller's frame outlived the call"
    finally:
        gc.enable()


def test_world_places_free_and_mocap_bodies(tmp_path):
    """World.set_pose, which the facade's setObjectPosition/Orientation use."""
    world = World(small_scene(tmp_path, {}))
    ball, target, base = (world.resolve(n).handle for n in ("Ball", "Target", "Base"))
    world.set_pose(ball, -1, position=[0.1, 0.2, 0.3])
    quarter_turn_x = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
    world.set_pose(target, base, position=[0.0, 0.0, 1.0], rotation=quarter_turn_x)
    assert world.position(ball, -1) == pytest.approx([0.1, 0.2, 0.3])
    assert world.position(target, -1) == pytest.approx([0.0, 0.0, 1.1])
    assert world.orientation(target, -1) == pytest.approx([np.pi / 2, 0, 0])


# ------------------------------------------------------------------ safety
LUA_REMOTE_CODE = """
function executeCode(inInts, inFloats, inStrings, inBuffer)
  return {}, {}, {tostring(loadstring(inStrings[1])())}, ''
end
function escape() os.exit(1) end
function binaryChunk() return {}, {}, {tostring(load(string.dump(function() return 1 end)))} end
"""
PY_REMOTE_CODE = """
def executeCode(inInts, inFloats, inStrings, inBuffer):
    return [], [], [str(eval(inStrings[0]))]
"""


def test_client_code_runs_only_with_the_flag(tmp_path, simulation):
    scene = small_scene(tmp_path, {"Lua": ("code.lua", LUA_REMOTE_CODE), "Py": ("code.py", PY_REMOTE_CODE)})
    sim = simulation(scene)
    sim.start()
    with pytest.raises(ScriptError, match=r"code\.lua:3: loadstring is not available .*--allow-remote-code"):
        call(sim, "Lua", "executeCode", strings=["return sim.getObjectHandle('Base')"])
    with pytest.raises(ScriptError, match=r"code\.py:3: ScriptError: eval\(\) is disabled .*--allow-remote-code"):
        call(sim, "Py", "executeCode", strings=["1 + 1"])
    with pytest.raises(ScriptError, match="os.exit is not available"):
        call(sim, "Lua", "escape")

    trusting = simulation(scene, allow_remote_code=True)
    trusting.start()
    base = str(trusting.world.resolve("Base").handle)
    assert call(trusting, "Lua", "executeCode", strings=["return sim.getObjectHandle('Base')"])[2] == [base]
    assert call(trusting, "Py", "executeCode", strings=["1 + 1"])[2] == ["2"]
    # Even then, no precompiled chunks (they can crash the Lua VM).
    assert call(trusting, "Lua", "binaryChunk")[2] == ["nil"]


def test_scripts_in_a_folder_clients_write_to_are_refused(tmp_path):
    """A scene sent with simxTransferFile must not bring code: its scripts are refused unless
    the server allows remote code."""
    scene = small_scene(tmp_path, {"Box": ("sent.py", "def f(*a):\n    return [1]\n")})
    world = World(scene)
    with pytest.raises(ValueError, match="sent by a client .*--allow-remote-code"):
        Scripts(world, untrusted=[tmp_path])
    assert set(Scripts(world, untrusted=[tmp_path], allow_remote_code=True, allow_python_scripts=True).scripts) == {
        world.resolve("Box").handle}
    assert len(Scripts(world, untrusted=[tmp_path / "elsewhere"], allow_python_scripts=True).scripts) == 1


def test_scene_errors_refuse_the_scene(tmp_path):
    (tmp_path / "sub").mkdir()
    outside = tmp_path / "outside.lua"
    outside.write_text("function f() end\n")
    for data, message in [("child_script=../outside.lua", "outside the scene folder"),
                          ("child_script=missing.lua", "not found"),
                          ("child_script=x.txt", "unknown language"),
                          ("child_script=x.lua script_timeout=0", "script_timeout")]:
        (tmp_path / "sub" / "x.txt").write_text("")
        (tmp_path / "sub" / "x.lua").write_text("")
        scene = tmp_path / "sub" / "scene.xml"
        scene.write_text(SMALL_SCENE.format(bodies='<body name="B"><geom size="0.1"/></body>',
                                            texts=f'<text name="simx:B" data="{data}"/>'))
        with pytest.raises(ValueError, match=message):
            Simulation(scene, realtime=False)


def test_signals_store():
    s = Signals()
    s.set_int("a", 3)
    s.set_float("a", 1.5)
    s.set_string("a", "é")
    assert (s.get_int("a"), s.get_float("a"), s.get_string("a")) == (3, 1.5, "é".encode())
    assert s.get_int("b") is None and s.get_int("b", 0) == 0
    s.set(Signals.INT, "b", 4.0, by_script=True)
    assert s.names(Signals.INT) == ["a", "b"]
    s.clear_script_signals()
    assert s.names(Signals.INT) == ["a"]
    s.clear(Signals.FLOAT, "a")
    assert s.get_float("a") is None and s.get_string("a") == "é".encode()
    s.clear()
    assert s.get_int("a") is None and s.get_string("a") is None
    with pytest.raises(Exception, match="not an integer"):
        s.set_int("x", 1.5)


# ------------------------------------------------------------------ remote: real servers
def test_remote_legacy_rg2_lua_closes_on_the_ball_and_opens(tmp_path):
    import vrep

    B = vrep.simx_opmode_blocking
    scene = ur5_copy(tmp_path, require_shared(LEGACY_RG2), "RG2.lua")
    assert (tmp_path / "RG2.lua").read_bytes() == LEGACY_RG2.read_bytes()
    server = ServerProcess(str(scene), renderers="on-demand")
    cid = -1
    try:
        cid = vrep.simxStart("127.0.0.1", server.port, True, True, 5000, 5)
        assert cid >= 0
        rc, g = vrep.simxGetObjectHandle(cid, GRIPPER, B)
        assert rc == 0
        assert vrep.simxSynchronous(cid, True) == 0  # steps on our triggers: no wall-clock timing

        def state() -> tuple[float, float]:
            rc, q = vrep.simxGetJointPosition(cid, g, B)
            assert rc == 0
            return q, vrep.simxGetLastCmdTime(cid) / 1000.0

        def steps(n: int) -> None:
            for _ in range(n):
                assert vrep.simxSynchronousTrigger(cid) == 0

        assert state()[0] == pytest.approx(0.055, abs=1e-3)  # sysCall_init opened it
        assert vrep.simxCallScriptFunction(cid, "RG2", vrep.sim_scripttype_childscript, "rg2Close",
                                           [], [], [], bytearray(), B) == \
            (0, [], [pytest.approx(-0.05, rel=1e-6)], [], bytearray())
        steps(2)
        q0, t0 = state()
        steps(4)
        q1, t1 = state()
        assert t1 - t0 == pytest.approx(0.2, abs=1e-6)
        assert (q1 - q0) / (t1 - t0) == pytest.approx(-0.05, rel=0.05)
        steps(20)
        q_held, _ = state()
        steps(4)
        assert state()[0] == pytest.approx(q_held, abs=1e-5)
        assert q_held == pytest.approx(BALL_RADIUS, abs=0.003)
        rc, force = vrep.simxGetJointForce(cid, g, B)
        assert rc == 0 and force == pytest.approx(-20.0, abs=1.0)

        rc, _, floats, _, _ = vrep.simxCallScriptFunction(cid, "RG2", vrep.sim_scripttype_childscript, "rg2Open",
                                                          [], [], [], bytearray(), B)
        assert rc == 0 and floats == [pytest.approx(0.05, rel=1e-6)]
        steps(20)
        assert state()[0] == pytest.approx(0.055, abs=2e-3)
    finally:
        if cid >= 0:
            vrep.simxFinish(cid)
        server.stop()


def test_remote_script_faults_answer_errors_and_the_server_keeps_serving():
    import vrep

    B = vrep.simx_opmode_blocking
    server = ServerProcess(str(SCRIPT_SCENE))
    cid = -1
    failed = (8, [], [], [], bytearray())
    try:
        cid = vrep.simxStart("127.0.0.1", server.port, True, True, 5000, 5)
        assert cid >= 0

        def script(obj: str, function: str, ints=(), floats=(), strings=(), buffer=b""):
            return vrep.simxCallScriptFunction(cid, obj, vrep.sim_scripttype_childscript, function,
                                               list(ints), list(floats), list(strings), bytearray(buffer), B)

        def still_serving():
            assert vrep.simxGetObjectHandle(cid, "Base", B)[0] == 0
            assert script("LuaBox", "echo", [5]) == (0, [5], [], [], bytearray())

        blob = bytes(range(256))
        for obj in ("LuaBox", "PyBox"):
            assert script(obj, "echo", [1, -2], [0.5, -1.25], ["a", "héllo"], blob) == \
                (0, [1, -2], [0.5, -1.25], ["a", "héllo"], bytearray(blob))
            rc, ints, floats, strings, buf = script(obj, "describe", [1, 2, 3], [0.5], ["ab"], b"xyz")
            assert (rc, ints, strings, bytes(buf)) == (0, [3, 1, 1, 3], ["AB"], struct.pack("<f", 0.5))
            assert floats == [pytest.approx(0.05)]

        for obj, function in [("LuaSyntax", "ok"), ("PySyntax", "broken"),
                              ("LuaFaulty", "fail"), ("LuaFaulty", "badObject"), ("LuaFaulty", "unknownSim"),
                              ("LuaFaulty", "badReturn"), ("PyFaulty", "fail"), ("PyFaulty", "badObject"),
                              ("PyFaulty", "unknownSim"),
                              ("LuaLoop", "spin"), ("LuaLoop", "stubborn"), ("LuaLoop", "inCoroutine"),
                              ("PyLoop", "spin"), ("PyLoop", "stubborn"),
                              ("LuaBox", "noSuchFunction"), ("LuaBox", "executeCode")]:
            assert script(obj, function) == failed, f"{obj}.{function}"
            still_serving()
        for obj in ("LuaFaulty", "PyFaulty", "LuaLoop", "PyLoop"):
            assert script(obj, "fine")[:2] in ((0, [42]), (0, [7]))
    finally:
        if cid >= 0:
            vrep.simxFinish(cid)
        log = server.stop()
    assert server.proc.returncode == 0, log
    expected = [
        r"syntax_error\.lua of 'LuaSyntax' cannot be loaded: syntax_error\.lua:4: .*expected near 'return'",
        r"syntax_error\.py of 'PySyntax' cannot be loaded: syntax_error\.py:4: SyntaxError",
        r"runtime_error\.lua of 'LuaFaulty', fail: runtime_error\.lua:4: attempt to index a nil value",
        r"runtime_error\.lua of 'LuaFaulty', badObject: runtime_error\.lua:8: sim\.getObjectHandle: object "
        r"'no_such_object' does not exist",
        r"runtime_error\.lua of 'LuaFaulty', unknownSim: runtime_error\.lua:12: sim\.noSuchFunction is not available",
        r"runtime_error\.py of 'PyFaulty', fail: runtime_error\.py:5: ZeroDivisionError",
        r"runtime_error\.py of 'PyFaulty', badObject: runtime_error\.py:9: UnknownObjectError",
        r"endless\.lua of 'LuaLoop', spin: endless\.lua:4: interrupted: did not return within 0\.2 s",
        r"endless\.lua of 'LuaLoop', stubborn: endless\.lua:\d+: interrupted",
        r"endless\.lua of 'LuaLoop', inCoroutine: endless\.lua:14: interrupted",
        r"endless\.py of 'PyLoop', spin: endless\.py:\d+: interrupted: did not return within 0\.2 s",
        r"endless\.py of 'PyLoop', stubborn: endless\.py:\d+: interrupted",
        r"facade\.lua of 'LuaBox', executeCode: facade\.lua:\d+: loadstring is not available .*--allow-remote-code",
    ]
    for pattern in expected:
        lines = [line for line in log.splitlines() if re.search(pattern, line)]
        assert lines, f"no log line matches {pattern!r}:\n{log}"
        if "cannot be loaded" not in pattern:
            assert any("simxCallScriptFunction failed" in line for line in lines), lines


def test_python_scripts_are_bounded_in_cpu_time_with_a_wall_backstop(tmp_path, simulation):
    """A Python script's script_timeout counts its thread's CPU time, as a Lua script's does: a
    call that waits (a render it asked for on a loaded machine; here a sleep) is not cut at the
    bound, one that works past it is, and one that waits past WALL_FACTOR times the bound is."""
    from simx_server.scripts.watchdog import Watchdog

    py = ("import time\n"
          "naps = 0\n"
          "def wait(*a):\n    time.sleep(0.3)\n    return [1]\n"
          "def work(*a):\n    while True:\n        pass\n"
          "def nap(*a):\n    global naps\n    while True:\n        naps += 1\n        time.sleep(0.01)\n"
          "def count(*a):\n    return [naps]\n")
    sim = simulation(small_scene(tmp_path, {"P": ("c.py", py)}, "script_timeout=0.05"))
    sim.start()
    assert call(sim, "P", "wait") == [[1], [], [], b""]  # 0.3 s of waiting, past the 0.05 s bound
    for function in ("work", "nap"):
        with pytest.raises(ScriptError, match="did not return within 0.05 s"):
            call(sim, "P", function)
    # the nap was cut by the wall-time backstop (WALL_FACTOR x 0.05 s: at most 50 naps of 10 ms),
    # long before its thread's CPU time (some microseconds a nap) could reach the bound
    naps = call(sim, "P", "count")[0][0]
    assert 1 <= naps <= Watchdog.WALL_FACTOR * 0.05 / 0.01 + 1
