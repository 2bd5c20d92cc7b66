"""V-REP's scripts as scenes carry them (issue 34), in-process: the first-line comment that Lua's
``loadfile`` skips, pre-3.6 ``sim_call_type`` scripts, the 3.x global names, threaded scripts as
coroutines, customization scripts, joint callbacks and script simulation parameters.

Each test writes a small scene and its scripts into ``tmp_path`` and drives a
:class:`~simx_server.scene.simulation.Simulation` step by step (no wall clock, no network).
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

    def make(scripts: dict, settings: str = "", **kwargs) -> Simulation:
        sim = Simulation(small_scene(tmp_path, scripts, settings), realtime=False, **kwargs)
        sims.append(sim)
        return sim

    yield make
    for sim in sims:
        sim.close()


# ---------------------------------------------------------------- loading
def test_a_first_line_starting_with_hash_is_skipped_as_loadfile_does(run):
    source = "#!/usr/bin/env lua -- a comment line some authors write\nfunction f(a, b, c, d)\n" \
             "  error('here')\nend\nfunction g() return {7} end\n"
    sim = run({"Box": ("hash.lua", source)})
    assert sim.scripts.scripts[next(iter(sim.scripts.scripts))].load_error is None
    sim.start()
    assert call(sim, "Box", "g") == [[7], [], [], b""]
    with pytest.raises(Exception, match=r"hash\.lua:3: here"):  # line numbers stay those of the file
        call(sim, "Box", "f")


def steps(sim: Simulation, n: int) -> None:
    for _ in range(n):
        sim.step()


def signal(sim: Simulation, name: str):
    return sim.signals.get_int(name)


# ---------------------------------------------------------------- old style, 3.x names
OLD_STYLE = """-- V-REP 3.2: the whole text runs at every call, sim_call_type says which
if (sim_call_type==sim_childscriptcall_initialization) then
    slider=simGetObjectHandle('Slider_joint')
    passes=0
    simSetIntegerSignal('init', simGetScriptExecutionCount())
    packed=simPackFloats({1.5, 2.5})
    simSetStringSignal('packed', packed)
    simSetIntegerSignal('or16', simBoolOr16(1, 4))
    simAddStatusbarMessage('old style up')
end
if (sim_call_type==sim_childscriptcall_actuation) then
    passes=passes+1
    simSetJointTargetVelocity(slider, 0.2)
    simSetIntegerSignal('actuation', passes)
end
if (sim_call_type==sim_childscriptcall_sensing) then
    local p=simGetObjectPosition(simGetObjectHandle('Slider'), -1)
    simSetFloatSignal('x', p[1])
    simSetIntegerSignal('sensing', passes)
end
if (sim_call_type==sim_childscriptcall_cleanup) then
    simSetIntegerSignal('cleanup', passes)
end
"""


def test_old_style_script_runs_its_text_per_call_type(run, caplog):
    sim = run({"Box": ("old.lua", OLD_STYLE)})
    with caplog.at_level(logging.INFO, logger="simx.scripts"):
        sim.start()
        steps(sim, 5)
    assert signal(sim, "init") == 0 and signal(sim, "actuation") == 5 and signal(sim, "sensing") == 5
    assert signal(sim, "or16") == 5
    assert sim.signals.get_string("packed") == b"\x00\x00\xc0?\x00\x00 @"
    assert sim.signals.get_float("x") > 0.001  # the slider moved under simSetJointTargetVelocity
    assert "old style up" in caplog.text
    script = next(iter(sim.scripts.scripts.values()))
    assert script.old_style
    sim.scripts.signals.clear_script_signals = lambda: None  # keep the cleanup's signal to read it
    sim.stop()
    assert signal(sim, "cleanup") == 5


def test_a_3x_function_simx_lacks_raises_an_error_naming_it(run):
    source = "function f(a, b, c, d)\n  simMoveToJointPositions({1}, {0}, 1)\nend\n" \
             "function g(a, b, c, d)\n  return {simROS == nil and 1 or 0, simUI.getSliderValue(1, 2)}\nend\n"
    sim = run({"Box": ("missing.lua", source)})
    sim.start()
    with pytest.raises(Exception, match=r"missing\.lua:2: simMoveToJointPositions is not available in simx"):
        call(sim, "Box", "f")
    assert call(sim, "Box", "g") == [[1, 0], [], [], b""]


CUSTOM_UI = """function sysCall_init()
    ui=simGetUIHandle('Control')
    simSetUIButtonLabel(ui, 3, 'Start')
    local b=simGetUIEventButton(ui)
    local h=simUI.create('<ui><button id="1" text="go"/></ui>')
    simUI.setLabelText(h, 1, 'x')
    sim.setIntegerSignal('ui', b)
    sim.setIntegerSignal('custom_init', 1)
end
function sysCall_beforeSimulation() sim.setIntegerSignal('before', 1) end
function sysCall_actuation() n=(n or 0)+1 sim.setIntegerSignal('custom_steps', n) end
function sysCall_afterSimulation() after=n end
function get(a, b, c, d) return {after} end
function sysCall_cleanup() sim.setIntegerSignal('custom_cleanup', 1) end
"""


def test_customization_script_lives_from_load_to_unload_and_ui_calls_are_no_ops(tmp_path, caplog):
    scene = small_scene(tmp_path, {"Box": ("custom.lua", CUSTOM_UI)})
    text = scene.read_text().replace('data="child_script=custom.lua', 'data="customization_script=custom.lua')
    scene.write_text(text)
    with caplog.at_level(logging.INFO, logger="simx.scripts"):
        sim = Simulation(scene, realtime=False)
    try:
        assert sim.signals.get_int("custom_init") == 1 and sim.signals.get_int("ui") == -1
        assert "simSetUIButtonLabel: a user-interface call, a no-op" in caplog.text
        sim.start()
        steps(sim, 3)
        assert sim.signals.get_int("before") == 1 and sim.signals.get_int("custom_steps") == 3
        sim.stop()
        sim.start()  # the same state across simulations: the count goes on
        steps(sim, 2)
        assert sim.signals.get_int("custom_steps") == 5
        sim.stop()
        assert sim.scripts.call("Box", 6, "get", [], [], [], b"") == [[5], [], [], b""]
    finally:
        sim.close()
    assert sim.signals.get_int("custom_cleanup") == 1


# ---------------------------------------------------------------- threads
THREAD_36 = """function sysCall_threadmain()
    sim.setThreadAutomaticSwitch(false)  -- else a sim call past the 2 ms time slice may yield
    local slider=sim.getObjectHandle('Slider_joint')
    for i=1,3 do
        sim.setIntegerSignal('loops', i)
        sim.switchThread()
    end
    local t0=sim.getSimulationTime()
    sim.wait(0.2)
    sim.setFloatSignal('waited', sim.getSimulationTime()-t0)
    sim.waitForSignal('go')
    sim.setIntegerSignal('got', 1)
    while sim.getSimulationState()~=sim.simulation_advancing_abouttostop do
        sim.setJointTargetVelocity(slider, 0.1)
        sim.switchThread()
    end
end
function sysCall_cleanup() sim.setIntegerSignal('cleaned', 1) end
"""


def test_sysCall_threadmain_runs_as_a_coroutine_one_resume_per_step(run):
    sim = run({"Box": ("thread.lua", THREAD_36)})
    sim.start()  # runs to the first switchThread
    assert signal(sim, "loops") == 1
    steps(sim, 2)
    assert signal(sim, "loops") == 3
    steps(sim, 6)  # 0.2 s of waiting at dt = 0.05
    assert sim.signals.get_float("waited") == pytest.approx(0.2, abs=1e-6)
    steps(sim, 3)
    assert signal(sim, "got") is None  # waiting for the signal
    sim.signals.set_int("go", 1)
    steps(sim, 2)
    assert signal(sim, "got") == 1
    sim.stop()  # the thread is dropped, the cleanup runs


THREADED_3X = """simSetThreadSwitchTiming(2)
simSetThreadAutomaticSwitch(true)
count=0
while (simGetSimulationState()~=sim_simulation_advancing_abouttostop) do
    count=count+1
    simSetIntegerSignal('count', count)
    simWait(0.1)
end
"""


def test_threaded_3x_script_runs_its_whole_text_as_a_thread(tmp_path):
    scene = small_scene(tmp_path, {"Box": ("t3.lua", THREADED_3X)}, settings="threaded=1 vrep_version=30200")
    sim = Simulation(scene, realtime=False)
    try:
        sim.start()
        assert sim.signals.get_int("count") == 1
        steps(sim, 10)  # resumed before each step, at t = 0 ... 0.45 s: a pass at 0, 0.1 ... 0.4 s
        assert sim.signals.get_int("count") == 5
    finally:
        sim.stop()
        sim.close()


def test_threaded_36_script_runs_its_text_then_its_threadmain_in_the_thread(tmp_path):
    # The V-REP 3.6 threaded kind (threaded=1); no automatic switch before the first pass is done.
    source = "simSetThreadAutomaticSwitch(false)\nsimSetIntegerSignal('top', 1)\n" + THREAD_36
    sim = Simulation(small_scene(tmp_path, {"Box": ("t36.lua", source)}, settings="threaded=1 vrep_version=30600"),
                     realtime=False)
    try:
        sim.start()
        assert sim.signals.get_int("top") == 1 and sim.signals.get_int("loops") == 1
        steps(sim, 2)
        assert sim.signals.get_int("loops") == 3
    finally:
        sim.stop()
        sim.close()


def test_a_thread_that_never_yields_is_interrupted_and_the_simulation_goes_on(tmp_path, caplog):
    source = "function sysCall_thread()\n  sim.setThreadAutomaticSwitch(false)\n  while true do local x=1 end\nend\n" \
             "function sysCall_actuation() n=(n or 0)+1 sim.setIntegerSignal('n', n) end\n"
    scene = small_scene(tmp_path, {"Box": ("spin.lua", source)}, settings="script_timeout=0.2")
    sim = Simulation(scene, realtime=False)
    try:
        sim.start()
        steps(sim, 3)
        assert sim.signals.get_int("n") == 3
        assert "interrupted" in caplog.text and "spin.lua:3" in caplog.text
    finally:
        sim.stop()
        sim.close()


def test_automatic_switching_yields_a_busy_loop_at_sim_calls(tmp_path):
    source = "function sysCall_thread()\n  sim.setThreadSwitchTiming(1)\n  local n=0\n" \
             "  while true do n=n+1 sim.setIntegerSignal('busy', n) end\nend\n"
    sim = Simulation(small_scene(tmp_path, {"Box": ("busy.lua", source)}), realtime=False)
    try:
        sim.start()
        first = sim.signals.get_int("busy")
        steps(sim, 2)
        assert first >= 1 and sim.signals.get_int("busy") > first  # yields and resumes, never overruns
    finally:
        sim.stop()
        sim.close()


def test_a_3x_thread_looping_without_a_switch_call_is_switched_and_other_scripts_run(tmp_path, caplog):
    # V-REP switches a threaded script when its slice ends, wherever it is (a C count hook that
    # yields): a loop that calls no sim function is not cut by the time bound but resumed each step.
    busy = "function count(a, b, c, d) return {n} end\nn=0\nwhile true do n=n+1 end\n"
    other = "function sysCall_actuation() k=(k or 0)+1 sim.setIntegerSignal('k', k) end\n"
    scene = small_scene(tmp_path, {"Busy": ("busy.lua", busy)}, settings="threaded=1 vrep_version=30200")
    (tmp_path / "other.lua").write_text(other)
    text = scene.read_text().replace(
        "</custom>", '<text name="simx:Other" data="child_script=other.lua"/></custom>').replace(
        "</worldbody>", '<body name="Other" pos="2 0 0"><geom type="box" size="0.01 0.01 0.01" '
        'contype="0" conaffinity="0"/></body></worldbody>')
    scene.write_text(text)
    sim = Simulation(scene, realtime=False)
    try:
        sim.start()
        counts = [call(sim, "Busy", "count")[0][0]]
        for _ in range(3):
            steps(sim, 1)
            counts.append(call(sim, "Busy", "count")[0][0])
        assert counts[0] > 0 and counts == sorted(set(counts))  # it runs again at every step
        assert sim.signals.get_int("k") == 3  # and the other script runs at every step too
        assert "interrupted" not in caplog.text
    finally:
        sim.stop()
        sim.close()


def test_script_simulation_parameters(tmp_path):
    (tmp_path / "params.json").write_text(
        '[{"name": "speed", "value": "0.25", "unit": "m/s"}, {"name": "mode", "value": "fast", "unit": ""}]')
    source = "function f(a, b, c, d)\n  local s=simGetScriptSimulationParameter(sim_handle_self, 'speed')\n" \
             "  local m=simGetScriptSimulationParameter(sim_handle_self, 'mode')\n" \
             "  local t=simGetScriptSimulationParameter(sim_handle_self, 'speed', true)\n" \
             "  local none=simGetScriptSimulationParameter(sim_handle_self, 'none')\n" \
             "  return {}, {s}, {m, t, tostring(none)}\nend\n"
    scene = small_scene(tmp_path, {"Box": ("p.lua", source)}, settings="script_parameters=params.json")
    sim = Simulation(scene, realtime=False)
    try:
        sim.start()
        assert call(sim, "Box", "f") == [[], [0.25], ["fast", "0.25", "nil"], b""]
    finally:
        sim.stop()
        sim.close()


def test_user_parameters_are_the_objects_script_parameters(tmp_path, caplog):
    # V-REP 3.x customization scripts call simSetUserParameter(sim_handle_self, '@enable', '') at
    # init; the values are the object's, which its scripts read as simulation parameters.
    custom = ("if (sim_call_type==sim_customizationscriptcall_initialization) then\n"
              "  simSetUserParameter(sim_handle_self, '@enable', '')\nend\n")
    child = ("function f(a, b, c, d)\n  simSetUserParameter(sim_handle_self, 'speed', 0.5)\n"
             "  local other = sim.getObjectHandle('Base')\n  sim.setUserParameter(other, 'tag', 'x')\n"
             "  return {}, {simGetScriptSimulationParameter(sim_handle_self, 'speed')},\n"
             "    {sim.getUserParameter(sim_handle_self, 'speed', true), sim.getUserParameter(other, 'tag'),\n"
             "     tostring(sim.getUserParameter(other, 'none')), sim.getUserParameter(sim_handle_self, 'exampleParameter')}\n"
             "end\n")
    scene = small_scene(tmp_path, {"Box": ("child.lua", child)})
    (tmp_path / "custom.lua").write_text(custom)
    scene.write_text(scene.read_text().replace("child_script=child.lua", "child_script=child.lua "
                                               "customization_script=custom.lua"))
    sim = Simulation(scene, realtime=False)
    try:
        with caplog.at_level(logging.ERROR, "simx.scripts"):
            sim.scripts.open()  # the customization script's init
            sim.start()
        assert not caplog.records, [r.getMessage() for r in caplog.records]
        assert call(sim, "Box", "f") == [[], [0.5], ["0.5", "x", "nil", "Hello World!"], b""]
    finally:
        sim.stop()
        sim.close()


def test_custom_data_blocks(run):
    source = "function f(a, b, c, d)\n  simWriteCustomDataBlock(sim_handle_self, 'tag', 'abc')\n" \
             "  local tags=simReadCustomDataBlockTags(sim_handle_self)\n" \
             "  return {}, {}, {simReadCustomDataBlock(sim_handle_self, 'tag'), tags[1]}\nend\n"
    sim = run({"Box": ("cd.lua", source)})
    sim.start()
    assert call(sim, "Box", "f") == [[], [], ["abc", "tag"], b""]


# ---------------------------------------------------------------- docs
def test_docs_list_every_3x_function_with_its_status_as_the_code_says():
    from conftest import ROOT
    from simx_server.api.legacy_names import DOC_BEGIN, DOC_END, doc_table
    from simx_server.scripts.threads import script_functions

    text = (ROOT / "docs" / "SCRIPTS.md").read_text()
    begin, end = text.index(DOC_BEGIN), text.index(DOC_END) + len(DOC_END)
    assert text[begin:end] == doc_table(script_functions()), \
        "docs/SCRIPTS.md's 3.x list is stale: run python scripts/gen_coverage.py"


ISSUE_NAMES = ("simGetObjectHandle", "simSetJointTargetVelocity", "simReadProximitySensor", "simGetObjectPosition",
               "simAddStatusbarMessage", "simGetScriptSimulationParameter", "simPackFloats", "simUnpackFloats",
               "simGetStringSignal", "simBoolOr16", "simGetObjectAssociatedWithScript", "simGetScriptExecutionCount",
               "simHandleChildScripts", "simSetScriptAttribute", "simWriteCustomDataBlock", "simReadCustomDataBlock",
               "simSwitchThread", "simSetThreadAutomaticSwitch", "simWait", "simWaitForSignal",
               "simSetThreadSwitchTiming", "simExtRemoteApiStart", "simResetDynamicObject", "simAddForceAndTorque")


def test_the_3x_functions_the_issue_names_run():
    from simx_server.api.legacy_names import status
    from simx_server.scripts.threads import script_functions

    functions = script_functions()
    assert {n: status(n, functions) for n in ISSUE_NAMES if status(n, functions) == "missing"} == {}


# ---------------------------------------------------------------- dynamics-step callbacks
JOINT_PID = """-- the RG2 centre joints' kind of controller: a PID in sysCall_jointCallback
function sysCall_init()
    sim.setJointTargetPosition(sim.getObjectHandle('Slider_joint'), 0.2)
    passes=0
end
function sysCall_jointCallback(inData)
    passes=passes+1
    sim.setIntegerSignal('passes', passes)
    sim.setIntegerSignal('total', inData.totalPasses)
    local v=inData.errorValue*20
    if v>0.5 then v=0.5 elseif v<-0.5 then v=-0.5 end
    return {force=5, velocity=v}
end
function sysCall_dynCallback(inData)
    if inData.afterStep then dyn=(dyn or 0)+1 sim.setIntegerSignal('dyn_after', dyn) end
end
"""


def test_joint_callback_controls_its_joint_at_every_substep(tmp_path):
    scene = small_scene(tmp_path, {})
    (tmp_path / "pid.lua").write_text(JOINT_PID)
    scene.write_text(scene.read_text().replace('data="mode=velocity max_velocity=1"',
                                               'data="mode=passive child_script=pid.lua"'))
    sim = Simulation(scene, realtime=False)
    try:
        sim.start()
        steps(sim, 40)  # 2 s
        q = sim.world.data.joint("Slider_joint").qpos[0]
        assert q == pytest.approx(0.2, abs=0.01)  # the script's controller brought it to its target
        substeps = sim.world.substeps
        assert substeps > 1 and signal(sim, "total") == substeps
        assert signal(sim, "passes") == 40 * substeps and signal(sim, "dyn_after") == 40 * substeps
    finally:
        sim.stop()
        sim.close()
    assert sim.world.substep_hook is None  # removed at stop


PY_THREAD = '''def sysCall_thread():
    n = 0
    while True:
        n += 1
        sim.setIntegerSignal("py_passes", n)
        sim.wait(0.1)
        if n == 3:
            sim.waitForSignal("py_go")
            sim.setIntegerSignal("py_got", 1)


def sysCall_cleanup():
    pass
'''


def test_python_script_thread_runs_as_a_coroutine(run):
    sim = run({"Box": ("thread.py", PY_THREAD)}, allow_python_scripts=True)
    sim.start()
    assert signal(sim, "py_passes") == 1
    steps(sim, 3)  # resumed before each step: at t = 0 and 0.05 still waiting, at 0.1 the second pass
    assert signal(sim, "py_passes") == 2
    steps(sim, 10)
    assert signal(sim, "py_passes") == 3 and signal(sim, "py_got") is None
    sim.signals.set_int("py_go", 1)
    steps(sim, 1)
    assert signal(sim, "py_got") == 1
    thread = next(iter(sim.scripts.scripts.values())).py_thread
    sim.stop()
    assert not thread.alive and not thread._thread.is_alive()  # ended with the simulation


def test_a_python_thread_that_never_yields_is_interrupted(tmp_path, caplog):
    source = "def sysCall_thread():\n    while True:\n        pass\n\n" \
             "def sysCall_actuation():\n    global n\n    n = globals().get('n', 0) + 1\n" \
             "    sim.setIntegerSignal('n', n)\n"
    sim = Simulation(small_scene(tmp_path, {"Box": ("spin.py", source)}, settings="script_timeout=0.2"),
                     realtime=False, allow_python_scripts=True)
    try:
        sim.start()
        steps(sim, 2)
        assert sim.signals.get_int("n") == 2 and "did not yield within 0.2 s" in caplog.text
    finally:
        sim.stop()
        sim.close()


def test_getObjectHandle_of_a_copy_finds_the_objects_of_the_same_copy(tmp_path):
    source = "function f(a, b, c, d)\n  local s, n = simGetNameSuffix(nil)\n" \
             "  local mine = simGetObjectHandle('Part')\n  local plain = simGetObjectHandle('Part#')\n" \
             "  simSetNameSuffix(-1)\n  local again = simGetObjectHandle('Part')\n" \
             "  return {s, mine, plain, again}, {}, {n}\nend\n"
    scene = small_scene(tmp_path, {"Robot#0": ("r.lua", source), "Part": ("p.lua", ""), "Part#0": ("p0.lua", "")})
    sim = Simulation(scene, realtime=False)
    try:
        sim.start()
        part, part0 = sim.world.resolve("Part").handle, sim.world.resolve("Part#0").handle
        assert call(sim, "Robot#0", "f") == [[0, part0, part, part], [], ["Robot"], b""]
    finally:
        sim.stop()
        sim.close()


def test_an_error_in_a_thread_is_logged_with_its_line_and_ends_the_thread(tmp_path, caplog):
    source = "function sysCall_thread()\n  sim.switchThread()\n  local x = nil\n  return x.field\nend\n" \
             "function sysCall_actuation() n=(n or 0)+1 sim.setIntegerSignal('n', n) end\n"
    sim = Simulation(small_scene(tmp_path, {"Box": ("bad.lua", source)}), realtime=False)
    try:
        sim.start()
        steps(sim, 3)
        script = next(iter(sim.scripts.scripts.values()))
        assert sim.signals.get_int("n") == 3 and not script._thread_alive()
        errors = [r.getMessage() for r in caplog.records if r.levelno >= logging.ERROR]
        assert len(errors) == 1 and "bad.lua:4: attempt to index a nil value" in errors[0], errors
    finally:
        sim.stop()
        sim.close()
