"""Issues 40 and 48: a budget for all of a scene's scripts together (simx_server/scripts/budget.py).

30 scripts, each within its own 1 s and 256 MiB, made one step take 30 s and 2 GB. Now a pass
of the simulation thread (a start, a step, an idle pass) gives all scripts together
limits.MAX_SCRIPTS_STEP_TIME of CPU: the script running when it ends is interrupted and named with
the bound, the scripts after it wait for the next pass, and every overrunning script has its step
functions skipped until the next start. Their Lua states hold limits.MAX_SCRIPTS_MEMORY together.

Four scripts at 0.6 s each, within that bound, made every step take 2 s for as long as the scene
ran, and a sysCall_dynCallback at 0.15 s a call ran outside it (7.5 s a step). Now every callback
counts, and the scripts share limits.SCRIPTS_SHARE of the server's CPU time over
limits.SCRIPTS_SHARE_WINDOW beyond limits.SCRIPTS_PASS_ALLOWANCE a pass: the script that passes it
is named and its callbacks are skipped until the next start.

The in-process tests shrink the budget (CPU time, so the outcome is the same on any machine; the
share's window runs on a clock the test holds still)."""

from __future__ import annotations

import logging
import re
from pathlib import Path

import pytest

import vrep
from conftest import ServerProcess, wait_until
from simx_server.base import limits as L
from simx_server.scene.simulation import Simulation
from simx_server.scripts.budget import ScriptBudget

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here

BURN = """function sysCall_init() sim.setInt32Signal("init_" .. NAME, 1) end
function sysCall_actuation()
  sim.setInt32Signal("ran_" .. NAME, (sim.getInt32Signal("ran_" .. NAME) or 0) + 1)
  while true do end
end
"""


def many(tmp_path, n: int, script: str, settings: str = "") -> Path:
    bodies, texts = [], []
    for i in range(n):
        name = f"S{i}"
        (tmp_path / f"s{i}.lua").write_text(f'local NAME = "{name}"\n' + script)
        bodies.append(f'<body name="{name}" pos="{i} 0 0"><geom type="box" size="0.1 0.1 0.1"/></body>')
        texts.append(f'<text name="simx:{name}" data="child_script=s{i}.lua {settings}"/>')
    (tmp_path / "scene.xml").write_text(f"""<mujoco model="many scripts">
  <worldbody>{"".join(bodies)}</worldbody>
  <custom>{"".join(texts)}</custom>
</mujoco>
""")
    return tmp_path / "scene.xml"


def test_the_scripts_share_one_budget_per_step_and_the_overrunning_one_is_named(tmp_path, caplog):
    """6 endless scripts of 0.2 s each, 0.3 s per pass: each step interrupts one at its own bound
    and the next at the pass's end; the others wait for the next step. After 3 steps all six
    have been interrupted once, in order, and their step functions are skipped."""
    sim = Simulation(many(tmp_path, 6, BURN, "script_timeout=0.2"), realtime=False)
    sim.scripts.budget.seconds = 0.3
    try:
        with caplog.at_level(logging.ERROR, "simx.scripts"):
            sim.start()
            for _ in range(4):
                sim.step()
        ran = [sim.signals.get_int(f"ran_S{i}") for i in range(6)]
        assert ran == [1] * 6, ran  # each ran once, then was skipped
        assert all(sim.signals.get_int(f"init_S{i}") == 1 for i in range(6))
    finally:
        sim.close()
    lines = [r.getMessage() for r in caplog.records if "sysCall_actuation" in r.getMessage()]
    named = [re.search(r"of 'S(\d)'", m).group(1) for m in lines]
    assert named == ["0", "1", "2", "3", "4", "5"], lines
    own = [m for m in lines if "did not return within 0.2 s (script_timeout)" in m]
    by_pass = [m for m in lines if "used up their 0.3 s of this pass (limits.MAX_SCRIPTS_STEP_TIME)" in m]
    assert len(own) == 3 and len(by_pass) == 3, lines
    assert all("skipped until the simulation restarts" in m for m in lines)


def test_a_pass_shares_its_time_between_actuation_and_sensing(tmp_path, caplog):
    script = """function sysCall_actuation() end
function sysCall_sensing() sim.setInt32Signal("sensed_" .. NAME, 1) while true do end end
"""
    sim = Simulation(many(tmp_path, 3, script, "script_timeout=0.2"), realtime=False)
    sim.scripts.budget.seconds = 0.3
    try:
        with caplog.at_level(logging.ERROR, "simx.scripts"):
            sim.start()
            sim.step()
        assert [sim.signals.get_int(f"sensed_S{i}") for i in range(3)] == [1, 1, None]
    finally:
        sim.close()


def test_the_lua_states_hold_the_memory_budget_together(tmp_path, caplog):
    script = """function sysCall_init()
  hoard = string.rep("x", 32 * 1024 * 1024)  -- 32 MiB kept (64 MiB while it is made)
  sim.setInt32Signal("kept_" .. NAME, 1)
end
"""
    sim = Simulation(many(tmp_path, 4, script), realtime=False)
    # room for three states (a few MiB each) and their hoards, not for the fourth's 64 MiB while it is made
    sim.scripts.budget.memory = (4 * 32 + 16 + 3 * 3) << 20
    try:
        with caplog.at_level(logging.ERROR, "simx.scripts"):
            sim.start()
        assert [sim.signals.get_int(f"kept_S{i}") for i in range(4)] == [1, 1, 1, None]
        assert sum(s.memory_used() for s in sim.scripts.scripts.values()) <= sim.scripts.budget.memory
    finally:
        sim.close()
    line = next(r.getMessage() for r in caplog.records if "MAX_SCRIPTS_MEMORY" in r.getMessage())
    assert line.startswith("child script s3.lua of 'S3', sysCall_init: out of memory (the scene's Lua scripts "
                           "hold at most 153 MiB together"), line


def test_the_default_budget():
    assert L.MAX_SCRIPTS_STEP_TIME == 2.0 and L.MAX_SCRIPTS_MEMORY == 512 << 20
    assert (L.SCRIPTS_SHARE, L.SCRIPTS_SHARE_WINDOW, L.SCRIPTS_PASS_ALLOWANCE) == (0.5, 10.0, 0.1)


OVERRUN = re.compile(r"^.*sysCall_actuation: s\d+\.lua:\d+: interrupted.*$", re.M)


def test_many_burning_scripts_leave_the_clients_served(tmp_path):
    """10 endless scripts of 0.3 s each: at most the default 2 s of scripts' CPU per step (not 3 s);
    a client's calls are answered in between, and each script is named once in the log. (The
    client waits up to 60 s for a reply: a busy machine stretches the steps' 2 s of CPU.)"""
    scene = many(tmp_path, 10, BURN, "script_timeout=0.3")
    srv = ServerProcess(str(scene), "--stopped", "--pacing", "immediate", renderers="on-demand")
    cid = vrep.simxStart("127.0.0.1", srv.port, True, True, -60000, 5)  # blocking calls: 60 s
    try:
        assert cid >= 0 and vrep.simxStartSimulation(cid, vrep.simx_opmode_blocking) == 0
        answered = 0
        for _ in range(10):
            rc, _handle = vrep.simxGetObjectHandle(cid, "S0", vrep.simx_opmode_blocking)
            answered += rc == 0
        assert answered == 10
        wait_until(lambda: len(OVERRUN.findall(srv.log_so_far())) == 10, timeout=120,
                   what="every script interrupted once")
        rc, _handle = vrep.simxGetObjectHandle(cid, "S9", vrep.simx_opmode_blocking)
        assert rc == 0 and srv.proc.poll() is None
    finally:
        vrep.simxFinish(cid)
        log = srv.stop()
    lines = OVERRUN.findall(log)
    assert len(lines) == 10 and any("limits.MAX_SCRIPTS_STEP_TIME" in x for x in lines), lines


# ---------------------------------------------------------------- the scripts' share over time
def frozen_share(sim: Simulation, room: float, allowance: float = 0.01) -> None:
    """The scripts may take ``allowance`` s a pass, and ``room`` s beyond it in all, on a clock
    that stands still (nothing leaves the window); the pass's end is out of the way."""
    budget = sim.scripts.budget
    budget.seconds, budget.allowance, budget.clock = 10.0, allowance, lambda: 0.0
    budget.window, budget.share = 1000.0, room / 1000.0


def named(records, what: str = "") -> list[tuple[str, str]]:
    """(object, bound) of each overrun logged: bound "pass", "share" or "own"."""
    out = []
    for r in records:
        m = r.getMessage()
        hit = re.search(r"of '(\w+)', \w+: .*interrupted", m)
        if hit and what in m:
            bound = "pass" if "MAX_SCRIPTS_STEP_TIME" in m else "share" if "SCRIPTS_SHARE" in m else "own"
            out.append((hit.group(1), bound))
    return out


SPEND = """function sysCall_actuation()
  sim.setInt32Signal("ran_" .. NAME, (sim.getInt32Signal("ran_" .. NAME) or 0) + 1)
  local t = os.clock() while os.clock() - t < SECONDS do end
end
"""


def test_the_share_window_counts_what_passes_took_beyond_their_allowance():
    now = [0.0]
    budget = ScriptBudget(seconds=10.0, share=0.5, window=4.0, allowance=0.1, clock=lambda: now[0])
    with budget.pass_of("step") as step:
        assert step.allowance == pytest.approx(0.1 + 2.0)  # all of the share is left
        step.used = 1.1
    assert budget.taken() == pytest.approx(1.0)  # only what passed the allowance
    now[0] = 1.0
    with budget.pass_of("step") as step:
        assert step.allowance == pytest.approx(0.1 + 1.0)
        step.used = 0.05  # a short pass is not charged
    with budget.pass_of("step") as step:
        step.used = 0.6
    assert budget.taken() == pytest.approx(1.5)
    now[0] = 4.5  # the first charge has left the window, the last has not
    assert budget.taken() == pytest.approx(0.5)
    with budget.pass_of("step") as step:
        step.used = 1.9  # past the share: the next pass gets its allowance only
    with budget.pass_of("step") as step:
        assert step.allowance == pytest.approx(0.1)


def test_scripts_within_every_pass_are_cut_once_they_have_taken_their_share(tmp_path, caplog):
    """Four scripts of about 0.05 s each a pass, far within the pass's bound: the first passes
    run them all; once they have taken their share, each pass has its allowance only, and the
    script running past it is named, by the share, and skipped from then on, until none runs."""
    script = SPEND.replace("SECONDS", "0.05")
    sim = Simulation(many(tmp_path, 4, script), realtime=False)
    frozen_share(sim, room=0.5)
    try:
        with caplog.at_level(logging.ERROR, "simx.scripts"):
            sim.start()
            sim.step()
            assert [sim.signals.get_int(f"ran_S{i}") for i in range(4)] == [1] * 4 and not named(caplog.records)
            for _ in range(12):
                sim.step()
                if len(named(caplog.records)) == 4:
                    break
            ran = [sim.signals.get_int(f"ran_S{i}") for i in range(4)]
            steps = sim.steps
            for _ in range(3):
                sim.step()
            assert [sim.signals.get_int(f"ran_S{i}") for i in range(4)] == ran  # none runs any more
        assert steps > 2  # the share spans passes: no pass alone was cut
    finally:
        sim.close()
    cut = named(caplog.records)
    assert sorted(cut) == [(f"S{i}", "share") for i in range(4)], cut
    lines = [r.getMessage() for r in caplog.records if "SCRIPTS_SHARE" in r.getMessage()]
    assert all("its callbacks are skipped until the simulation restarts" in m for m in lines), lines


DYN = """function sysCall_dynCallback(inData)
  n = (n or 0) + 1
  sim.setInt32Signal("dyn", n)
  while true do end
end
function sysCall_sensing() sim.setInt32Signal("sensed", 1) end
"""


@pytest.mark.parametrize("bound", ["pass", "share"])
def test_a_dyn_callback_that_spends_each_substep_is_counted_and_cut(tmp_path, caplog, bound):
    """A sysCall_dynCallback interrupted at its own 0.15 s each call (50 calls a step: 7.5 s a
    step before) counts toward the step's pass: the fourth call passes 0.5 s of scripts' time,
    the script is named and its callbacks are skipped; the simulation goes on."""
    sim = Simulation(many(tmp_path, 1, DYN, "script_timeout=0.15"), realtime=False)
    if bound == "pass":
        sim.scripts.budget.seconds = 0.5
    else:
        frozen_share(sim, room=0.49)
    try:
        with caplog.at_level(logging.ERROR, "simx.scripts"):
            sim.start()
            assert sim.world.substeps == 25
            for _ in range(4):
                sim.step()
        assert sim.signals.get_int("dyn") == 4 and sim.signals.get_int("sensed") is None
        assert sim.world.time == pytest.approx(4 * sim.world.dt)
    finally:
        sim.close()
    assert named(caplog.records, "sysCall_dynCallback")[-1] == ("S0", bound)
    assert [b for _, b in named(caplog.records)].count(bound) == 1


CALLBACK_SCENE = """<mujoco model="callbacks">
  <option timestep="0.002"/>
  <worldbody>
    <geom name="Floor" type="plane" size="2 2 0.1"/>
    <body name="Crate" pos="0 0 0.05"><freejoint/><geom type="box" size="0.05 0.05 0.05" mass="0.2"/></body>
    <body name="Base" pos="1 0 0.1">
      <body name="Slider" pos="0 0 0.05">
        <joint name="Slider_joint" type="slide" axis="1 0 0" range="-0.5 0.5" damping="1"/>
        <geom type="box" size="0.02 0.02 0.02" mass="0.1" contype="0" conaffinity="0"/>
      </body>
    </body>
  </worldbody>
  <actuator><velocity name="Slider_motor" joint="Slider_joint" kv="100" forcerange="-5 5"/></actuator>
  <custom><text name="simx:Slider_joint" data="mode=passive {kind}=burn.lua script_timeout=5"/></custom>
</mujoco>
"""
BUMP = 'n = (n or 0) + 1 sim.setInt32Signal("n", n) while true do end'


@pytest.mark.parametrize("kind,function", [
    ("child_script", "sysCall_actuation"), ("child_script", "sysCall_sensing"),
    ("child_script", "sysCall_thread"), ("child_script", "sysCall_jointCallback"),
    ("child_script", "sysCall_contactCallback"), ("customization_script", "sysCall_actuation"),
    ("customization_script", "sysCall_nonSimulation")])
def test_every_callback_counts_toward_the_scripts_share(tmp_path, caplog, kind, function):
    """Each kind of callback, looping within its own 5 s: the share (0.3 s) interrupts it, names
    the script and skips it from then on; the simulation goes on."""
    # a thread would be switched at the end of its slice: it burns with automatic switching off
    no_switch = "sim.setThreadAutomaticSwitch(false) " if function == "sysCall_thread" else ""
    (tmp_path / "burn.lua").write_text(f"function {function}(inData) {no_switch}{BUMP} end\n")
    (tmp_path / "scene.xml").write_text(CALLBACK_SCENE.format(kind=kind))
    sim = Simulation(tmp_path / "scene.xml", realtime=False)
    frozen_share(sim, room=0.3)
    try:
        with caplog.at_level(logging.ERROR, "simx.scripts"):
            sim.scripts.open()
            for _ in range(3):
                if function == "sysCall_nonSimulation":
                    sim.scripts.idle()
                else:
                    sim.step() if sim.steps else (sim.start(), sim.step())
        assert sim.signals.get_int("n") == 1
        assert function == "sysCall_nonSimulation" or sim.steps == 3
    finally:
        sim.close()
    assert named(caplog.records) == [("Slider_joint", "share")], [r.getMessage() for r in caplog.records]


def test_four_scripts_spending_each_pass_are_cut_and_the_clients_served(tmp_path):
    """Issue 48's reproduction on a server, with the default bounds: four scripts at 0.6 s each
    (a 2 s step, every step). The pass's end cuts the fourth; then the share cuts the others, one
    a pass; every client call is answered meanwhile, and once all are cut no script runs. (The
    client waits up to 60 s for a reply: a busy machine stretches the passes' CPU time.)"""
    scene = many(tmp_path, 4, SPEND.replace("SECONDS", "0.6"))
    srv = ServerProcess(str(scene), "--stopped", renderers="on-demand")
    cid = vrep.simxStart("127.0.0.1", srv.port, True, True, -60000, 5)  # blocking calls: 60 s
    try:
        assert cid >= 0 and vrep.simxStartSimulation(cid, vrep.simx_opmode_blocking) == 0
        calls = answered = 0
        while len(OVERRUN.findall(srv.log_so_far())) < 4 and calls < 40:
            rc, _handle = vrep.simxGetObjectHandle(cid, "S0", vrep.simx_opmode_blocking)
            calls, answered = calls + 1, answered + (rc == 0)
        assert answered == calls and calls < 40
        ran = [vrep.simxGetIntegerSignal(cid, f"ran_S{i}", vrep.simx_opmode_blocking) for i in range(4)]
        for _ in range(3):  # three more steps (a blocking call sees a new step each)
            vrep.simxGetObjectHandle(cid, "S0", vrep.simx_opmode_blocking)
        again = [vrep.simxGetIntegerSignal(cid, f"ran_S{i}", vrep.simx_opmode_blocking) for i in range(4)]
        assert again == ran and all(rc == 0 for rc, _ in ran), (ran, again)
    finally:
        vrep.simxFinish(cid)
        log = srv.stop()
    lines = OVERRUN.findall(log)
    who = sorted(re.search(r"of 'S(\d)'", x).group(1) for x in lines)
    assert who == ["0", "1", "2", "3"], lines
    assert sum("limits.SCRIPTS_SHARE" in x for x in lines) >= 2, lines
    assert all("its callbacks are skipped until the simulation restarts" in x for x in lines), lines


def test_threads_take_turns_within_the_passes_allowance(tmp_path):
    """Issue 84: 200 auto-switched threaded scripts made every pass resume every thread (200 x
    its 2 ms slice), and other clients' calls waited 2.8 s (p99) while the share lasted. Now,
    once the threads' last resumes take more than SCRIPTS_PASS_ALLOWANCE together, a pass
    resumes them in turn, as many as fit, from where the last one stopped: no thread is cut,
    each resumes every few passes. In process, 12 busy threads, an allowance of 12 ms."""
    busy = "function sysCall_thread()\n  while true do local x = 0 for i = 1, 2000 do x = x + i end end\nend\n"
    sim = Simulation(many(tmp_path, 12, busy), realtime=False)
    sim.scripts.budget.allowance = 0.012
    resumed: list[list[str]] = []
    for script in sim.scripts.scripts.values():
        original = script.resume_thread

        def counted(original=original, name=script.object_name) -> None:
            resumed[-1].append(name)
            original()

        script.resume_thread = counted
    try:
        resumed.append([])
        sim.start()  # each thread runs to its first yield
        for _ in range(40):
            resumed.append([])
            sim.step()
        per_pass = [len(names) for names in resumed[2:]]  # the first step measures every thread
        assert max(per_pass) < 12, per_pass
        counts = {name: sum(names.count(name) for names in resumed[1:]) for name in resumed[1]}
        assert min(counts.values()) >= 40 * min(per_pass) // 12 - 2, counts  # in turn: none left behind
        assert not any(s.cut for s in sim.scripts.scripts.values())
    finally:
        sim.close()
