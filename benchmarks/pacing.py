"""Pacing of blocking calls (issue 12, part 3): the same calls against a server with legacy
pacing (the default: a client's blocking calls see distinct simulation steps, as on V-REP) and
one with ``--pacing immediate`` (served as they arrive), both in real time, dt 50 ms, UR5 scene,
side by side in this run.

Rows:
- blocking ``simxGetJointPosition`` round trip in each pacing, and how many distinct simulation
  steps the calls saw (legacy: one per call; immediate: many calls per step);
- a poll loop in the style of visual-pushing-grasping's ``close_gripper()``: drive the RG2 closed
  (0.055 m at 0.05 m/s: 1.1 s of travel) and poll the finger joint with blocking calls until a
  reading is not smaller than the previous one. Its wall time, readings and the finger opening
  at the end: with legacy pacing the loop ends when the fingers have stopped (closed); with
  immediate pacing two readings fall in the same step and it ends at once, fingers still open.
"""

from __future__ import annotations

import time

from benchmarks.common import Settings, connect
from benchmarks.procs import Server
from benchmarks.stats import Figure, scaled, summary
from simx_client import api
from simx_client import constants as C

B = C.simx_opmode_blocking
FINGERS = "RG2_openCloseJoint"


def _ok(rc) -> None:
    if rc != 0:
        raise RuntimeError(f"simx call failed with return code {rc}")


def _round_trips(cid: int, joint: int, n: int, budget_s: float) -> tuple[list[float], int]:
    """Wall time of up to ``n`` blocking calls (within ``budget_s``) and the distinct sim times seen."""
    times, stamps = [], set()
    deadline = time.monotonic() + budget_s
    while len(times) < n and time.monotonic() < deadline:
        t0 = time.perf_counter()
        rc, _ = api.simxGetJointPosition(cid, joint, B)
        times.append(time.perf_counter() - t0)
        _ok(rc)
        stamps.add(api.simxGetLastCmdTime(cid))
    return times, len(stamps)


def _close_gripper(cid: int, joint: int) -> tuple[float, int, float]:
    """(wall s, readings, final opening m) of one VPG-style closing poll, from open."""
    _ok(api.simxSetJointTargetVelocity(cid, joint, 0.05, B))  # open, and wait until open
    deadline = time.monotonic() + 5
    while api.simxGetJointPosition(cid, joint, B)[1] < 0.054 and time.monotonic() < deadline:
        time.sleep(0.02)
    t0 = time.perf_counter()
    rc, position = api.simxGetJointPosition(cid, joint, B)
    _ok(rc)
    _ok(api.simxSetJointForce(cid, joint, 20.0, B))
    _ok(api.simxSetJointTargetVelocity(cid, joint, -0.05, B))
    readings = 0
    while readings < 500:
        rc, new_position = api.simxGetJointPosition(cid, joint, B)
        _ok(rc)
        readings += 1
        if new_position >= position:
            position = new_position
            break
        position = new_position
    return time.perf_counter() - t0, readings, position


def _measure(s: Settings, pacing: str, calls: int) -> dict:
    with Server(s.log_dir, "--pacing", pacing, name=f"pacing-{pacing}") as srv:
        cid = connect(srv.port)
        try:
            rc, joint = api.simxGetObjectHandle(cid, FINGERS, B)
            _ok(rc)
            _round_trips(cid, joint, 5, 5.0)  # warm-up
            times, steps = _round_trips(cid, joint, calls, s.t(4.0, 1.5))
            loops = [_close_gripper(cid, joint) for _ in range(s.n(3, 1))]
        finally:
            api.simxFinish(cid)
    return {"times": times, "steps": steps, "loops": loops}


def run(s: Settings) -> list[Figure]:
    legacy = _measure(s, "legacy", s.n(60, 20))
    immediate = _measure(s, "immediate", s.n(1000, 200))
    figures = []
    for name, r in (("legacy", legacy), ("immediate", immediate)):
        n = len(r["times"])
        floor = None
        if name == "legacy":
            floor = {"label": "the same call, --pacing immediate", **scaled(summary(immediate["times"]), 1e3)}
        figures.append(Figure(
            f"pacing.{name}.call", f"blocking GetJointPosition, --pacing {name}", "ms",
            scaled(summary(r["times"]), 1e3), floor=floor,
            note=f"{n} calls saw {r['steps']} distinct simulation steps (dt 50 ms, real time)",
            extra={"calls": n, "distinct_steps": r["steps"]}))
    for name, r in (("legacy", legacy), ("immediate", immediate)):
        walls, readings, finals = zip(*r["loops"])
        figures.append(Figure(
            f"pacing.{name}.close_gripper", f"VPG-style close_gripper() poll, --pacing {name}", "ms",
            scaled(summary(walls), 1e3),
            note=f"readings {list(readings)}, finger opening at the end {[round(f, 4) for f in finals]} m "
                 "(0 = closed, 0.055 = open)",
            extra={"readings": list(readings), "final_opening_m": list(finals)}))
    return figures
