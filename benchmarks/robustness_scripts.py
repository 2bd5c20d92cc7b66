"""A client's scene and its scripts against the other clients (issue 84), on a server started
with ``--allow-remote-code``: the attacker sends a scene (``simxTransferFile``) whose child script
plans, decomposes, stores parameters or runs 200 busy threads, and loads it
(``simxLoadScene(name, 1)``: the simulation then starts it); figures, not pass/fail (the bounded
forms: tests/scripts/test_client_script_long_calls.py, test_script_parameter_bounds.py,
test_script_budget.py).

    MUJOCO_GL=egl python -m benchmarks.robustness_scripts                 # this checkout
    MUJOCO_GL=egl python -m benchmarks.robustness_scripts --code DIR      # another checkout's simx_server

Each prints the server's RSS before, at its peak and 10 s after the attack, and another legacy
client's calls while it ran (a process of its own, robustness_buffers.Probe: its slowest answer).
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

from benchmarks.robustness_buffers import ROOT, Probe, Target
from benchmarks.robustness_long_calls import _torus

ARM = """<mujoco model="client scene">
  <compiler angle="radian"/>
  <asset><mesh name="torus" vertex="{vertex}" face="{face}"/></asset>
  <worldbody>
    <body name="Keeper" pos="3 3 0.1"><geom type="box" size="0.05 0.05 0.05"/></body>
    <body name="Link1" pos="0 0 0.3">
      <joint name="Joint1" type="hinge" axis="0 0 1" range="-3 3" limited="true"/>
      <geom type="capsule" fromto="0.03 0 0 0.4 0 0" size="0.03" contype="0" conaffinity="0"/>
    </body>
    <body name="Post" pos="0 0.25 0.3"><geom type="box" size="0.03 0.03 0.2" contype="0" conaffinity="0"/></body>
    <body name="Torus" pos="1 1 0.2"><geom type="mesh" mesh="torus" contype="0" conaffinity="0"/></body>
    {bodies}
  </worldbody>
  <custom>{texts}</custom>
</mujoco>
"""
TASK = """local function blocked()
  local task = simOMPL.createTask("blocked")
  simOMPL.setAlgorithm(task, simOMPL.Algorithm.RRTConnect)
  simOMPL.setStateSpaceForJoints(task, {sim.getObject("/Joint1")}, {1})
  simOMPL.setCollisionPairs(task, {sim.getObject("/Link1"), sim.getObject("/Post")})
  simOMPL.setStartState(task, {0})
  simOMPL.setGoalState(task, {2.5})
  simOMPL.setup(task)
  return task
end
"""
DECOMPOSE = 'sim.convexDecompose(sim.getObject("/Torus"), 128, {0, 0, 0, 0, 0, 400000, 0, 0, 0, 64}, {0, 0, 0, 0, 0, 0, 0, 0, 0, 0})'
SCRIPTS = {
    "simOMPL.solve(task, 1e9) in sysCall_init": TASK + "function sysCall_init() simOMPL.solve(blocked(), 1e9) end\n",
    "simOMPL.solve(task, 10) again and again in a thread":
        TASK + "function sysCall_thread() local t = blocked() for i = 1, 3 do simOMPL.solve(t, 10) end end\n",
    "sim.convexDecompose at 400,000 voxels in sysCall_init": f"function sysCall_init() {DECOMPOSE} end\n",
    "sim.convexDecompose at 400,000 voxels in a thread": f"function sysCall_thread() {DECOMPOSE} end\n",
    "40 user parameters of 100 MiB": 'function sysCall_init() for i = 1, 40 do '
                                     'pcall(sim.setUserParameter, sim.handle_self, "p" .. i, string.rep("x", 100 * 1048576)) '
                                     'collectgarbage() end end\n',
}
THREAD = "function sysCall_thread() while true do local x = 0 for i = 1, 1000 do x = x + i end end end\n"


def _scene(folder: Path, scripts: dict[str, str]) -> list[Path]:
    """The client's scene file and its scripts (one body each)."""
    vertex, face = _torus()
    bodies = "".join(f'<body name="{n}" pos="{k} 2 0"><geom type="box" size="0.01 0.01 0.01" contype="0" '
                     'conaffinity="0"/></body>' for k, n in enumerate(scripts))
    texts = "".join(f'<text name="simx:{n}" data="child_script={n}.lua script_timeout=1e3"/>' for n in scripts)
    files = [folder / "client.xml"]
    files[0].write_text(ARM.format(vertex=vertex, face=face, bodies=bodies, texts=texts))
    for name, source in scripts.items():
        (folder / f"{name}.lua").write_text(source)
        files.append(folder / f"{name}.lua")
    return files


def attack(t: Target, files: list[Path], seconds: float) -> str:
    """Send and load the client's scene, let it run ``seconds``; the probe's figures."""
    from simx_client import api
    from simx_wire import protocol as P

    probe = Probe(t, "legacy", timeout=60.0)
    time.sleep(1.0)
    cid = api.simxStart("127.0.0.1", t.port, True, True, 5000, 5)
    for file in files:
        api.simxTransferFile(cid, str(file), file.name, 60, P.MODE_BLOCKING)
    api.simxStopSimulation(cid, P.MODE_BLOCKING)  # a scene loads while stopped
    start = time.monotonic()
    rc = api.simxLoadScene(cid, str(files[0]), 1, P.MODE_BLOCKING)  # sends the file first
    api.simxStartSimulation(cid, P.MODE_BLOCKING)
    loaded = time.monotonic() - start
    time.sleep(seconds)
    api.simxFinish(cid)
    return f"load rc {rc} ({loaded:.1f} s); {probe.result()}"


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--code", type=Path, default=ROOT, help="checkout whose simx_server runs (default: this one)")
    p.add_argument("--only", action="append", metavar="WORD", help="attacks whose name holds WORD (repeatable)")
    args = p.parse_args(argv)
    attacks = {name: ({f"S{k}": source}, 30.0) for k, (name, source) in enumerate(SCRIPTS.items())}
    attacks["200 auto-switched threaded scripts"] = ({f"T{k}": THREAD for k in range(200)}, 30.0)
    print(f"code: {args.code}; load average {os.getloadavg()[0]:.1f}")
    print("| client scene's script | server RSS before -> peak -> 10 s after | result |")
    print("|---|---|---|")
    for name, (scripts, seconds) in attacks.items():
        if args.only and not any(w in name for w in args.only):
            continue
        folder = Path(tempfile.mkdtemp(prefix="simx-script-attack-"))
        (folder / "scene.xml").write_text(ARM.format(vertex="0 0 0 1 0 0 0 1 0 0 0 1", face="0 1 2 0 2 3 0 3 1 1 3 2",
                                                     bodies="", texts=""))
        (folder / "client").mkdir()
        files = _scene(folder / "client", scripts)
        t = Target(args.code, folder, extra=("--allow-remote-code",))
        try:
            result = attack(t, files, seconds)
            time.sleep(10)
            print(f"| {name} | {t.before:.0f} -> {t.peak:.0f} -> {t.rss():.0f} MB | {result} |", flush=True)
        finally:
            t.stop()


if __name__ == "__main__":
    main()
