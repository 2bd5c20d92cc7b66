"""Long ZMQ calls against the simulation thread (issue 57): planning, convex decomposition and
IK searches at full size, each on a server of its own, while another client loops a cheap call;
figures, not pass/fail (tests/zmq/test_zmq_long_calls.py has the pass/fail side).

    MUJOCO_GL=egl python -m benchmarks.robustness_long_calls                 # this checkout
    MUJOCO_GL=egl python -m benchmarks.robustness_long_calls --code DIR      # another checkout's simx_server
    ... --state-count 1000000                                                # compute's stateCnt (default 1e7)

Each attack prints: the attackers' time, the other client's slowest ``sim.getSimulationTime``
while they ran (and how many it made), the server's RSS before, at its peak (sampled every 50 ms)
and 10 s after, and the attackers' first reply. Every wait is bounded (240 s a reply).

The ring's attacks (issue 84) measure instead how long another client's own 0.3 s
``simOMPL.solve`` takes when it comes just after the attackers' long calls: behind 12 connections
each solving for 10 s, behind 12 that sent such a solve and closed, behind 6 that sent a
400,000-voxel ``sim.convexDecompose`` and closed.
"""

from __future__ import annotations

import argparse
import math
import os
import tempfile
import time
from pathlib import Path

import zmq

from benchmarks.robustness_zmq import ROOT, Target, _short, call
from benchmarks.victims import during, once
from simx_server.zmq import codec

#: A one-link arm that a post blocks (no path: planners search until their time is up), and a
#: torus (a non-convex mesh) to decompose.
SCENE = """<mujoco model="long calls">
  <compiler angle="radian"/>
  <asset><mesh name="torus" vertex="{vertex}" face="{face}"/></asset>
  <worldbody>
    <body name="Link1" pos="0 0 0.3">
      <joint name="Joint1" type="hinge" axis="0 0 1" range="-3 3" limited="true"/>
      <geom type="capsule" fromto="0.03 0 0 0.4 0 0" size="0.03"/>
    </body>
    <body name="Post" pos="0 0.25 0.3"><geom type="box" size="0.03 0.03 0.2"/></body>
    <body name="Torus" pos="1 1 0.2"><geom type="mesh" mesh="torus"/></body>
  </worldbody>
</mujoco>
"""


def _torus(n: int = 48, m: int = 24, big: float = 0.2, small: float = 0.06) -> tuple[str, str]:
    vertex, face = [], []
    for i in range(n):
        for j in range(m):
            a, b = 2 * math.pi * i / n, 2 * math.pi * j / m
            r = big + small * math.cos(b)
            vertex += [r * math.cos(a), r * math.sin(a), small * math.sin(b)]
            p, q, s, t = i * m + j, ((i + 1) % n) * m + j, ((i + 1) % n) * m + (j + 1) % m, i * m + (j + 1) % m
            face += [p, q, s, p, s, t]
    return " ".join(f"{v:.5f}" for v in vertex), " ".join(map(str, face))


def _task(sock: zmq.Socket, uuid: str) -> str:
    joint, link, post = (call(sock, "sim.getObject", p, uuid=uuid)["ret"][0] for p in ("/Joint1", "/Link1", "/Post"))
    task = call(sock, "simOMPL.createTask", "blocked", uuid=uuid)["ret"][0]
    call(sock, "simOMPL.setAlgorithm", task, 30017, uuid=uuid)  # RRTConnect
    call(sock, "simOMPL.setStateSpaceForJoints", task, [joint], [1], uuid=uuid)
    call(sock, "simOMPL.setCollisionPairs", task, [link, post], uuid=uuid)
    call(sock, "simOMPL.setStartState", task, [0.0], uuid=uuid)
    call(sock, "simOMPL.setGoalState", task, [2.5], uuid=uuid)
    call(sock, "simOMPL.setup", task, uuid=uuid)
    return task


def _ik(sock: zmq.Socket, uuid: str) -> tuple[int, int, int]:
    joint, link = (call(sock, "sim.getObject", p, uuid=uuid)["ret"][0] for p in ("/Joint1", "/Link1"))
    env = call(sock, "simIK.createEnvironment", uuid=uuid)["ret"][0]
    group = call(sock, "simIK.createGroup", env, uuid=uuid)["ret"][0]
    tip, target = (call(sock, "sim.createDummy", 0.01, uuid=uuid)["ret"][0] for _ in range(2))
    call(sock, "sim.setObjectParent", tip, link, False, uuid=uuid)
    call(sock, "sim.setObjectPosition", tip, -1, [0.4, 0.0, 0.3], uuid=uuid)
    call(sock, "sim.setObjectPosition", target, -1, [5.0, 5.0, 5.0], uuid=uuid)  # out of reach
    call(sock, "simIK.addElementFromScene", env, group, -1, tip, target, 1, uuid=uuid)
    return env, group, joint


def _attack(t: Target, ctx: zmq.Context, attackers: int, prepare, request) -> str:
    """``attackers`` connections (uuids a0, a1...) each send ``request(prepared)`` once, at once,
    while another client loops sim.getSimulationTime: its slowest call, the attackers' replies."""
    other, reply = during(t, ctx, attackers, once(prepare, request))
    return f"other client's slowest call {other} | {reply}"


def _behind(t: Target, ctx: zmq.Context, attackers: int, prepare, request, leave: bool) -> str:
    """``attackers`` connections each send ``request(prepared)`` (and close at once when
    ``leave``); then another client's 0.3 s solve: how long it took to be answered."""
    socks = [t.socket(ctx, timeout_ms=300_000) for _ in range(attackers)]
    prepared = [prepare(s, f"a{k}") for k, s in enumerate(socks)]
    victim = t.socket(ctx, timeout_ms=300_000)
    task = _task(victim, "victim")
    for k, sock in enumerate(socks):
        func, *args = request(prepared[k])
        sock.send(codec.encode_request(func, list(args), f"a{k}"))
    time.sleep(1.0)  # every attacker's call is in
    if leave:
        for sock in socks:
            sock.close(0)
    start = time.monotonic()
    try:
        reply = _short(call(victim, "simOMPL.solve", task, 0.3, uuid="victim"))
    except zmq.Again:
        reply = "no reply in 300 s"
    took = time.monotonic() - start
    victim.close(0)
    if not leave:
        for sock in socks:
            sock.close(0)
    return f"the other client's 0.3 s solve answered in {took:.1f} s | {reply}"


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--code", type=Path, default=ROOT, help="checkout whose simx_server runs (default: this one)")
    p.add_argument("--only", action="append", metavar="WORD", help="attacks whose name holds WORD (repeatable)")
    p.add_argument("--state-count", type=int, default=10 ** 7, help="compute's stateCnt (default 1e7)")
    args = p.parse_args(argv)
    attacks = {
        "simOMPL.solve(task, 1e9), 3 connections at once":
            (3, _task, lambda task: ("simOMPL.solve", task, 1e9)),
        f"simOMPL.compute(task, 1e9, 1e9, {args.state_count:g})":
            (1, _task, lambda task: ("simOMPL.compute", task, 1e9, 1e9, args.state_count)),
        "sim.convexDecompose of a torus at resolution 400,000":
            (1, lambda s, u: call(s, "sim.getObject", "/Torus", uuid=u)["ret"][0],
             lambda shape: ("sim.convexDecompose", shape, 128, [0, 0, 0, 0, 0, 400_000, 0, 0, 0, 64], [0.0] * 10)),
        "simIK.findConfig(maxTime 1e9), 3 connections at once":
            (3, _ik, lambda e: ("simIK.findConfig", e[0], e[1], [e[2]], 0.1, 1e9)),
    }
    decompose = (lambda s, u: call(s, "sim.getObject", "/Torus", uuid=u)["ret"][0],
                 lambda shape: ("sim.convexDecompose", shape, 128, [0, 0, 0, 0, 0, 400_000, 0, 0, 0, 64], [0.0] * 10))
    ring = {
        "ring: behind 12 connections solving 10 s each": (12, _task, lambda task: ("simOMPL.solve", task, 10.0), False),
        "ring: behind 12 clients that sent a 10 s solve and left":
            (12, _task, lambda task: ("simOMPL.solve", task, 10.0), True),
        "ring: behind 6 clients that sent a convexDecompose and left": (6, *decompose, True),
    }
    folder = Path(tempfile.mkdtemp(prefix="simx-long-calls-"))
    vertex, face = _torus()
    (folder / "scene.xml").write_text(SCENE.format(vertex=vertex, face=face))
    ctx = zmq.Context()
    print(f"code: {args.code}; load average {os.getloadavg()[0]:.1f}")
    print("| attack | attackers' time | other client | server RSS before -> peak -> 10 s after | reply |")
    print("|---|---|---|---|---|")
    runs = {**{name: (lambda t, a=a: _attack(t, ctx, *a)) for name, a in attacks.items()},
            **{name: (lambda t, a=a: _behind(t, ctx, *a)) for name, a in ring.items()}}
    for name, run in runs.items():
        if args.only and not any(w in name for w in args.only):
            continue
        t = Target(args.code, folder)
        try:
            start = time.monotonic()
            other, _, reply = run(t).partition(" | ")
            took = time.monotonic() - start
            time.sleep(10)
            print(f"| {name} | {took:.1f} s | {other} | {t.before:.0f} -> {t.peak:.0f} -> {t.rss():.0f} MB | "
                  f"{reply} |", flush=True)
        finally:
            t.stop()
    ctx.destroy(0)


if __name__ == "__main__":
    main()
