"""Profile the worst-ratio figures with pyinstrument: the server (its simulation thread, the
main thread, where every request is executed) and the client side, under one workload.

    python -m benchmarks.profile calls          # 3000 blocking simxGetJointPosition
    python -m benchmarks.profile image          # sync mode: trigger + simxGetVisionSensorImage x40
    python -m benchmarks.profile stream-image   # streamed kinect_rgb, legacy buffer loop, 6 s
    python -m benchmarks.profile clients        # 16 client processes, blocking calls, 5 s

Writes benchmarks/results/profiles/<workload>-server.txt and -client.txt (pyinstrument text
reports; wall time, so time waiting in queue.get is the server being idle). Needs
``pip install -r benchmarks/requirements.txt``.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")

from benchmarks import clients as clients_suite  # noqa: E402
from benchmarks.common import Settings, connect  # noqa: E402
from benchmarks.procs import ROOT, SCENE, Proc, child_env, free_port  # noqa: E402
from simx_client import api  # noqa: E402
from simx_client import constants as C  # noqa: E402

OUT = Path(__file__).resolve().parent / "results" / "profiles"
B = C.simx_opmode_blocking


def profiled_server(name: str, *args: str) -> tuple[Proc, int, Path]:
    port = free_port()
    out = OUT / f"{name}-server.txt"
    cmd = [sys.executable, "-m", "pyinstrument", "-r", "text", "--no-color", "-o", str(out),
           "-m", "simx_server.cli", str(SCENE), "--port", str(port), "--log-level", "WARNING", *args]
    return Proc(f"profile-{name}-server", cmd, OUT / "logs", env=child_env(), cwd=ROOT), port, out


def workload_calls(cid: int) -> None:
    h = api.simxGetObjectHandle(cid, "UR5_joint1", B)[1]
    for _ in range(3000):
        api.simxGetJointPosition(cid, h, B)


def workload_image(cid: int) -> None:
    h = api.simxGetObjectHandle(cid, "kinect_rgb", B)[1]
    api.simxSynchronous(cid, True)
    api.simxStartSimulation(cid, B)
    for _ in range(40):
        api.simxSynchronousTrigger(cid)
        api.simxGetVisionSensorImage(cid, h, 0, B)
    api.simxSynchronous(cid, False)


def workload_stream_image(cid: int) -> None:
    h = api.simxGetObjectHandle(cid, "kinect_rgb", B)[1]
    api.simxGetVisionSensorImage(cid, h, 0, C.simx_opmode_streaming)
    end = time.monotonic() + 6
    while time.monotonic() < end:
        if api.simxGetVisionSensorImage(cid, h, 0, C.simx_opmode_buffer)[0] != 0:
            time.sleep(0.001)
    api.simxGetVisionSensorImage(cid, h, 0, C.simx_opmode_discontinue)


WORKLOADS = {"calls": workload_calls, "image": workload_image, "stream-image": workload_stream_image,
             "clients": None}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.profile", description=__doc__.splitlines()[0])
    p.add_argument("workload", choices=list(WORKLOADS))
    args = p.parse_args(argv)
    from pyinstrument import Profiler

    OUT.mkdir(parents=True, exist_ok=True)
    srv, port, server_out = profiled_server(args.workload)
    try:
        if args.workload == "clients":
            cid = connect(port)
            names = [[n, api.simxGetObjectHandle(cid, n, B)[1]] for n in clients_suite.NAMES]
            api.simxFinish(cid)
            got = clients_suite._run_count(Settings(False, OUT / "logs"), port, names, 16, 5.0)
            print(json.dumps({k: got[k] for k in ("calls", "lost", "mismatched", "throughput")}, indent=1))
        else:
            cid = connect(port)
            profiler = Profiler(interval=0.0005)
            profiler.start()
            try:
                WORKLOADS[args.workload](cid)
            finally:
                profiler.stop()
                api.simxFinish(cid)
            client_out = OUT / f"{args.workload}-client.txt"
            client_out.write_text(profiler.output_text(unicode=False, color=False))
            print(f"client profile: {client_out}")
    finally:
        srv.stop(timeout=30)
    print(f"server profile: {server_out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
