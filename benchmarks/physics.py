"""5. Physics speed: real-time factor of the UR5 scene on a server at ``--speed 0``.

Windows of ``window`` s: the client reads the simulation time (blocking ``simxGetPingTime``,
``simxGetLastCmdTime``) at both ends, RTF = simulated time / wall time. Between server windows
the simulation is paused (blocking ``simxPauseSimulation``) and the same scene is stepped in
this process for the same wall time, with no transport: the physics floor, side by side, with
the two never competing for the CPU.
"""

from __future__ import annotations

import time

from benchmarks.common import Settings, connect
from benchmarks.procs import SCENE, Server
from benchmarks.stats import Figure, Target, summary
from simx_client import api
from simx_client import constants as C

B = C.simx_opmode_blocking


def _sim_now(cid: int) -> tuple[float, float]:
    rc, _ = api.simxGetPingTime(cid)
    if rc:
        raise RuntimeError(f"simxGetPingTime failed with return code {rc}")
    return time.monotonic(), api.simxGetLastCmdTime(cid) / 1e3


def run(s: Settings) -> list[Figure]:
    from simx_server.scene.simulation import Simulation

    sim = Simulation(SCENE, 0.05)
    sim.start()
    window, rounds = s.t(0.5, 0.4), s.n(12, 4)
    remote, local = [], []
    try:
        with Server(s.log_dir, "--speed", "0", "--dt", "0.05", name="physics") as srv:
            cid = connect(srv.port)
            try:
                time.sleep(0.2)  # warm up
                for _ in range(rounds):
                    api.simxStartSimulation(cid, B)
                    w0, s0 = _sim_now(cid)
                    time.sleep(window)
                    w1, s1 = _sim_now(cid)
                    api.simxPauseSimulation(cid, B)
                    remote.append((s1 - s0) / (w1 - w0))
                    t0, n0 = time.monotonic(), sim.steps
                    while time.monotonic() - t0 < window:
                        sim.step()
                    local.append((sim.steps - n0) * sim.world.dt / (time.monotonic() - t0))
            finally:
                api.simxFinish(cid)
    finally:
        sim.close()
    return [
        Figure("physics.rtf", "physics real-time factor, server --speed 0", "x", summary(remote),
               floor={"label": "in-process stepping RTF", **summary(local)},
               target=Target("value", ">=", 50, "RTF >= 50"),
               note=f"{rounds} windows of {window} s each"),
        Figure("physics.rtf_inprocess", "  floor: in-process Simulation.step RTF", "x", summary(local)),
    ]
