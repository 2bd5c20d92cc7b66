"""A failed simulation step, as the ZMQ door tells it: the loop stops the simulation and marks
every client of every door (``Clients.fault_all``); a ZMQ client hears the reason once, as the
error of its next call (a stepped client: of the ``sim.step`` whose step failed), then its calls
are served again, as the legacy door's clients are told at their next request
(tests/transport/test_server_core.py)."""

from __future__ import annotations

from pathlib import Path

import pytest

from conftest import ServerProcess, free_port

pytest.importorskip("coppeliasim_zmqremoteapi_client")

#: mj_step raises once its boxes touch the floor (its arena is too small for the contacts).
ARENA = Path(__file__).resolve().parents[1] / "scenes" / "arena_overflow.xml"


def test_a_failed_step_is_told_once_to_each_zmq_client(official):
    port = free_port()
    srv = ServerProcess(str(ARENA), "--stopped", "--zmq-port", str(port), renderers="on-demand")
    try:
        stepper, other = official(port).require("sim"), official(port).require("sim")
        assert other.getSimulationState() == other.simulation_stopped  # a client before the failure
        stepper.setStepping(True)
        stepper.startSimulation()
        with pytest.raises(Exception, match="step failed") as failed:
            for _ in range(100):  # the boxes touch the floor after 0.22 s: a few steps of 0.05 s
                stepper.step()
        assert "FatalError" in str(failed.value) and len(str(failed.value)) < 400
        assert stepper.getSimulationState() == stepper.simulation_stopped  # told once
        with pytest.raises(Exception, match="step failed"):
            other.getObject("/Box1")  # told instead of executed
        assert other.getObject("/Box1") >= 0
        assert other.getSimulationState() == other.simulation_stopped
    finally:
        log = srv.stop()
    assert srv.proc.returncode == 0
    assert sum(" ERROR " in line and "the simulation step failed" in line for line in log.splitlines()) == 1
