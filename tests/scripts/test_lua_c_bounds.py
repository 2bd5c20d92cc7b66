"""Issue 40: Lua time bounds that hold inside C (simx_server/scripts/lua_bounds.py).

Patterns that backtrack (``?`` included) are refused before the matcher runs; ``string.rep``,
``table.move``, ``table.concat`` and ``table.sort`` of many elements run where the script's time
bound reaches them; a loop of string copies is interrupted by the collector's checks. In child,
customization and threaded scripts alike, in-process; and against a real server, whose clients
are served after a threaded script ran the issue's pattern."""

from __future__ import annotations

import logging

import pytest

import vrep
from conftest import ServerProcess, wait_until
from simx_client.protocol import ScriptError
from simx_server.scene.simulation import Simulation
from simx_server.scripts.child import ScriptTimeoutError

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here

CHILD = vrep.sim_scripttype_childscript
CUSTOM = vrep.sim_scripttype_customizationscript
#: The issue's freeze: 2^34 ways for the optional items, each tried on 35 starting points.
FREEZE = 'string.find(("a"):rep(34), ("a?"):rep(34) .. ("a"):rep(34))'


def scene(tmp_path, script: str, kind: str = "child_script", settings: str = "") -> Simulation:
    (tmp_path / "box.lua").write_text(script)
    (tmp_path / "scene.xml").write_text(f"""<mujoco model="c bounds">
  <worldbody><body name="Box"><geom type="box" size="0.1 0.1 0.1"/></body></worldbody>
  <custom><text name="simx:Box" data="{kind}=box.lua {settings}"/></custom>
</mujoco>
""")
    return Simulation(tmp_path / "scene.xml", dt=0.05, realtime=False)


CALLS = r"""
function run(i, f, s, b)
  local r = {load(s[1])()}
  for k = 1, #r do r[k] = tostring(r[k]) end
  return {}, {}, r, ""
end
function fill(i, f, s, b)  -- big[1 .. i[1]] = descending numbers, i[2] per call
  big = big or {}
  local n = #big
  for k = n + 1, math.min(i[1], n + i[2]) do big[k] = -k end
  return {#big}, {}, {}, ""
end
function sortBig(i, f, s, b)
  phase = "sorting"
  table.sort(big)
  phase = "sorted"
  return {}, {}, {}, ""
end
function getPhase(i, f, s, b) return {}, {}, {phase or "none"}, "" end
"""


@pytest.fixture
def child(tmp_path):
    sim = scene(tmp_path, CALLS, settings="script_timeout=0.5")
    sim.scripts.allow_remote_code = True
    for script in sim.scripts.scripts.values():
        script.allow_remote_code = True  # load() for the tests' snippets
    sim.start()
    yield sim
    sim.close()


def run(sim, code: str, kind=CHILD) -> list[str]:
    return sim.scripts.call("Box", kind, "run", [], [], [code], b"")[2]


@pytest.mark.parametrize("pattern, subject", [
    ('("a?"):rep(34) .. ("a"):rep(34)', '("a"):rep(34)'),  # the issue's: optional items
    ('".-.-.-b"', '("a"):rep(1000)'),  # lazy repetitions
    ('"(a*)*b"', '("a"):rep(100000)'),  # nested-looking greedy: * of a capture is literal '*'
    ('".*b"', '("a"):rep(100000)'),  # one repetition tried from every start: n^2
    ('"(.+)%1%1b"', '("a"):rep(100000)'),  # back-references
])
@pytest.mark.parametrize("function", ["find", "match", "gmatch", "gsub"])
def test_backtracking_patterns_are_refused_naming_the_bound(child, function, pattern, subject):
    extra = ', ""' if function == "gsub" else ""
    with pytest.raises(ScriptError, match=rf"string\.{function}: a pattern of \d+ bytes on \d+ bytes is refused"
                                          r".*limits\.MAX_PATTERN_WORK"):
        run(child, f"return string.{function}({subject}, {pattern}{extra})")
    with pytest.raises(ScriptError, match=r"MAX_PATTERN_WORK"):  # as a string method too
        run(child, f"return ({subject}):{function}({pattern}{extra})")


def test_ordinary_patterns_and_plain_searches_still_work(child):
    assert run(child, 'return ("  trim me  "):match("^%s*(.-)%s*$")') == ["trim me"]
    assert run(child, 'return string.find("joint_12#3", "_(%d+)#(%d)")') == ["6", "10", "12", "3"]
    assert run(child, 'return ("a,b,,c"):gsub(",", ";")') == ["a;b;;c", "3"]
    assert run(child, 'local n = 0 for w in ("x y z"):gmatch("%a") do n = n + 1 end return n') == ["3"]
    assert run(child, 'return ("f(a(b)c)d"):match("%b()")') == ["(a(b)c)"]
    big = '("a"):rep(1000000)'
    assert run(child, f'return string.find({big} .. "b", ("a"):rep(100) .. "b", 1, true)') == ["999901", "1000001"]
    assert run(child, f'return string.find({big}, "b") == nil') == ["true"]  # a byte search, no backtracking


def test_the_refusal_is_a_lua_error_the_script_can_catch(child):
    ok, message = run(child, f"return pcall(function() return {FREEZE} end)")
    assert ok == "false" and "MAX_PATTERN_WORK" in message


def test_string_rep_of_an_empty_string_many_times_is_immediate_and_long_results_are_exact(child):
    assert run(child, 'return #string.rep("", 2^62), #string.rep("", 2^62, "")') == ["0", "0"]
    assert run(child, 'local s = string.rep("ab", 1100001, ",") return #s, s:sub(1, 5), s:sub(-5)') == [
        "3300002", "ab,ab", "ab,ab"]
    assert run(child, 'local t = {} for i = 1, 1100001 do t[i] = "ab" end '
                      'return string.rep("ab", 1100001, ",") == table.concat(t, ",")') == ["true"]
    with pytest.raises(ScriptError, match=r"not enough memory|out of memory|too large"):
        run(child, 'return #string.rep("x", 2^40)')  # refused at its first allocation


def test_table_move_of_2_62_slots_is_interrupted_and_long_moves_are_exact(child):
    with pytest.raises(ScriptTimeoutError, match=r"interrupted: did not return within 0\.5 s"):
        run(child, "table.move({}, 1, 2^62, 1, {})")
    with pytest.raises(ScriptTimeoutError, match=r"interrupted"):  # C's own check lets this one through
        run(child, "table.move({}, -2^62, 2^61, 1, {})")
    with pytest.raises(ScriptError, match=r"too many elements to move"):  # and refuses this one, as before
        run(child, "table.move({}, -2^62, 2^62, 1, {})")
    assert run(child, "local t = {} for i = 1, 1.2e6 do t[i] = i end table.move(t, 1, 1.2e6, 2) "
                      "return t[1], t[2], t[1.2e6 + 1]") == ["1", "1", "1200000"]  # overlapping: backwards
    assert run(child, "local t = {} for i = 1, 1.2e6 do t[i] = i end table.move(t, 2, 1.2e6, 1) "
                      "return t[1], t[1.2e6 - 1], t[1.2e6]") == ["2", "1200000", "1200000"]
    assert run(child, "return run ~= nil") == ["true"]  # the script is still usable


def test_a_big_sort_runs_where_the_time_bound_reaches_it(child):
    """4 M numbers: a few seconds of sorting, in C one call out of the bound's reach; here it is
    interrupted inside the sort (its phase stays "sorting"), and a small sort still works."""
    while child.scripts.call("Box", CHILD, "fill", [4_000_000, 500_000], [], [], b"")[0][0] < 4_000_000:
        pass
    with pytest.raises(ScriptTimeoutError, match=r"interrupted"):
        child.scripts.call("Box", CHILD, "sortBig", [], [], [], b"")
    assert child.scripts.call("Box", CHILD, "getPhase", [], [], [], b"")[2] == ["sorting"]
    assert run(child, "local t = {3, 1, 2} table.sort(t) return t[1], t[2], t[3]") == ["1", "2", "3"]


def test_a_loop_of_long_string_copies_is_interrupted(child):
    with pytest.raises(ScriptTimeoutError, match=r"interrupted"):
        run(child, 'local s = ("a"):rep(2^26) while true do local t = s .. "x" end')
    with pytest.raises(ScriptTimeoutError, match=r"interrupted"):
        run(child, 'collectgarbage("stop") local s = ("a"):rep(2^25) while true do local t = s .. "x" end')
    with pytest.raises(ScriptTimeoutError, match=r"interrupted"):
        run(child, 'local s = ("a"):rep(2^24) while true do local u = s:upper() end')


def test_a_customization_script_is_bounded_alike(tmp_path, caplog):
    with caplog.at_level(logging.ERROR, "simx.scripts"):
        sim = scene(tmp_path, f"function sysCall_init() {FREEZE} end\nfunction sysCall_nonSimulation() "
                              "table.move({}, 1, 2^62, 1, {}) end", kind="customization_script",
                    settings="script_timeout=0.2")
        try:
            sim.scripts.idle()
        finally:
            sim.close()
    lines = [r.getMessage() for r in caplog.records]
    assert any("customization script box.lua of 'Box', sysCall_init" in m and "MAX_PATTERN_WORK" in m
               for m in lines), lines
    assert any("sysCall_nonSimulation: interrupted" in m for m in lines), lines


def test_a_threaded_script_is_bounded_alike_and_the_simulation_goes_on(tmp_path, caplog):
    script = f"""function sysCall_thread()
  sim.setInt32Signal("reached", 1)
  sim.switchThread()
  {FREEZE}
  sim.setInt32Signal("after", 1)
end"""
    with caplog.at_level(logging.ERROR, "simx.scripts"):
        sim = scene(tmp_path, script)
        try:
            sim.start()
            for _ in range(3):
                sim.step()
            assert sim.signals.get_int("reached") == 1 and sim.signals.get_int("after") is None
        finally:
            sim.close()
    assert any("child script box.lua of 'Box', thread: box.lua:4: string.find" in r.getMessage()
               and "MAX_PATTERN_WORK" in r.getMessage() for r in caplog.records), caplog.text


def test_the_issues_pattern_in_a_threaded_scene_script_leaves_the_clients_served(tmp_path):
    (tmp_path / "box.lua").write_text(f"function sysCall_thread()\n  while true do {FREEZE} end\nend\n")
    (tmp_path / "scene.xml").write_text("""<mujoco model="c bounds">
  <worldbody><body name="Box"><geom type="box" size="0.1 0.1 0.1"/></body></worldbody>
  <custom><text name="simx:Box" data="child_script=box.lua"/></custom>
</mujoco>
""")
    srv = ServerProcess(str(tmp_path / "scene.xml"), "--pacing", "immediate", renderers="on-demand")
    cid = vrep.simxStart("127.0.0.1", srv.port, True, True, 5000, 5)
    try:
        assert cid >= 0
        assert vrep.simxStartSimulation(cid, vrep.simx_opmode_blocking) == 0
        wait_until(lambda: "MAX_PATTERN_WORK" in srv.log_so_far(), what="the refusal in the log")
        for _ in range(5):  # the simulation thread serves
            rc, handle = vrep.simxGetObjectHandle(cid, "Box", vrep.simx_opmode_blocking)
            assert rc == 0 and handle >= 0
        assert srv.proc.poll() is None
        line = next(x for x in srv.log_so_far().splitlines() if "MAX_PATTERN_WORK" in x)
        assert "child script box.lua of 'Box'" in line
    finally:
        vrep.simxFinish(cid)
        srv.stop()
