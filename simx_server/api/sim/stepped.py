"""Calls that last several simulation steps, as a ZMQ client sees them (``sim.moveToConfig``,
``sim.moveToPose``, ``sim.wait``, ``sim.waitForSignal``).

In CoppeliaSim these are Lua functions of the ``sim`` namespace that call ``sim.step()`` in a
loop: over the ZMQ remote API the client's call is answered ``_*wait*_`` at each of those steps
and returns when the motion ends. simx runs them the same way: for a remote client each of
these functions returns a :class:`Stepped` (a generator that yields once per step it wants),
which :mod:`simx_server.zmq.service` drives, one increment per simulation step, the client
stepped meanwhile (as CoppeliaSim's ``sim.setStepping(true)`` inside them). The motions are
those child scripts run (:mod:`simx_server.api.sim.motion`, one implementation); a 4.3-4.5
callback is the client's Python function, passed as ``"NAME@func"``: the generator yields a
:class:`CallbackCall` for it, which the service sends the client as ``{func: NAME, args}``.
"""

from __future__ import annotations

from typing import Any, Generator

from simx_wire.protocol import ArgumentError

#: The most steps one such call lasts.
MAX_MOTION_STEPS = 100_000


class CallbackCall:

    """A motion's request to run its caller's ``callback`` with ``args`` (a list) before it
    waits for the next step; the driver sends the generator the callback's return values."""

    __slots__ = ("callback", "args")

    def __init__(self, callback: Any, args: list):
        self.callback, self.args = callback, args


class Stepped:
    """A call that lasts several steps: ``generator`` yields once per step it wants (``None``) or
    a :class:`CallbackCall`, and returns the call's return value (a list of values)."""

    __slots__ = ("generator",)

    def __init__(self, generator: Generator[Any, Any, list]):
        self.generator = generator


def zmq_callback(callback: Any) -> str:
    """A 4.3-4.5 callback as the ZMQ client passes its Python function: ``"NAME@func"``; returns
    ``NAME``, which the client's reply ``{func: NAME, args}`` runs."""
    if not isinstance(callback, str) or not callback.endswith("@func") or len(callback) <= 5:
        raise ArgumentError(
            f'the 4.3-4.5 form\'s callback must be a function (the client sends "NAME@func"), '
            f"got {type(callback).__name__}"
        )
    return callback[:-5]


def strings_as_text(value: Any) -> Any:
    """Lua strings (bytes) as text where they are UTF-8, in nested lists and dicts."""
    if isinstance(value, bytes):
        try:
            return value.decode("utf-8")
        except UnicodeDecodeError:
            return value
    if isinstance(value, list):
        return [strings_as_text(v) for v in value]
    if isinstance(value, dict):
        return {strings_as_text(k): strings_as_text(v) for k, v in value.items()}
    return value
