"""The one table of CoppeliaSim's API (issue 43, ``simx_server.api``): every ``sim`` and ``simIK``
entry is reachable from Lua child scripts, Python child scripts and ZMQ clients alike (one
parametrised test walks the whole table through each door); an entry served to remote clients
only answers scripts with an error that says so; object arguments take every form
``sim.getObject`` takes."""

from __future__ import annotations

import pytest

from conftest import SCENE, ServerProcess, free_port
from simx_server.api import SIM, SIMIK, Callers, client_context, script_sim
from simx_server.scene.simulation import Simulation
from simx_wire.protocol import UnknownObjectError, UnsupportedError
from test_scripts import small_scene

#: Every entry as programs write it: ``sim.NAME`` and ``simIK.NAME``.
pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here
EVERY = [f"sim.{n}" for n in SIM] + [f"simIK.{n}" for n in SIMIK]

LUA_WALK = """
function sysCall_init()
  local missing = {}
  for _, qualified in ipairs({NAMES}) do
    local lib, name = qualified:match("^(%w+)%.([%w_]+)$")
    local t = lib == "sim" and sim or simIK
    if type(t[name]) ~= "function" then missing[#missing + 1] = qualified end
  end
  sim.setStringSignal("missing", table.concat(missing, ","))
  local ok, message = pcall(sim.loadScene, "elsewhere.ttt")
  sim.setStringSignal("refused", ok and "ran" or tostring(message))
end
"""

PYTHON_WALK = """
NAMES = {NAMES}


def sysCall_init():
    libraries = {{"sim": sim, "simIK": simIK}}
    missing = [q for q in NAMES if not callable(getattr(libraries[q.split(".")[0]], q.split(".")[1], None))]
    sim.setStringSignal("missing", ",".join(missing))
    try:
        sim.loadScene("elsewhere.ttt")
        sim.setStringSignal("refused", "ran")
    except Exception as exc:
        sim.setStringSignal("refused", str(exc))
"""


def _script_walk(tmp_path, language: str) -> tuple[str, str]:
    names = ", ".join(f'"{q}"' for q in EVERY)
    source = (LUA_WALK.replace("{NAMES}", "{" + names + "}") if language == "lua"
              else PYTHON_WALK.format(NAMES="[" + names + "]"))
    scene = small_scene(tmp_path, {"Walker": (f"walk.{'lua' if language == 'lua' else 'py'}", source)})
    sim = Simulation(scene, realtime=False, allow_python_scripts=True)
    try:
        sim.start()
        sim.step()
        missing, refused = (sim.signals.get("string", n) for n in ("missing", "refused"))
    finally:
        sim.stop()
        sim.close()
    assert missing is not None, "the walking script did not run"
    return missing.decode(), refused.decode()


@pytest.fixture(scope="module")
def zmq_server():
    port = free_port()
    srv = ServerProcess(str(SCENE), "--stopped", "--zmq-port", str(port), renderers="on-demand")
    srv.zmq_port = port
    yield srv
    srv.stop()


@pytest.mark.parametrize("door", ["lua", "python", "zmq"])
def test_every_entry_of_the_table_is_reachable(door, tmp_path, request):
    """Through each door the whole table: Lua's and Python's ``sim``/``simIK`` have every entry as
    a function; the official ZMQ client's ``require('sim')``/``require('simIK')`` objects have every
    entry served to clients, and a call of each library reaches the table."""
    if door == "zmq":
        pytest.importorskip("coppeliasim_zmqremoteapi_client")
        port = request.getfixturevalue("zmq_server").zmq_port
        client = request.getfixturevalue("official")(port)
        libraries = {"sim": client.require("sim"), "simIK": client.require("simIK")}
        served = [f"sim.{n}" for n in SIM.names(Callers.CLIENTS)] + [f"simIK.{n}" for n in SIMIK.names(Callers.CLIENTS)]
        assert len(served) == len(EVERY)  # no entry is for scripts only
        missing = [q for q in served if not callable(getattr(libraries[q.split(".")[0]], q.split(".")[1], None))]
        assert missing == []
        sim, simik = libraries["sim"], libraries["simIK"]
        assert sim.getObject("/UR5_joint1") == sim.getObjectHandle("UR5_joint1")
        env = simik.createEnvironment()
        assert isinstance(env, int)
        simik.eraseEnvironment(env)
        return
    missing, refused = _script_walk(tmp_path, door)
    assert missing == ""
    assert "sim.loadScene is served to remote API clients only in simx" in refused


def test_clients_only_entries_are_the_remote_programs_calls():
    """Which entries scripts may not call: the ones that act on the server from outside the scene
    (loading and closing scenes, starting the simulation...), each refused with its name. A
    script may stop or pause the simulation (a request, as in CoppeliaSim:
    tests/scripts/test_script_stop.py)."""
    only = set(SIM.names(Callers.CLIENTS)) - set(SIM.names(Callers.SCRIPTS))
    assert {"loadScene", "closeScene", "startSimulation"} <= only
    assert not {"stopSimulation", "pauseSimulation"} & only
    assert all(SIM[n].module == "simx_server.api.sim.remote" for n in only)
    assert set(SIMIK.names(Callers.SCRIPTS)) == set(SIMIK)


@pytest.fixture
def scene_sim():
    s = Simulation(SCENE, realtime=False)
    yield s
    s.close()


#: Calls of every category that take an object, with the rest of their arguments.
OBJECT_CALLS = [
    ("getObjectPosition", (-1,)), ("getObjectOrientation", (-1,)), ("getObjectQuaternion", (-1,)),
    ("getObjectMatrix", (-1,)), ("getObjectPose", (-1,)), ("getObjectParent", ()), ("getObjectType", ()),
    ("getObjectName", ()), ("getObjectAlias", (2,)), ("getObjectsInTree", ()), ("getObjectChild", (0,)),
    ("getJointPosition", ()), ("getJointType", ()), ("getJointInterval", ()), ("getJointTargetPosition", ()),
    ("getObjectVelocity", ()), ("getObjectInt32Param", (2000,)), ("getObjectFloatParam", (2003,)),
    ("isHandle", ()), ("readCustomDataBlockTags", ()), ("getExplicitHandling", ()),
]


@pytest.mark.parametrize("caller", ["script", "client"])
def test_object_arguments_take_every_form_get_object_takes(scene_sim, caller):
    """A handle, a name, a 3.x ``name#`` / ``name#n``, an absolute path, a path with an index and
    ``{"path": ..., "index": n}`` name the same object for calls of every category; an unknown path
    is an unknown object (not a wrong type)."""
    w = scene_sim.world
    api = (script_sim(w, w.resolve("UR5").handle, scene_sim.signals, simulation=scene_sim) if caller == "script"
           else client_context(scene_sim).sim)
    joint = w.resolve("UR5_joint1").handle
    forms = [joint, "UR5_joint1", "UR5_joint1#", "/UR5_joint1", "/UR5_joint1[0]", {"path": "/UR5_joint1", "index": 0}]
    assert all(api.getObject(f if not isinstance(f, dict) else f["path"]) == joint for f in forms[1:])
    for name, rest in OBJECT_CALLS:
        answers = [getattr(api, name)(form, *rest) for form in forms]
        assert all(a == answers[0] for a in answers), (name, answers)
    with pytest.raises(UnknownObjectError, match="does not exist"):
        api.getObjectPosition("/no/such/object", -1)
    assert api.getObjectPosition(joint, "/UR5") == api.getObjectPosition(joint, w.resolve("UR5").handle)


def test_scripts_get_a_clear_error_for_a_clients_only_entry(scene_sim):
    api = script_sim(scene_sim.world, scene_sim.world.resolve("UR5").handle, scene_sim.signals, simulation=scene_sim)
    with pytest.raises(UnsupportedError, match="sim.closeScene is served to remote API clients only"):
        api.closeScene()
