"""simx-server with three probes: the wall time at the end of every simulation step, the
duration of every vision-sensor frame the server produces, and every request that reaches a
client's queue.

``python -m benchmarks.instrumented_server [simx-server arguments]`` runs
``simx_server.cli.main`` unchanged except that

* ``Simulation.step`` is wrapped to record ``(sim_time_ms, time.monotonic())`` right after the
  step (before the server publishes the streams);
* ``VisionSensors._render`` (on the render thread) is wrapped to record
  ``(kind, start, duration)`` of every frame actually rendered ("image" for RGB, "depth");
  the flip and copy to bytes that follow (about 1 ms) fall into "transfer";
* ``Sessions.admit`` (on Zenoh's threads) is wrapped to record ``(time.monotonic(), commands,
  queued)`` of every readable request: how many requests a client puts on the wire, and which
  the server answered "server busy" instead of queueing (``queued`` false).

On exit the records go, as JSON ``{"steps": [...], "frames": [...], "requests": [...]}``, to the file named by
``SIMX_BENCH_PROBE_LOG``. With ``SIMX_BENCH_CPROFILE=FILE`` the whole server (its main thread,
where requests execute) also runs under cProfile and its stats go to FILE (pstats format). CLOCK_MONOTONIC is system-wide on Linux, so a client process can
compare its own ``time.monotonic()`` with these stamps. Cost: a clock read or two and a list
append per step or frame.
"""

from __future__ import annotations

import collections
import functools
import inspect
import json
import os
import sys
import time

from simx_server import cli
from simx_server.scene.simulation import Simulation
from simx_server.sim.vision import VisionSensors
from simx_server.legacy.sessions import Sessions

_MAX_RECORDS = 200_000
_steps: collections.deque = collections.deque(maxlen=_MAX_RECORDS)
_frames: collections.deque = collections.deque(maxlen=_MAX_RECORDS)
_requests: collections.deque = collections.deque(maxlen=_MAX_RECORDS)


def _argument(original, name: str):
    """``get(args, kwargs)``: the argument ``name`` of a call to ``original``, read from the
    function's own signature, so that a wrapper passes every argument through unchanged and
    names only the one it records (a probe that copied the signature went stale when
    ``Sessions.admit`` gained arguments, and the image suites stopped running; a parameter
    renamed now fails here, at the server's start)."""
    names = list(inspect.signature(original).parameters)
    if name not in names:
        raise TypeError(f"benchmarks.instrumented_server: {original.__qualname__} has no parameter {name!r} "
                        f"(its parameters: {names}); update the probe")
    at = names.index(name)

    def get(args: tuple, kwargs: dict):
        return kwargs[name] if name in kwargs else args[at]
    return get


def _wrap_step(original):
    @functools.wraps(original)
    def step(self: Simulation, *args, **kwargs):
        out = original(self, *args, **kwargs)
        _steps.append((self.sim_time_ms, time.monotonic()))
        return out
    return step


def _wrap_render(original):
    kind_of = _argument(original, "kind")

    @functools.wraps(original)
    def render(*args, **kwargs):
        t0 = time.monotonic()
        try:
            return original(*args, **kwargs)
        finally:
            _frames.append(("image" if kind_of(args, kwargs) == "rgb" else "depth", t0, time.monotonic() - t0))
    return render


def _wrap_admit(original):
    request_of = _argument(original, "request")

    @functools.wraps(original)
    def admit(*args, **kwargs):
        refused = original(*args, **kwargs)
        commands = request_of(args, kwargs)[1]
        _requests.append((time.monotonic(), len(commands), refused is None))  # deque.append: thread-safe
        return refused
    return admit


def main(argv: list[str] | None = None) -> int:
    Simulation.step = _wrap_step(Simulation.step)
    VisionSensors._render = _wrap_render(VisionSensors._render)
    Sessions.admit = _wrap_admit(Sessions.admit)
    profile_path = os.environ.get("SIMX_BENCH_CPROFILE")
    profiler = None
    if profile_path:
        import cProfile

        profiler = cProfile.Profile()
    try:
        return profiler.runcall(cli.main, argv) if profiler else cli.main(argv)
    finally:
        if profiler:
            profiler.dump_stats(profile_path)
        path = os.environ.get("SIMX_BENCH_PROBE_LOG")
        if path:
            with open(path, "w") as f:
                json.dump({"steps": list(_steps), "frames": list(_frames), "requests": list(_requests)}, f)


if __name__ == "__main__":
    sys.exit(main())
