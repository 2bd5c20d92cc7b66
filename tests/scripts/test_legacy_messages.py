"""V-REP 3.x calls the census of ``../shared/ttt-corpus`` found (issue 34), on scripts of the tests'
own: tubes between scripts (``simTubeOpen``...), wireless data (``simSendData`` /
``simReceiveData``), special properties, dummy links, the execution count V-REP 3.1.3's
compatibility header sets, ``simDelegateChildScriptExecution`` and the fly-mode camera
parameter. In-process: a :class:`~simx_server.scene.simulation.Simulation` driven step by step.
"""

from __future__ import annotations

import logging

import pytest

from test_scripts import call, small_scene
from simx_server.scene.simulation import Simulation

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here


@pytest.fixture
def run(tmp_path):
    sims = []

    def make(scripts: dict, settings: str = "") -> Simulation:
        sim = Simulation(small_scene(tmp_path, scripts, settings), realtime=False)
        sims.append(sim)
        return sim

    yield make
    for sim in sims:
        sim.close()


def _errors(caplog) -> list[str]:
    return [r.getMessage() for r in caplog.records if r.name == "simx.scripts" and r.levelno >= logging.ERROR]


# ---------------------------------------------------------------- tubes
TUBE_END = """function sysCall_init() t=simTubeOpen(0, 'gripperState', 2) end
function write(i, f, s, b) return {simTubeWrite(t, b)} end
function read(i, f, s, b) local d=simTubeRead(t) if d then return {1}, {}, {}, d end return {0} end
function status(i, f, s, b) local st, r, w=simTubeStatus(t) return {st, r, w} end
function close(i, f, s, b) return {simTubeClose(t)} end
"""


def test_a_tube_connects_two_scripts_and_keeps_at_most_its_buffer_size(run):
    sim = run({"A": ("a.lua", TUBE_END), "B": ("b.lua", TUBE_END)})
    sim.start()
    for packet in (b"x", b"y", b"z"):
        assert call(sim, "A", "write", buffer=packet)[0] == [1]
    assert call(sim, "A", "status")[0] == [1, 0, 2]  # connected; B holds 2 packets (its buffer size)
    assert call(sim, "B", "read") == [[1], [], [], b"y"]  # the oldest, x, was dropped
    assert call(sim, "B", "read") == [[1], [], [], b"z"]
    assert call(sim, "B", "read")[0] == [0]  # nothing left: nil
    assert call(sim, "B", "close")[0] == [1]
    assert call(sim, "A", "status")[0] == [0, 0, 0]  # the other end went: not connected
    assert call(sim, "A", "write", buffer=b"lost")[0] == [-1]
    assert call(sim, "B", "status")[0] == [-1, 0, 0]  # a closed end does not exist
    assert call(sim, "B", "read")[0] == [0]


def test_tubes_close_when_the_simulation_stops(run):
    sim = run({"A": ("a.lua", TUBE_END), "B": ("b.lua", TUBE_END)})
    sim.start()
    assert call(sim, "A", "write", buffer=b"old")[0] == [1]
    sim.stop()
    sim.start()  # both open afresh: the packet of the previous run is gone
    assert call(sim, "B", "read")[0] == [0]


def test_a_blocking_tube_read_yields_the_thread_until_a_packet_arrives(run):
    reader = "function sysCall_init() t=simTubeOpen(0, 'cmd', 1) end\n" \
             "function sysCall_thread()\n  local d=simTubeRead(t, true)\n" \
             "  sim.setInt32Signal('got', simUnpackInts(d)[1])\nend\n"
    writer = "function sysCall_init() t=simTubeOpen(0, 'cmd', 1) n=0 end\n" \
             "function sysCall_actuation() n=n+1 if n==5 then simTubeWrite(t, simPackInts({42})) end end\n"
    sim = run({"Reader": ("r.lua", reader), "Writer": ("w.lua", writer)})
    sim.start()
    for _ in range(5):
        sim.step()
    assert sim.signals.get_int("got") is None  # written in the 5th pass, after the reader's resume
    sim.step()
    assert sim.signals.get_int("got") == 42


# ---------------------------------------------------------------- wireless data
SENDER = """function sysCall_sensing()
  simSendData(sim_handle_all, 7, 'light', simPackFloats({0.25}), sim_handle_self, {radius})
  local d=simReceiveData(7, 'light')  -- its own packets never come back
  if d then sim.setInt32Signal('echo', 1) end
end
"""
RECEIVER = """function sysCall_actuation()
  local d, sender, header, name=simReceiveData(7, 'light')
  if d then sim.setFloatSignal('light', simUnpackFloats(d)[1]) sim.setInt32Signal('from', sender)
    sim.setStringSignal('name', name) end
end
"""


@pytest.mark.parametrize("radius, received", [(100, True), (0.05, False)])
def test_wireless_data_reaches_scripts_within_the_action_radius_in_the_next_pass(run, radius, received):
    sim = run({"Sender": ("s.lua", SENDER.replace("{radius}", str(radius))), "Receiver": ("r.lua", RECEIVER)})  # 0.1 m apart
    sim.start()
    sim.step()  # sent in the first pass's sensing
    assert sim.signals.get_float("light") is None
    sim.step()  # read in the second pass
    assert (sim.signals.get_float("light") == pytest.approx(0.25)) is received
    if received:
        assert sim.signals.get_int("from") == sim.world.resolve("Sender").handle
        assert sim.signals.get_string("name") == b"light"
    assert sim.signals.get_int("echo") is None


# ---------------------------------------------------------------- special properties, dummy links
def test_special_properties_read_and_set_collidable_and_renderable(run):
    source = """function f(i, fl, s, b)
  local h=sim_handle_self
  local before=simGetObjectSpecialProperty(h)
  simSetObjectSpecialProperty(h, sim_objectspecialproperty_collidable+sim_objectspecialproperty_measurable
      +sim_objectspecialproperty_detectable_all+sim_objectspecialproperty_renderable)
  local collidable=simGetObjectSpecialProperty(h)
  simSetObjectSpecialProperty(h, sim_objectspecialproperty_detectable_all)
  return {before, collidable, simGetObjectSpecialProperty(h)}
end
"""
    sim = run({"Box": ("sp.lua", source)})  # the box's geom: contype=conaffinity=0, a shape all the same
    sim.start()
    assert call(sim, "Box", "f")[0] == [1 + 2 + 496 + 512, 1 + 2 + 496 + 512, 496]
    m, geom = sim.world.model, int(sim.world.model.body("Box").geomadr[0])
    # not renderable: out of the vision sensors' geom groups; its contact bits untouched
    assert (m.geom_contype[geom], m.geom_conaffinity[geom], m.geom_group[geom]) == (0, 0, 3)


def test_special_properties_each_flag_on_its_own(run):
    source = "function f(i, fl, s, b) simSetObjectSpecialProperty(sim_handle_self, 1) return {simGetObjectSpecialProperty(sim_handle_self)} end\n"
    sim = run({"Box": ("sp.lua", source)})
    sim.start()
    assert call(sim, "Box", "f")[0] == [1]  # collidable without measurable, as V-REP allows


LINKED = """<mujoco>
  <worldbody>
    <body name="Pad" pos="0 0 0.5"><freejoint/><geom type="box" size="0.02 0.02 0.02"/>
      <site name="LoopClosureDummy1"/></body>
    <body name="Holder" pos="0 0 0.5"><geom type="box" size="0.01 0.01 0.01" contype="0" conaffinity="0"/>
      <site name="LoopClosureDummy2"/></body>
  </worldbody>
  <equality><connect site1="LoopClosureDummy1" site2="LoopClosureDummy2"/></equality>
  <custom><text name="simx:Holder" data="child_script=link.lua"/></custom>
</mujoco>
"""


def test_set_link_dummy_switches_the_scenes_equality_between_the_two_dummies(tmp_path):
    (tmp_path / "link.lua").write_text("""function unlink(i, f, s, b)
  local a=sim.getObject('/LoopClosureDummy1')
  sim.setLinkDummy(a, -1) return {sim.getLinkDummy(a)} end
function link(i, f, s, b)
  local a, c=sim.getObject('/LoopClosureDummy1'), sim.getObject('/LoopClosureDummy2')
  sim.setLinkDummy(a, c) return {sim.getLinkDummy(a), c} end
""")
    (tmp_path / "scene.xml").write_text(LINKED)
    sim = Simulation(tmp_path / "scene.xml", realtime=False)
    try:
        sim.start()
        assert call(sim, "Holder", "unlink")[0] == [-1]
        for _ in range(100):  # unlinked, the pad falls
            sim.step()
        assert sim.world.data.body("Pad").xpos[2] < 0.45
        linked, other = call(sim, "Holder", "link")[0]
        assert linked == other
        assert bool(sim.world.data.eq_active[0])
    finally:
        sim.close()


# ---------------------------------------------------------------- V-REP 3.1.3's header, delegation
HEADER_3_1_3 = """if (sim_call_type==sim_childscriptcall_initialization) then
  simSetScriptAttribute(sim_handle_self,sim_childscriptattribute_automaticcascadingcalls,false)
  simSetIntegerSignal('delegated', simDelegateChildScriptExecution())
  local cam=simGetIntegerParameter(sim_intparam_flymode_camera_handle)
  simSetIntegerSignal('flymode', cam and 1 or 0)
end
if (sim_call_type==sim_childscriptcall_actuation) then
  if not firstTimeHere93846738 then firstTimeHere93846738=0 end
  simSetScriptAttribute(sim_handle_self,sim_scriptattribute_executioncount,firstTimeHere93846738)
  firstTimeHere93846738=firstTimeHere93846738+1
  if (simGetScriptExecutionCount()==0) then simSetIntegerSignal('first', 1) end
  simSetIntegerSignal('count', simGetScriptExecutionCount())
end
"""


def test_the_313_header_sets_the_execution_count_the_old_text_tests(run, caplog):
    sim = run({"Wheel": ("w.lua", HEADER_3_1_3)}, settings="vrep_version=30203")
    sim.start()
    for _ in range(3):
        sim.step()
    assert sim.signals.get_int("first") == 1
    assert sim.signals.get_int("count") == 2  # passes 0, 1, 2
    assert sim.signals.get_int("delegated") == 1
    assert sim.signals.get_int("flymode") == 0  # no fly-mode camera: nil
    assert not _errors(caplog)


NESTED = """<mujoco>
  <option gravity="0 0 0"/>
  <worldbody>
    <body name="Robot"><geom type="box" size="0.01 0.01 0.01" contype="0" conaffinity="0"/>
      <body name="Sensor" pos="0.05 0 0"><geom type="box" size="0.01 0.01 0.01" contype="0" conaffinity="0"/></body>
    </body>
    <body name="Other" pos="0 0.1 0"><geom type="box" size="0.01 0.01 0.01" contype="0" conaffinity="0"/></body>
  </worldbody>
  <custom>
    <text name="simx:Robot" data="child_script=rx.lua"/>
    <text name="simx:Sensor" data="child_script=tx.lua"/>
    <text name="simx:Other" data="child_script=ox.lua"/>
  </custom>
</mujoco>
"""


@pytest.mark.parametrize("target, robot, other", [("sim_handle_chain", True, False), ("sim_handle_all", True, True),
                                                  ("sim_handle_tree", False, False)])
def test_wireless_targets_chain_tree_and_all(tmp_path, target, robot, other):
    receive = "function sysCall_actuation() if simReceiveData(0, 'x') then sim.setInt32Signal('{0}', 1) end end\n"
    (tmp_path / "rx.lua").write_text(receive.replace("{0}", "robot"))
    (tmp_path / "ox.lua").write_text(receive.replace("{0}", "other"))
    (tmp_path / "tx.lua").write_text(f"function sysCall_sensing() simSendData({target}, 0, 'x', 'data') end\n")
    (tmp_path / "scene.xml").write_text(NESTED)
    sim = Simulation(tmp_path / "scene.xml", realtime=False)
    try:
        sim.start()
        sim.step()
        sim.step()
        assert (sim.signals.get_int("robot") == 1, sim.signals.get_int("other") == 1) == (robot, other)
    finally:
        sim.close()
