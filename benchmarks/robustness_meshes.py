"""Exact mesh queries and recompiling calls against the simulation thread (issue 84, items 1
and 4), at full size, each attack on a server of its own while another ZMQ client loops
``sim.getSimulationTime``; figures, not pass/fail (tests/sim/test_mesh_bounds.py,
tests/zmq/test_zmq_mesh_queries.py, tests/transport/test_stream_budget.py,
tests/zmq/test_zmq_edit_charges.py and tests/zmq/test_zmq_file_calls.py have the pass/fail side).

    MUJOCO_GL=egl python -m benchmarks.robustness_meshes                 # this checkout
    MUJOCO_GL=egl python -m benchmarks.robustness_meshes --code DIR      # another checkout's simx_server
    ... --only checkCollision                                            # the attacks named so

The scene: two spheres of 200,000 triangles (MuJoCo binary meshes next to it), one 0.1 % smaller
inside the other (a near miss of every triangle), the inner one free (no gravity, no contacts) for
a planner to move; the attacks that create a 200,000-triangle shape of their own have a scene
of one box (the shape made before the other client starts). Each attack prints the attackers' time, the other client's slowest call while
they ran (the "gap", and how many it made), the server's RSS before, at its peak (sampled every
50 ms) and 10 s after, and the first attacker's reply. Every wait is bounded (240 s a reply).
"""

from __future__ import annotations

import argparse
import os
import struct
import tempfile
import time
from pathlib import Path

import numpy as np
import zmq

from benchmarks.robustness_zmq import ROOT, Target, call
from benchmarks.victims import during, once

SCENE = """<mujoco model="nested meshes">
  <option gravity="0 0 0"/>
  <asset><mesh name="outer" file="outer.msh"/><mesh name="inner" file="inner.msh"/></asset>
  <worldbody>
    <body name="Outer" pos="0 0 1"><geom type="mesh" mesh="outer" contype="0" conaffinity="0"/></body>
    <body name="Inner" pos="0 0 1"><freejoint/><geom type="mesh" mesh="inner" contype="0" conaffinity="0"/></body>
    <site name="Sensor" pos="0 0 -1"/>
  </worldbody>
  <sensor><rangefinder name="Sensor_range" site="Sensor" cutoff="10"/></sensor>
  <custom><text name="simx:Sensor" data="type=proximity angle=90"/></custom>
</mujoco>
"""
#: The scene of the attacks that create their own 200,000-triangle shape (the nested spheres and
#: it would pass a client's MAX_SCENE_MESH_FACES).
PLAIN = """<mujoco model="plain">
  <worldbody><body name="Box" pos="0 0 0.1"><geom type="box" size="0.05 0.05 0.05"/></body></worldbody>
</mujoco>
"""


def sphere(faces: int, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """A UV sphere of about ``faces`` triangles."""
    rings = int(np.sqrt(faces / 4))
    around = 2 * rings
    t, p = np.meshgrid(np.linspace(0, np.pi, rings + 1)[1:-1], np.linspace(0, 2 * np.pi, around, endpoint=False),
                       indexing="ij")
    v = np.column_stack([np.sin(t).ravel() * np.cos(p).ravel(), np.sin(t).ravel() * np.sin(p).ravel(),
                         np.cos(t).ravel()])
    v = np.vstack([v, [[0, 0, 1], [0, 0, -1]]]) * radius
    top, bottom = len(v) - 2, len(v) - 1
    j = np.arange(around)
    rows = [np.column_stack([np.full(around, top), j, (j + 1) % around]),
            np.column_stack([np.full(around, bottom), (rings - 2) * around + (j + 1) % around,
                             (rings - 2) * around + j])]
    for i in range(rings - 2):
        a, b = i * around + j, i * around + (j + 1) % around
        c, d = a + around, b + around
        rows += [np.column_stack([a, c, b]), np.column_stack([b, c, d])]
    return v, np.vstack(rows)


def _msh(v: np.ndarray, f: np.ndarray) -> bytes:
    return struct.pack("<4i", len(v), 0, 0, len(f)) + v.astype("<f4").tobytes() + f.astype("<i4").tobytes()


def _pair(sock: zmq.Socket, uuid: str) -> tuple[int, int]:
    return tuple(call(sock, "sim.getObject", p, uuid=uuid)["ret"][0] for p in ("/Outer", "/Inner"))


def _task(sock: zmq.Socket, uuid: str) -> str:
    """A task moving the inner sphere within the outer one (every check a near miss)."""
    outer, inner = _pair(sock, uuid)
    space = call(sock, "simOMPL.createStateSpace", "p", 50003, inner, [-0.01, -0.01, 0.99], [0.01, 0.01, 1.01], 1,
                 uuid=uuid)["ret"][0]
    task = call(sock, "simOMPL.createTask", "t", uuid=uuid)["ret"][0]
    for func, *args in (("setAlgorithm", 30017), ("setStateSpace", [space]), ("setCollisionPairs", [inner, outer]),
                        ("setStartState", [0, 0, 1]), ("setGoalState", [0.005, 0, 1])):
        call(sock, f"simOMPL.{func}", task, *args, uuid=uuid)
    return task


def _set_up(sock: zmq.Socket, uuid: str) -> str:
    task = _task(sock, uuid)
    call(sock, "simOMPL.setup", task, uuid=uuid)
    return task


def _kept_tasks(sock: zmq.Socket, uuid: str) -> str:
    """25 tasks set up, the scene edited between (each keeps the model of its setup)."""
    last = ""
    for _ in range(25):
        task = _task(sock, uuid)
        last = str(call(sock, "simOMPL.setup", task, uuid=uuid).get("err", "set up"))
        call(sock, "sim.createDummy", 0.01, uuid=uuid)
    return last


def _created(sock: zmq.Socket, uuid: str) -> int:
    """A 200,000-triangle shape made by the client (sim.createShape)."""
    v, f = sphere(200_000, 0.3)
    return call(sock, "sim.createShape", 0, 0.0, (v + [2, 0, 1]).ravel().tolist(), f.ravel().tolist(),
                uuid=uuid)["ret"][0]


def _links(sock: zmq.Socket, uuid: str) -> str:
    """Beside such a shape (made before): 10 times two new dummies linked (setLinkDummy's weld pool)."""
    reply: dict = {}
    for _ in range(10):
        a, b = (call(sock, "sim.createDummy", 0.01, uuid=uuid)["ret"][0] for _ in range(2))
        reply = call(sock, "sim.setLinkDummy", a, b, uuid=uuid)
    return str(reply.get("err", "linked"))


def _streamed(t: Target) -> str:
    """A legacy client streaming simxCheckCollision of the two spheres, for 20 s."""
    import vrep

    cid = vrep.simxStart("127.0.0.1", t.port, True, True, 5000, 5)
    _, outer = vrep.simxGetObjectHandle(cid, "Outer", vrep.simx_opmode_blocking)
    _, inner = vrep.simxGetObjectHandle(cid, "Inner", vrep.simx_opmode_blocking)
    vrep.simxCheckCollision(cid, outer, inner, vrep.simx_opmode_streaming)
    time.sleep(20)
    code, answer = vrep.simxCheckCollision(cid, outer, inner, vrep.simx_opmode_buffer)
    vrep.simxFinish(cid)
    return f"last streamed value: return code {code}, {answer}"


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--code", type=Path, default=ROOT, help="checkout whose simx_server runs (default: this one)")
    p.add_argument("--only", action="append", metavar="WORD", help="attacks whose name holds WORD (repeatable)")
    args = p.parse_args(argv)
    rng = np.random.default_rng(0)
    triangles = (rng.uniform(-0.5, 0.5, (9_000, 9)) + [0, 0, 1] * 3).ravel().tolist()
    attacks = {
        "sim.checkCollision of the nested spheres": (1, once(_pair, lambda h: ("sim.checkCollision", *h))),
        "sim.checkDistance of the nested spheres": (1, once(_pair, lambda h: ("sim.checkDistance", *h))),
        "sim.checkCollision of them, 3 connections at once": (3, once(_pair, lambda h: ("sim.checkCollision", *h))),
        "simOMPL.solve(task, 10) of the inner sphere inside the outer": (1, once(
            _set_up, lambda task: ("simOMPL.solve", task, 10))),
        "25 simOMPL tasks set up, the scene edited between": (1, _kept_tasks),
        "setLinkDummy of new dummies beside a 200,000-triangle createShape": (1, _links, _created),
        "sim.saveScene with a 200,000-triangle createShape": (
            1, once(lambda s, u: None, lambda _: ("sim.saveScene", "s.xml")), _created),
        "sim.exportMesh of 200,000 triangles": (1, once(lambda s, u: sphere(200_000, 0.3), lambda m: (
            "sim.exportMesh", 0, "mesh.obj", 0, 1.0, [m[0].ravel().tolist()], [m[1].ravel().tolist()])), None),
        "sim.checkProximitySensorEx2, 9,000 triangles x a 90-degree cone's 440 rays": (1, once(
            lambda s, u: call(s, "sim.getObject", "/Sensor", uuid=u)["ret"][0],
            lambda h: ("sim.checkProximitySensorEx2", h, triangles, 2, 9_000, 3, 100.0, 1.0))),
        "a legacy client streaming simxCheckCollision of the nested spheres (20 s)": (1, None),
    }
    folder = Path(tempfile.mkdtemp(prefix="simx-meshes-"))
    for name, radius in (("outer", 0.5), ("inner", 0.4995)):
        (folder / f"{name}.msh").write_bytes(_msh(*sphere(200_000, radius)))
    (folder / "scene.xml").write_text(SCENE)
    plain = Path(tempfile.mkdtemp(prefix="simx-meshes-plain-"))
    (plain / "scene.xml").write_text(PLAIN)
    ctx = zmq.Context()
    print(f"code: {args.code}; load average {os.getloadavg()[0]:.1f}")
    print("| attack | attackers' time | other client's slowest call (p99, calls) | server RSS before -> peak -> 10 s after | reply |")
    print("|---|---|---|---|---|")
    for name, (count, attack, *before) in attacks.items():
        if args.only and not any(w in name for w in args.only):
            continue
        t = Target(args.code, plain if before else folder)  # a shape of its own: the box's scene
        try:
            start = time.monotonic()
            other, reply = during(t, ctx, count, attack or (lambda s, u: _streamed(t)), *before)
            took = time.monotonic() - start
            time.sleep(10)
            print(f"| {name} | {took:.1f} s | {other} | {t.before:.0f} -> {t.peak:.0f} -> {t.rss():.0f} MB | "
                  f"{reply} |", flush=True)
        finally:
            t.stop()
    ctx.destroy(0)


if __name__ == "__main__":
    main()
