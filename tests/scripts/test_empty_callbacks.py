"""Life-cycle callbacks without code (V-REP's child-script template leaves ``sysCall_actuation``
and ``sysCall_sensing`` empty, with comments) are not called: a call would change nothing and
each costs the scripts' budget bookkeeping (about 50 µs; PyRep's Panda and its gripper bring two
such scripts, four calls a step). Everything else is called as before, and the execution count
(``sim.getScriptExecutionCount``) counts the skipped ones as V-REP counts them."""

from __future__ import annotations

import pytest

from simx_server.scene.simulation import Simulation

pytestmark = pytest.mark.renderers_on_demand

SCENE = ('<mujoco><worldbody><body name="Box"><geom type="box" size="0.1 0.1 0.1"/></body></worldbody>'
         '<custom><text name="simx:Box" data="child_script=box.lua"/></custom></mujoco>')

SCRIPT = """function sysCall_init()
    n, m = 0, 0
end

function sysCall_actuation()
    -- put your actuation code here
    --[[ a block comment
         over lines ]]
end

function sysCall_sensing()
    n = n + 1 end

function countSensing() return {n} end

function becomeBusy()
    sysCall_actuation = function()
        m = m + 1
    end
end

function countActuation() return {m} end
"""


@pytest.fixture
def sim(tmp_path):
    (tmp_path / "scene.xml").write_text(SCENE)
    (tmp_path / "box.lua").write_text(SCRIPT)
    s = Simulation(tmp_path / "scene.xml", realtime=False)
    s.start()
    yield s
    s.stop()
    s.close()


def _call(sim, function):
    ints, _, _, _ = sim.scripts.call("Box", 1, function, [], [], [], b"")  # 1: sim_scripttype_childscript
    return ints[0]


def test_an_empty_callback_is_not_called_and_one_with_code_on_its_last_line_is(sim):
    script = sim.scripts.scripts[sim.world.resolve("Box").handle]
    assert script._body("sysCall_actuation") == 1 and script._body("sysCall_sensing") == 2
    assert script._body("sysCall_init") == 2 and script._body("sysCall_nothing") == 0
    before = script.executions
    for _ in range(3):
        sim.step()
    assert _call(sim, "countSensing") == 3  # "n = n + 1 end": code on the last line, called
    assert script.executions - before == 6  # both step functions of 3 steps counted


def test_a_callback_given_code_at_run_time_is_called_from_then_on(sim):
    sim.step()
    assert _call(sim, "countActuation") == 0
    sim.scripts.call("Box", 1, "becomeBusy", [], [], [], b"")
    for _ in range(2):
        sim.step()
    assert _call(sim, "countActuation") == 2


def test_what_a_script_defines_is_looked_up_again_after_any_of_its_code_ran(tmp_path):
    """Which callbacks have code is asked of Lua once and kept (no Lua call per script and step)
    until code of the script runs: its own thread or callback may give a callback code, empty
    it, or end the thread, and the next step follows."""
    (tmp_path / "scene.xml").write_text(SCENE)
    (tmp_path / "box.lua").write_text("""function sysCall_init() n, a, t = 0, 0, 0 end
function sysCall_thread()
    for i = 1, 2 do t = t + 1; sim.switchThread() end
end
function sysCall_actuation()
end
function sysCall_sensing()
    n = n + 1
    if n == 2 then sysCall_actuation = function() a = a + 1 end end
    if n == 4 then sysCall_actuation = nil end
end
function counts() return {n, a, t} end
""")
    s = Simulation(tmp_path / "scene.xml", realtime=False)
    try:
        s.start()
        script = s.scripts.scripts[s.world.resolve("Box").handle]
        alive = []
        for _ in range(6):
            s.step()
            alive.append(script._thread_alive())
        ints, _, _, _ = s.scripts.call("Box", 1, "counts", [], [], [], b"")
        # actuation had code in steps 3 and 4 (given in step 2's sensing, removed in step 4's)
        assert ints == [6, 2, 2]
        assert alive == [True, False, False, False, False, False]
        assert script._body("sysCall_actuation") == 0
    finally:
        s.stop()
        s.close()
