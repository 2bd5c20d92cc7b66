"""A ``simx-server`` stopped with Ctrl-C leaves nothing on stderr but its log (issue 60): OMPL's
bindings (nanobind) counted every type and function they had defined as "leaked" at each exit,
about 40 lines, once the pyrep or test extra was installed. They are imported when a planning
call first needs them now, and what the loop froze for its passes (``gc.freeze``) is collectable
again when the server closes, so even a server that planned exits quietly."""

from __future__ import annotations

import os
import signal
import subprocess
import sys

import pytest

from conftest import free_port, ready_line

#: Two links turning about z at the origin and a pillar in the stretched arm's way.
SCENE = """<mujoco model="plan">
  <compiler angle="radian"/>
  <worldbody>
    <body name="Link1" pos="0 0 0.3">
      <joint name="Joint1" type="hinge" axis="0 0 1" range="-3 3" limited="true"/>
      <geom type="capsule" fromto="0.03 0 0 0.4 0 0" size="0.03"/>
      <body name="Link2" pos="0.4 0 0">
        <joint name="Joint2" type="hinge" axis="0 0 1" range="-2.8 2.8" limited="true"/>
        <geom type="capsule" fromto="0.04 0 0 0.3 0 0" size="0.03"/>
      </body>
    </body>
    <body name="Pillar" pos="0 0.5 0.3"><geom type="box" size="0.03 0.03 0.2"/></body>
  </worldbody>
</mujoco>
"""


def test_the_server_imports_no_planner_until_a_planning_call():
    code = ("import sys; import simx_server.cli, simx_server.api, simx_server.scene.simulation, "
            "simx_server.zmq.remote_api; print(sorted(m for m in sys.modules if m.split('.')[0] == 'ompl'))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"


def test_a_server_that_planned_exits_on_sigint_without_leak_lines(tmp_path, official):
    pytest.importorskip("ompl")
    (tmp_path / "plan.xml").write_text(SCENE)
    port, zmq_port = free_port(), free_port()
    # python -m simx_server.cli, not the suite's forked servers: those end with os._exit, which
    # skips the interpreter's exit, where the lines were printed.
    proc = subprocess.Popen([sys.executable, "-m", "simx_server.cli", str(tmp_path / "plan.xml"), "--stopped",
                             "--renderers", "on-demand", "--port", str(port), "--zmq-port", str(zmq_port)],
                            stdout=subprocess.PIPE, stderr=open(tmp_path / "err", "w"),
                            env=dict(os.environ, MUJOCO_GL="egl"), text=True)
    try:
        assert ready_line(proc, 60) is not None, (tmp_path / "err").read_text()
        client = official(zmq_port)
        sim, simOMPL = client.require("sim"), client.require("simOMPL")  # noqa: N806 (CoppeliaSim's name)
        pillar = sim.getObject("/Pillar")
        task = simOMPL.createTask("t")
        simOMPL.setAlgorithm(task, simOMPL.Algorithm.RRTConnect)
        simOMPL.setStateSpaceForJoints(task, [sim.getObject("/Joint1"), sim.getObject("/Link1/Joint2")], [1, 1])
        simOMPL.setCollisionPairs(task, [sim.getObject("/Link1"), pillar, sim.getObject("/Link1/Link2"), pillar])
        simOMPL.setStartState(task, [0.0, 0.0])
        simOMPL.setGoalState(task, [2.5, 0.0])
        simOMPL.setup(task)
        solved, states = simOMPL.compute(task, 10.0, -1.0, 0)
        assert solved and len(states) > 2
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=30) == 0  # a bound on the wait only: a hang fails here
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    err = (tmp_path / "err").read_text()
    assert "leaked" not in err and "nanobind" not in err, err[-3000:]
    assert err.rstrip().endswith("stopped"), err[-3000:]
