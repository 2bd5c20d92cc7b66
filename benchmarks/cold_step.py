"""What a simulation step costs after a wait (issue 44): the ``sync`` suite's floor steps back
to back, hot; a server's step follows a wait for the client's trigger.

    MUJOCO_GL=egl python -m benchmarks.cold_step

Times ``Simulation.step()`` of the benchmarks' scene (dt 50 ms) in this process, median of
``n`` steps, after each kind of gap: none (back to back, the floor), a sleep, a wake-up by
another thread, a busy-wait (the core never idles), and touching 4 MB of memory (the L2's size
here). Not a suite of ``run.py``: a measurement of the machine, quoted in benchmarks/README.md.
"""

from __future__ import annotations

import statistics
import threading
import time

import numpy as np

from benchmarks.procs import SCENE


def _gap_sleep(s: float):
    return lambda: time.sleep(s)


def _gap_woken() -> None:
    event = threading.Event()
    threading.Timer(0.0005, event.set).start()
    event.wait()


def _gap_spin(s: float):
    def spin() -> None:
        end = time.perf_counter() + s
        while time.perf_counter() < end:
            pass
    return spin


def main(n: int = 1000) -> None:
    from simx_server.scene.simulation import Simulation

    sim = Simulation(SCENE, 0.05)
    sim.start()
    junk = np.zeros(4 * 1024 * 1024 // 8)
    gaps = {"back to back": None, "sleep 0.3 ms": _gap_sleep(0.0003), "sleep 1 ms": _gap_sleep(0.001),
            "woken by a thread after 0.5 ms": _gap_woken, "busy-wait 0.3 ms": _gap_spin(0.0003),
            "busy-wait 1 ms": _gap_spin(0.001), "touch 4 MB": junk.sum}
    try:
        for _ in range(200):
            sim.step()
        for name, gap in gaps.items():
            times = []
            for _ in range(n):
                if gap is not None:
                    gap()
                t0 = time.perf_counter()
                sim.step()
                times.append(time.perf_counter() - t0)
            print(f"{name:32s} {statistics.median(times) * 1e6:6.0f} us")
    finally:
        sim.close()


if __name__ == "__main__":
    main()
