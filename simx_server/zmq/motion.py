"""Calls that last several simulation steps, for ZMQ clients: ``sim.moveToConfig``,
``sim.moveToPose``, ``sim.wait``.

In CoppeliaSim these are Lua functions of the ``sim`` namespace that call ``sim.step()`` in a
loop: over the ZMQ remote API the client's call is answered ``_*wait*_`` at each of those steps
and returns when the motion ends. simx runs them the same way: each call returns a
:class:`Stepped` (a generator that yields once per step it wants), which
:mod:`simx_server.zmq.service` drives, one increment per simulation step, the client stepped
meanwhile (as CoppeliaSim's ``sim.setStepping(true)`` inside them). The motions are the script
facade's (:mod:`simx_server.scripts.facade_motion`, one implementation); a 4.3-4.5 callback is
the client's Python function, passed as ``"NAME@func"``: the generator yields a
:class:`CallbackCall` for it, which the service sends the client as ``{func: NAME, args}``.
"""

from __future__ import annotations

from typing import Any, Generator

from simx_wire.protocol import ArgumentError, UnsupportedError
from simx_server.base.arguments import as_number as _num
from simx_server.scripts.facade_motion import MAX_MOTION_STEPS, CallbackCall, MotionCore

__all__ = ["MAX_MOTION_STEPS", "CallbackCall", "MotionCalls", "Stepped"]


class Stepped:
    """A call that lasts several steps: ``generator`` yields once per step it wants (``None``) or
    a :class:`CallbackCall`, and returns the call's return value (a list of values)."""

    __slots__ = ("generator",)

    def __init__(self, generator: Generator[Any, Any, list]):
        self.generator = generator


def _zmq_callback(callback: Any) -> str:
    """A 4.3-4.5 callback as the ZMQ client passes its Python function: ``"NAME@func"``; returns
    ``NAME``, which the client's reply ``{func: NAME, args}`` runs."""
    if not isinstance(callback, str) or not callback.endswith("@func") or len(callback) <= 5:
        raise ArgumentError(
            f'the 4.3-4.5 form\'s callback must be a function (the client sends "NAME@func"), '
            f"got {type(callback).__name__}"
        )
    return callback[:-5]


class MotionCalls(MotionCore):
    """``sim.moveToConfig``, ``sim.moveToPose`` and ``sim.wait`` (mixin of RemoteSim)."""

    def moveToConfig(self, params: Any, *legacy: Any) -> Stepped:  # noqa: N802 (CoppeliaSim's names)
        """Move joints along a jerk-limited trajectory, one increment per simulation step: the
        script facade's ``sim.moveToConfig`` (its map form and 4.3-4.5's positional form, whose
        callback is the client's ``"NAME@func"``), lasting several steps."""
        return Stepped(self._config_motion(params, legacy, _zmq_callback))

    def moveToPose(self, params: Any, *legacy: Any) -> Stepped:  # noqa: N802
        """Move an object or a pose along a jerk-limited trajectory, one increment per simulation
        step: the script facade's ``sim.moveToPose`` (map and 4.3-4.5 forms), lasting several steps."""
        return Stepped(self._pose_motion(params, legacy, _zmq_callback))

    def wait(self, dt: Any, simulationTime: Any = True) -> Stepped:  # noqa: N803
        """Let ``dt`` s of simulation time pass (one step at least); returns the time left over
        (0 or negative: the steps' overshoot). Only simulation time (``simulationTime`` true)."""
        span = _num(dt, "dt")
        if not simulationTime:
            raise UnsupportedError("sim.wait with system time is not supported: give simulation time")
        world = self._world

        def waiting() -> Generator[None, None, list]:
            end = world.time + span
            for _ in range(MAX_MOTION_STEPS):
                yield
                if world.time >= end - 1e-9:
                    break
            return [end - world.time]

        return Stepped(waiting())
