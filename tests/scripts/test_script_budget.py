"""Issue 40: a budget for all of a scene's scripts together (simx_server/scripts/budget.py).

30 scripts, each within its own 1 s and 256 MiB, made one step take 30 s and 2 GB. Now a pass
of the simulation thread (a start, a step, an idle pass) gives all scripts together
limits.MAX_SCRIPTS_STEP_TIME of CPU: the script running when it ends is interrupted and named with
the bound, the scripts after it wait for the next pass, and every overrunning script has its step
functions skipped until the next start. Their Lua states hold limits.MAX_SCRIPTS_MEMORY together.
The in-process tests shrink the budget (CPU time, so the outcome is the same on any machine)."""

from __future__ import annotations

import logging
import re
from pathlib import Path

import pytest

import vrep
from conftest import ServerProcess, wait_until
from simx_server.base import limits as L
from simx_server.scene.simulation import Simulation

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
