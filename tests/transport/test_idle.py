"""An idle server costs nothing: ``--speed 0`` with no client and no viewer takes no step (the
loop sleeps until a request), and steps again as fast as possible as soon as a client connects."""

from __future__ import annotations

import os
import time

from conftest import SCENE, ServerProcess, wait_until

_TICK = os.sysconf("SC_CLK_TCK")


def cpu_seconds(pid: int) -> float:
    """User + system CPU time of process ``pid`` so far (s), from /proc/PID/stat."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / _TICK


def cpu_share(pid: int, seconds: float) -> float:
    """Fraction of one core process ``pid`` used over the next ``seconds`` of wall time."""
    start_cpu, start = cpu_seconds(pid), time.monotonic()
    time.sleep(seconds)  # the measurement window itself, not a synchronisation
    return (cpu_seconds(pid) - start_cpu) / (time.monotonic() - start)


def test_speed0_server_without_clients_is_idle_and_steps_for_a_client():
    import vrep

    srv = ServerProcess(str(SCENE), "--speed", "0", renderers="on-demand")
    try:
        share = cpu_share(srv.proc.pid, 2.0)
        assert share < 0.05, f"an idle --speed 0 server used {share:.0%} of a core"
        cid = vrep.simxStart("127.0.0.1", srv.port, True, True, 5000, 5)
        assert cid >= 0
        try:
            def sim_time():
                vrep.simxGetPingTime(cid)
                return vrep.simxGetLastCmdTime(cid)
            first = wait_until(sim_time, what="a reply stamped with the simulation time")
            # as fast as possible while a client is there: many steps of 50 ms in little wall time
            wait_until(lambda: sim_time() - first > 20_000, timeout=30,
                       what="20 s of simulated time with a client connected")
        finally:
            vrep.simxFinish(cid)
        # the client left: idle again (its token is gone at once on simxFinish)
        wait_until(lambda: cpu_share(srv.proc.pid, 0.5) < 0.05, timeout=10,
                   what="the server idle again after the client left")
    finally:
        srv.stop()
