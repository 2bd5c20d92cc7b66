"""4. Synchronous stepping: ``simxSynchronousTrigger`` + ``simxGetPingTime`` per step
(the legacy idiom: the ping returns once the triggered step is done), UR5 scene, dt 50 ms.

Floor, side by side in interleaved blocks: two bare Zenoh query/replies (the trigger's and the
ping's request/reply sizes) to benchmarks/zenoh_echo.py, plus MuJoCo stepping the same scene
in this process with no transport (``Simulation(scene, 0.05).step()``: the same step the server
runs, scripts included). floor = p50(two round trips) + p50(in-process step).
The arm is at rest in both (same state, same physics cost).

With ``--baseline DIR`` the same steps against a server of that source tree (an older commit)
join the interleaved blocks, and against a second such server with the client as it was before
issue 44 (``client_as_before_issue44``): before and after in one run, against the same floor.

A line follower's step (issue 50) joins them on servers of its own: ``simxSynchronousTrigger``,
then the streamed ``UR5_joint1`` position read with ``simx_opmode_buffer`` (no ping), the idiom
whose clock V-REP advances by one step per trigger; with ``--baseline`` also on that tree's server.
"""

from __future__ import annotations

from collections.abc import Callable

from benchmarks.common import Floor, Settings, client_as_before_issue44, connect, interleaved, wire_sizes
from benchmarks.procs import SCENE, Echo, Server
from benchmarks.stats import Figure, Target, rate_summary, scaled, summary
from simx_client import api
from simx_client import constants as C

B = C.simx_opmode_blocking


def run(s: Settings) -> list[Figure]:
    from simx_server.scene.simulation import Simulation

    sim = Simulation(SCENE, 0.05)
    sim.start()
    base_srv = base = base_client = base_client_srv = None
    follow_srvs: list[Server] = []
    follow: list[int] = []
    try:
        with Server(s.log_dir, "--dt", "0.05", name="sync") as srv, Echo(s.log_dir) as echo:
            for root, name in ((None, "sync-follow"), (s.baseline, "sync-follow-baseline")):
                if name == "sync-follow" or root is not None:
                    follow_srvs.append(Server(s.log_dir, "--dt", "0.05", name=name, root=root))
                    follow.append(connect(follow_srvs[-1].port))
            if s.baseline is not None:
                base_srv = Server(s.log_dir, "--dt", "0.05", name="sync-baseline", root=s.baseline)
                base = connect(base_srv.port)
                # the baseline server once more, with the client as it was before issue 44
                base_client_srv = Server(s.log_dir, "--dt", "0.05", name="sync-baseline-client", root=s.baseline)
                base_client = connect(base_client_srv.port)
                client_as_before_issue44(base_client)
            cid = connect(srv.port)
            floor = Floor(echo.port)
            try:
                return _measure(s, cid, floor, sim, base, base_client, follow)
            finally:
                for c in (cid, base, base_client, *follow):
                    if c is not None:
                        api.simxSynchronous(c, False)
                        api.simxFinish(c)
                floor.close()
    finally:
        for server in (base_srv, base_client_srv, *follow_srvs):
            if server is not None:
                server.stop()
        sim.close()


def _start_stepping(cid: int) -> None:
    for rc, what in ((api.simxSynchronous(cid, True), "simxSynchronous"),
                     (api.simxStartSimulation(cid, B), "simxStartSimulation")):
        if rc != 0:
            raise RuntimeError(f"{what} failed with return code {rc}")


def _follower(cid: int, failures: list) -> Callable[[], None]:
    """A line follower's step on ``cid``: trigger, then the streamed joint from the inbox."""
    _start_stepping(cid)
    joint = api.simxGetObjectHandle(cid, "UR5_joint1", B)[1]
    api.simxGetJointPosition(cid, joint, C.simx_opmode_streaming)
    api.simxGetPingTime(cid)

    def step() -> None:
        rc = api.simxSynchronousTrigger(cid)
        rc2, _ = api.simxGetJointPosition(cid, joint, C.simx_opmode_buffer)
        if rc or rc2:
            failures.append((rc, rc2))
    return step


def _measure(s: Settings, cid: int, floor: Floor, sim, base: int | None = None,
             base_client: int | None = None, follow: list[int] | None = None) -> list[Figure]:
    _start_stepping(cid)
    for c in (base, base_client):
        if c is not None:
            _start_stepping(c)
    trig = wire_sizes(cid, [["SynchronousTrigger", B, []]])
    ping = wire_sizes(cid, [["GetPingTime", B, []]])
    api.simxGetPingTime(cid)  # wire_sizes ran one trigger: start counting after it
    t0 = api.simxGetLastCmdTime(cid)
    failures = []

    def step(cid: int = cid) -> None:
        rc = api.simxSynchronousTrigger(cid)
        rc2, _ = api.simxGetPingTime(cid)
        if rc or rc2:
            failures.append((rc, rc2))

    def two_rt() -> None:
        floor.call(trig[1], trig[0])
        floor.call(ping[1], ping[0])

    n0 = sim.steps
    cases = {"step": step, "floor_rt2": two_rt, "physics": sim.step}
    if base is not None:
        cases["baseline"] = lambda: step(base)
    if base_client is not None:
        cases["baseline_client"] = lambda: step(base_client)
    for name, c in zip(("follow", "follow_baseline"), follow or []):
        cases[name] = _follower(c, failures)
    t = interleaved(s.n(30, 6), 20, cases, budget_s=s.t(60, 20))
    if failures:
        raise RuntimeError(f"{len(failures)} failed steps, e.g. return codes {failures[0]}")
    api.simxGetPingTime(cid)
    advanced_ms = api.simxGetLastCmdTime(cid) - t0
    ms = {k: scaled(summary(v), 1e3) for k, v in t.items()}
    floor_ms = ms["floor_rt2"]["median"] + ms["physics"]["median"]
    composite = {"label": "2 bare Zenoh round trips + in-process step",
                 "median": floor_ms,
                 "p10": ms["floor_rt2"]["p10"] + ms["physics"]["p10"],
                 "p90": ms["floor_rt2"]["p90"] + ms["physics"]["p90"]}
    steps_expected = len(t["step"]) + 5  # + warm-up
    baseline = [] if base is None else [
        Figure("sync.step_baseline", "sync step, --baseline tree's server", "ms", ms["baseline"], floor=composite,
               note=f"server of {s.baseline}"),
        Figure("sync.steps_per_s_baseline", "sync steps/s, --baseline tree's server", "1/s",
               rate_summary(t["baseline"]), floor={"label": "in-process steps/s", **rate_summary(t["physics"])}),
        Figure("sync.steps_per_s_baseline_client", "sync steps/s, --baseline server and client", "1/s",
               rate_summary(t["baseline_client"]), floor={"label": "in-process steps/s", **rate_summary(t["physics"])},
               note="the client as before issue 44 (benchmarks.common.client_as_before_issue44)"),
    ]
    physics_rate = {"label": "in-process steps/s", **rate_summary(t["physics"])}
    followers = [Figure(f"sync.{name}_steps_per_s", f"line follower's steps/s (trigger + buffer read){what}", "1/s",
                        rate_summary(t[name]), floor=physics_rate)
                 for name, what in (("follow", ""), ("follow_baseline", ", --baseline tree's server")) if name in t]
    return followers + baseline + [
        Figure("sync.step", "sync step: SynchronousTrigger + GetPingTime", "ms", ms["step"], floor=composite,
               target=Target("ratio", "<=", 2.5, "p50 <= 2.5x floor"),
               note=f"sim advanced {advanced_ms} ms for {steps_expected} triggers (expect {steps_expected * 50})",
               extra={"sim_ms_advanced": advanced_ms, "triggers": steps_expected}),
        Figure("sync.floor_rt2", "  floor part: 2 bare Zenoh round trips", "ms", ms["floor_rt2"],
               note=f"trigger {trig[0]}/{trig[1]} B, ping {ping[0]}/{ping[1]} B"),
        Figure("sync.physics", "  floor part: in-process Simulation.step (dt 50 ms)", "ms", ms["physics"],
               note=f"{sim.steps - n0} in-process steps"),
        Figure("sync.steps_per_s", "sync steps/s over simx", "1/s", rate_summary(t["step"]),
               floor={"label": "in-process steps/s", **rate_summary(t["physics"])}),
    ]
